"""eMD* in the event engine (physics.md §4.8): A/B events, exceptions, pending contacts."""

import doctest
import math
import zlib

import numpy as np
import pytest
from reference import direct_two_spheres, random_contact
from test_twobody_friction import random_collision, reference

import edmd
import edmd.physics.emdstar
from edmd import Hertz, LinearDashpot, Simulation, State
from edmd.physics.collide import Inelastic, Rough, RuleError, TC, Wall
from edmd.physics.emdstar import EMDStar, EMDStarError
from edmd.physics.friction import Friction
from edmd.physics.twobody import collide_frictional

CONTACTS = [
    (LinearDashpot(k=1e4, gamma=20.0), 1.0),
    (LinearDashpot(k=500.0, gamma=8.0), 3.0),  # very soft: Lambda ~ 0.1
    (Hertz(young=1e6, poisson=0.3, A=1e-3), 1.0),
    (Hertz(young=600.0, poisson=0.3, A=2e-2), 2.0),  # very soft: Lambda ~ 0.13, delta ~ 0.35
]
M, R = (1.0, 2.5), (0.5, 0.8)


def two_body_state(r0, v0, dim, lead, gravity=None, box=40.0):
    """Two spheres that touch at time ``lead`` at ``r0`` with velocities ``v0`` (free flight before)."""
    G = np.zeros(3) if gravity is None else gravity
    pos = [r - v * lead + 0.5 * G * lead**2 for r, v in zip(r0, v0)]
    vel = [v - G * lead for v in v0]
    periodic = gravity is None
    return State(
        position=np.array(pos)[:, :dim], velocity=np.array(vel)[:, :dim], radius=R, mass=M,
        box=[box] * dim, periodic=[periodic] * dim,
    )  # fmt: skip


@pytest.mark.parametrize("contact, speed", CONTACTS, ids=[f"{c.name}-{i}" for i, (c, _s) in enumerate(CONTACTS)])
@pytest.mark.parametrize("tables, tol", [("exact", 1e-8), ("default", 1e-6)])
def test_two_body_matches_newton(contact, speed, tables, tol, dim, rng):
    """A and B events reproduce a direct Cartesian integration (physics.md §4.10(d)) after the contact."""
    for b in (0.0, 0.3, 0.7, 0.95):
        r0, v0 = random_contact(rng, dim, R, speed, b)
        lead = 0.5 / speed
        sim = Simulation(two_body_state(r0, v0, dim, lead), collision=EMDStar(contact, tables=tables))
        tc, _pos, _vel = direct_two_spheres(contact, M, R, r0, v0, np.zeros(3), 1.0)
        t_end = lead + 3.0 * tc
        tc, pos, vel = direct_two_spheres(contact, M, R, r0, v0, np.zeros(3), 3.0 * tc)
        sim.run(until_time=t_end)
        s = sim.state
        assert not s.has_pending
        assert sim.engine.emd_counters()["emd_contacts"] == 1
        unwrapped = s.unwrapped_position
        for k in range(2):
            assert np.max(np.abs(unwrapped[k] - pos[k][:dim])) < tol * (R[0] + R[1])
            assert np.max(np.abs(s.velocity[k] - vel[k][:dim])) < tol * speed


@pytest.mark.parametrize("contact, speed", CONTACTS, ids=[f"{c.name}-{i}" for i, (c, _s) in enumerate(CONTACTS)])
def test_one_species_contacts_use_the_pair_table(contact, speed, dim, rng):
    """Spheres of one mass and radius take the matrix of restitution from the pair table
    (physics.tables.pair_table); their contacts reproduce a direct Cartesian integration to 1e-6,
    as the three-dimensional table does for unlike pairs (test_two_body_matches_newton)."""
    m, r = (1.0, 1.0), (0.5, 0.5)
    for b in (0.0, 0.5, 0.9):
        r0, v0 = random_contact(rng, dim, r, speed, b)
        lead = 0.5 / speed
        pos = [x - v * lead for x, v in zip(r0, v0)]
        state = State(position=np.array(pos)[:, :dim], velocity=np.array(v0)[:, :dim], radius=r, mass=m, box=[40.0] * dim)
        sim = Simulation(state, collision=EMDStar(contact))
        assert sim.engine.emd.pair_grid[:, :4].tolist() == [[1.0, 0.5, 1.0, 0.5]]
        tc, _pos, _vel = direct_two_spheres(contact, m, r, r0, v0, np.zeros(3), 1.0)
        tc, pos, vel = direct_two_spheres(contact, m, r, r0, v0, np.zeros(3), 3.0 * tc)
        sim.run(until_time=lead + 3.0 * tc)
        s = sim.state
        assert sim.engine.emd_counters()["emd_contacts"] == 1 and not s.has_pending
        for k in range(2):
            assert np.max(np.abs(s.unwrapped_position[k] - pos[k][:dim])) < 1e-6
            assert np.max(np.abs(s.velocity[k] - vel[k][:dim])) < 1e-6 * speed
    two = State(position=[[0.0] * dim, [3.0] + [0.0] * (dim - 1)], velocity=[[0.0] * dim] * 2, radius=(0.5, 0.6), mass=1.0, box=[40.0] * dim)
    assert Simulation(two, collision=EMDStar(contact)).engine.emd.pair_grid[:, :4].tolist() == [[1.0, 0.5, 1.0, 0.5], [1.0, 0.5, 1.0, 0.6], [1.0, 0.6, 1.0, 0.6]]
    many = State(position=[[3.0 * k] + [0.0] * (dim - 1) for k in range(4)], velocity=[[0.0] * dim] * 4, radius=(0.5, 0.6, 0.7, 0.8), mass=1.0, box=[40.0] * dim)
    assert math.isnan(Simulation(many, collision=EMDStar(contact)).engine.emd.pair_grid[0, 0])  # (more species than PAIR_SPECIES)


def test_two_body_with_gravity(rng):
    """With gravity the pair falls with V + G t during the contact; B adds the increments (physics.md §4.6)."""
    contact = Hertz(young=1e6, poisson=0.3, A=1e-3)
    G = np.array([0.0, 0.0, -9.81])
    r0, v0 = random_contact(rng, 3, R, 1.0, 0.6)
    lead = 0.3
    sim = Simulation(two_body_state(r0, v0, 3, lead, gravity=G), collision=EMDStar(contact, tables="exact"), gravity=G)
    tc, _p, _v = direct_two_spheres(contact, M, R, r0, v0, G, 1.0)
    tc, pos, vel = direct_two_spheres(contact, M, R, r0, v0, G, 3.0 * tc)
    sim.run(until_time=lead + 3.0 * tc)
    s = sim.state
    for k in range(2):
        assert np.max(np.abs(s.position[k] - pos[k])) < 1e-8 * (R[0] + R[1])
        assert np.max(np.abs(s.velocity[k] - vel[k])) < 1e-8


def test_a_state_with_pending_contacts_can_be_assigned(rng, dim):
    """``sim.state = s`` takes eMD* states mid-contact, as checkpoints do, and continues the contact."""
    contact = Hertz(young=600.0, poisson=0.3, A=2e-2)
    r0, v0 = random_contact(rng, dim, R, 2.0, 0.5)
    sim = Simulation(two_body_state(r0, v0, dim, 0.25), collision=EMDStar(contact, tables="exact"))
    tc, _p, _v = direct_two_spheres(contact, M, R, r0, v0, np.zeros(3), 1.0)
    sim.run(until_time=0.25 + 0.5 * tc)
    mid = sim.state
    assert mid.has_pending and mid.overlapping_pair() is not None
    again = Simulation(two_body_state(r0, v0, dim, 0.25), collision=EMDStar(contact, tables="exact"))
    again.state = mid
    for s in (sim, again):
        s.run(until_time=0.25 + 2.0 * tc)
    np.testing.assert_allclose(again.state.velocity, sim.state.velocity, rtol=0, atol=1e-12)
    np.testing.assert_allclose(again.state.unwrapped_position, sim.state.unwrapped_position, rtol=0, atol=1e-12)


def test_pending_contact_observables_and_conservation(rng, dim):
    """Between A and B: committed velocities carry the momentum and energy (physics.md §4.8, T12)."""
    contact = Hertz(young=600.0, poisson=0.3, A=2e-2)
    r0, v0 = random_contact(rng, dim, R, 2.0, 0.5)
    state = two_body_state(r0, v0, dim, 0.25)
    sim = Simulation(state, collision=EMDStar(contact, tables="exact"))
    tc, _p, _v = direct_two_spheres(contact, M, R, r0, v0, np.zeros(3), 1.0)
    sim.run(until_time=0.25 + 0.5 * tc)
    mid = sim.state
    assert mid.has_pending and list(mid.pending_partner) == [1, 0]
    np.testing.assert_allclose(mid.velocity[0], mid.velocity[1], rtol=0, atol=0)  # both move with V
    np.testing.assert_allclose(mid.momentum(), state.momentum(), rtol=1e-14, atol=1e-14)
    sim.run(until_time=0.25 + 2.0 * tc)
    end = sim.state
    assert not end.has_pending
    np.testing.assert_allclose(end.momentum(), state.momentum(), rtol=1e-14, atol=1e-14)
    # kinetic + dissipated is conserved; the mid-contact value books the loss already (committed)
    totals = sim.totals()
    assert mid.kinetic_energy() == pytest.approx(end.kinetic_energy(), rel=1e-13)
    assert end.kinetic_energy() + totals.dissipated == pytest.approx(state.kinetic_energy(), rel=1e-13)
    assert totals.dissipated > 0


def test_elastic_contact_conserves_energy(dim, rng):
    """Elastic Hertz: D = 1, eps = 1, so no energy is lost (physics.md §4.5)."""
    r0, v0 = random_contact(rng, dim, R, 1.0, 0.8)
    state = two_body_state(r0, v0, dim, 0.3)
    sim = Simulation(state, collision=EMDStar(Hertz(young=1e5, poisson=0.3, A=0.0)))
    sim.run(until_time=2.0)
    assert sim.state.kinetic_energy() == pytest.approx(state.kinetic_energy(), rel=1e-13)
    assert abs(sim.totals().dissipated) < 1e-13 * state.kinetic_energy()


def test_classic_edmd_differs_from_emd_star(rng):
    """The instantaneous rule with the same central e_n misses oblique soft contacts (physics.md §4.10(d))."""
    contact = Hertz(young=600.0, poisson=0.3, A=2e-2)
    r0, v0 = random_contact(rng, 3, R, 2.0, 0.7)
    state = two_body_state(r0, v0, 3, 0.25)
    emd = Simulation(state, collision=EMDStar(contact, tables="exact"))
    classic = Simulation(state, collision=contact)  # (the material as the instantaneous rule)
    for sim in (emd, classic):
        sim.run(until_time=1.0)
    gap = np.abs(emd.state.unwrapped_position - classic.state.unwrapped_position).max()
    assert gap > 1e-2 * (R[0] + R[1])


def exception_a_state():
    """0 and 1 touch obliquely; the relocation swings 1 (down, -y) into 2, which rests nearby."""
    pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.2, -1.001, 0.0]]
    vel = [[0.5, 0.5, 0.0], [-0.5, -0.5, 0.0], [0.0, 0.0, 0.0]]
    return State(position=pos, velocity=vel, radius=0.5, mass=1.0, box=[20.0] * 3)


def test_exception_a_falls_back_to_the_instantaneous_rule():
    """a) relocation overlapping a third particle: instantaneous rule with the central e_n(v_n) (physics.md §4.8)."""
    contact = Hertz(young=50.0, poisson=0.3, A=0.01)  # very soft: a large rotation Phi
    state = exception_a_state()
    sim = Simulation(state, collision=EMDStar(contact, tables="exact"))
    sim.run(max_events=1)
    c = sim.engine.emd_counters()
    assert c["emd_exceptions_a"] == 1 and c["emd_fallbacks"] == 1 and c["emd_contacts"] == 0
    s = sim.state
    np.testing.assert_array_equal(s.position[:2], state.position[:2])  # positions unchanged
    g = state.velocity[0] - state.velocity[1]
    n = np.array([-1.0, 0.0, 0.0])
    e_n = contact.central(1.0, 1.0, 0.5, 0.5, v_n=-(g @ n)).e_n
    g_after = s.velocity[0] - s.velocity[1]
    assert g_after @ n == pytest.approx(-e_n * (g @ n), rel=1e-6)
    assert g_after[1] == pytest.approx(g[1], rel=1e-14)  # tangential part unchanged


@pytest.mark.parametrize("communication", [True, False])
def test_exception_b_executes_pending_b_events(communication):
    """b) a particle with a pending B meets a third particle: B first, then the contact (physics.md §4.8)."""
    contact = Hertz(young=20.0, poisson=0.3, A=0.0)  # long contacts
    pos = [[0.0, 0.0, 0.0], [1.0 + 1e-3, 0.0, 0.0], [2.0 + 0.02, 0.0, 0.0]]
    vel = [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]
    state = State(position=pos, velocity=vel, radius=0.5, mass=1.0, box=[20.0] * 3)
    sim = Simulation(state, collision=EMDStar(contact, tables="exact", communication=communication))
    sim.run(until_time=3.0)
    c = sim.engine.emd_counters()
    assert c["emd_exceptions_b"] >= 1
    s = sim.state
    assert not s.has_pending
    np.testing.assert_allclose(s.momentum(), state.momentum(), atol=1e-14)
    assert s.kinetic_energy() == pytest.approx(state.kinetic_energy(), rel=1e-12)  # elastic


def test_many_body_gas_runs_and_conserves(dim):
    """A dense soft gas: every kind of event and exception; momentum and energy balance hold."""
    state = edmd.maxwell_boltzmann(edmd.lattice(64 if dim == 2 else 125, 0.3, dim=dim), 1.0, seed=3)
    rule = EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3))
    sim = Simulation(state, collision=rule)
    e0 = state.kinetic_energy()
    sim.run(until_time=5.0)
    c = sim.engine.emd_counters()
    assert c["emd_contacts"] > 100 and c["emd_exceptions_b"] > 0 and c["emd_exceptions_a"] > 0
    s = sim.state
    np.testing.assert_allclose(s.momentum(), 0.0, atol=1e-12)
    assert s.kinetic_energy() + sim.totals().dissipated == pytest.approx(e0, rel=1e-11)
    assert s.kinetic_energy() < e0


def test_cells_and_lists_give_the_same_contacts(dim):
    """In cells mode an A event predicts both partners in its relocation scans (emdstar.relocation_scan),
    list mode by the full re-prediction over the lists: the same contacts, exceptions included.
    The lists are cut to the fullest again and again, so that they overflow, also in the A events'
    relocations (a contact made there, then a resync, is counted and logged all the same)."""
    state = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.1, dim=dim, seed=7), 1.0, seed=8)
    rule = EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3))
    logs, counters = [], []
    for mode in ("cells", "list"):
        sim = Simulation(state, collision=rule, engine={"neighbours": mode})
        sim.engine.enable_log()
        overflows = 0
        for t in np.linspace(0.1, 3.0, 30):
            engine, cut = sim.engine, 0
            if mode == "list":
                members, size, _centre = engine.lists
                cut = engine.list_capacity = int(size.max())
                engine.lists = engine.lists._replace(members=np.ascontiguousarray(members[:, :cut]))
            sim.run(until_time=t)
            overflows += mode == "list" and engine.list_capacity != cut  # (an overflow grows the rows)
        logs.append(sim.engine.take_log())
        counters.append(sim.engine.emd_counters())
        assert sim.collisions == counters[-1]["emd_contacts"] + counters[-1]["emd_fallbacks"] == len(logs[-1])
    assert overflows > 2
    assert counters[0] == counters[1] and counters[0]["emd_contacts"] > 150 and counters[0]["emd_exceptions_b"] > 0
    assert len(logs[0]) == len(logs[1])
    assert np.array_equal(np.sort(logs[0][:, 1:3], axis=1), np.sort(logs[1][:, 1:3], axis=1))
    assert np.abs(logs[0][:, 0] - logs[1][:, 0]).max() < 1e-9


def test_kept_predictions_match_re_predicting_at_b_events(dim):
    """physics.md §4.8 (predictions across B events): a B event keeps the predictions made while
    the contact was pending (they followed the jump). Runs with the vibrating wall re-predict at
    every B event instead (the B event in loop.py); with an amplitude that vanishes in floating
    point (1e-200) the two paths must give the same contacts, and every contact must approach."""
    periodic = [True] * (dim - 1) + [False]
    state = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.1, dim=dim, periodic=periodic, seed=7), 1.0, seed=8)
    rule = EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3))
    logs, counters = [], []
    for vibration in (None, edmd.VibratingWall(amplitude=1e-200, omega=1.0, axis="xyz"[dim - 1])):
        sim = Simulation(state, collision=rule, walls=Wall(e_n=1.0), vibration=vibration)
        sim.engine.enable_log(walls=True)
        sim.run(until_time=3.0)
        logs.append(sim.engine.take_log())
        counters.append(sim.engine.emd_counters())
        assert sim.totals().wall_collisions > 10
    assert counters[0] == counters[1] and counters[0]["emd_contacts"] > 100 and counters[0]["emd_exceptions_b"] > 0
    kept, repredicted = logs
    assert len(kept) == len(repredicted)
    assert np.array_equal(np.sort(kept[:, 1:3], axis=1), np.sort(repredicted[:, 1:3], axis=1))
    assert np.abs(kept[:, 0] - repredicted[:, 0]).max() < 1e-10  # (1e-12 measured: rounding, amplified by the gas)
    contacts = kept[kept[:, 2] >= 0]
    assert np.all(contacts[:, 3] > 0.0)  # approaching: v_n > 0


def test_energy_balance_with_walls_and_gravity(dim):
    """Kinetic (committed) + potential + dissipated stays constant; particles in a contact that
    reach a wall complete it first (exception b), so the wall acts on their own velocity."""
    periodic = [True] * (dim - 1) + [False]
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.2, dim=dim, periodic=periodic, seed=9), 1.0, seed=10)
    g = np.zeros(dim)
    g[-1] = -0.5
    sim = Simulation(s, collision=EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3)), gravity=g)
    thermo = sim.add(edmd.Thermo(0.5))
    sim.run(until_time=4.0)
    balance = np.array([r["energy_balance"] for r in thermo.rows])
    assert np.abs(balance / balance[0] - 1.0).max() < 1e-10
    assert sim.totals().wall_collisions > 50 and sim.engine.emd_counters()["emd_exceptions_b"] > 0


def test_walls_use_the_contact_law(dim):
    """Walls with eMD*: the instantaneous rule with the contact law's e_n(v_n), mu = m, R_eff = R."""
    contact = Hertz(young=1e4, poisson=0.3, A=5e-3)
    pos = np.zeros((1, dim))
    vel = np.zeros((1, dim))
    vel[0, 0] = -2.0
    state = State(position=pos, velocity=vel, radius=0.5, mass=1.0, box=[4.0] * dim, periodic=[False] + [True] * (dim - 1))
    sim = Simulation(state, collision=EMDStar(contact))
    sim.run(until_time=1.0)
    expected = Wall(e_n=contact)
    ref = Simulation(state, collision=Inelastic(1.0), walls=expected)
    ref.run(until_time=1.0)
    assert sim.state.velocity[0, 0] == pytest.approx(ref.state.velocity[0, 0], rel=1e-12)
    assert 0 < sim.state.velocity[0, 0] < 2.0


def test_bad_settings_name_the_problem(tmp_path):
    with pytest.raises(EMDStarError, match="soft contact law"):
        EMDStar(Inelastic(0.9))
    with pytest.raises(EMDStarError, match="no table file"):
        EMDStar(Hertz(1e7, 0.3), tables=str(tmp_path / "missing.npz"))
    with pytest.raises(EMDStarError, match="communication"):
        EMDStar(Hertz(1e7, 0.3), communication="yes")
    with pytest.raises(RuleError, match="TC model does not apply"):
        TC(EMDStar(Hertz(1e7, 0.3)), 1e-4)
    s = State(position=[[0.0, 0.0], [0.9, 0.0]], velocity=[[0.0, 0.0], [0.0, 0.0]], radius=0.5, mass=1.0, box=[5.0, 5.0],
              pending_partner=[1, 0], pending_until=[1.0, 1.0], pending_velocity=[[0.1, 0.0], [-0.1, 0.0]])  # fmt: skip
    with pytest.raises(edmd.StateError, match="pending eMD"):
        Simulation(s)
    with pytest.raises(edmd.StateError, match="inconsistent pending"):
        State(position=[[0.0, 0.0]], velocity=[[0.0, 0.0]], radius=0.5, mass=1.0, box=[5.0, 5.0], pending_partner=[0])


def test_state_round_trips_pending_contacts(tmp_path, rng):
    contact = Hertz(young=600.0, poisson=0.3, A=2e-2)
    r0, v0 = random_contact(rng, 3, R, 2.0, 0.5)
    sim = Simulation(two_body_state(r0, v0, 3, 0.25), collision=EMDStar(contact, tables="exact"))
    sim.run(until_time=0.26)
    s = sim.state
    assert s.has_pending
    edmd.write_state(tmp_path / "s.gsd", s)
    back = edmd.read_state(tmp_path / "s.gsd")
    for name in ("position", "velocity", "pending_velocity", "pending_until", "pending_partner"):
        np.testing.assert_array_equal(getattr(back, name), getattr(s, name))


def test_examples_in_docstrings():
    assert doctest.testmod(edmd.physics.emdstar).failed == 0


def test_resync_keeps_pending_contacts_exact(rng):
    """A run cut into pieces with resyncs in between equals the uncut run (pending B's re-based)."""
    state = edmd.maxwell_boltzmann(edmd.lattice(125, 0.2), 1.0, seed=5)
    rule = EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3))
    a = Simulation(state, collision=rule)
    a.run(until_time=2.0)
    b = Simulation(state, collision=rule)
    for t in np.linspace(0.1, 2.0, 20):
        b.run(until_time=float(t))
        b.engine.resync(float(t))
    sa, sb = a.state, b.state
    assert a.collisions == b.collisions
    np.testing.assert_allclose(sb.unwrapped_position, sa.unwrapped_position, atol=1e-9)
    np.testing.assert_allclose(sb.committed_velocity, sa.committed_velocity, atol=1e-9)
    assert math.isfinite(sa.kinetic_energy())


def gas_comparison(model, dim, eta, t_end, steps):
    """eMD* (default tables), classic EDMD with the same central e_n(v) and DEM at ``steps`` per contact, from one state.

    Returns the final states and which particles had a soft contact in eMD* (collision log).
    """
    state = edmd.maxwell_boltzmann(edmd.random_packing(1000, eta, dim=dim, seed=4), 1.0, seed=5)
    if model == "hertz":  # t_c ~ 0.01, e_n ~ 0.9 at the thermal speed
        contact = Hertz(young=2.5e6, poisson=0.3, A=2e-4)
        classic = contact  # (the material as the instantaneous rule)
    else:
        contact = LinearDashpot.from_restitution(0.9, k=4.9e4, mass=1.0)
        classic = contact.restitution_rule(1.0)
    runs = [Simulation(state, collision=EMDStar(contact)), Simulation(state, collision=classic)]
    runs += [edmd.DEMSimulation(state, contact, steps_per_contact=s) for s in steps]
    runs[0].engine.enable_log()
    for sim in runs:
        sim.run(until_time=t_end)
    collided = np.zeros(state.n, bool)
    collided[runs[0].engine.take_log()[:, 1:3].astype(int).ravel()] = True
    return [sim.state for sim in runs], collided


@pytest.mark.parametrize("model", ["hertz", "dashpot"])
def test_dilute_gas_follows_force_based_md(model, dim):
    """Same initial state: eMD* particles follow the DEM trajectories, which converge to them as dt -> 0
    (~1e-6 sigma at 400 steps per contact); classic EDMD visibly does not (physics.md §4.8).

    Statistics over the particles that had a contact and are not in one now (those follow eMD*'s
    surrogate path); medians, because the rare three-body encounters (exceptions) are not exact.
    """
    (emd, classic, coarse, fine), collided = gas_comparison(model, dim, 0.02, 1.0, (100, 400))
    sel = collided & (emd.pending_partner < 0)
    assert sel.sum() > 60
    dist = [np.linalg.norm(s.unwrapped_position - emd.unwrapped_position, axis=1)[sel] for s in (classic, coarse, fine)]
    assert np.median(dist[2]) < 2e-6
    assert np.median(dist[2]) < np.median(dist[1]) / 4  # DEM's time-step error, not a difference of physics
    assert np.median(dist[0]) > 1e-3  # the instantaneous rule misses oblique contacts
    assert emd.temperature() == pytest.approx(fine.temperature(), rel=2e-3)


# ---------------------------------------------------------------------------------------------
# frictional contacts (docs/physics.md §4.8, §4.11)

FRICTIONAL = {
    "dashpot-linear": (LinearDashpot(k=1e5, gamma=20.0), Friction(mu=0.3, stiffness=3e4, damping=0.5)),
    "hertz-mindlin": (Hertz(young=1e7, poisson=0.3, A=1e-5), Friction(mu=0.3, law="mindlin")),
}


def spinning_pair(dim, shift, rng):
    """Two particles of unequal mass and radius that touch at t = 0.3 after free flight, with spins;
    ``shift`` moves the pair so that the contact straddles the periodic faces at +-5. Returns the
    state (wrapped into the box), the collision, the lead time and the offset the wrapping took."""
    x1, x2, v1, v2, w1, w2, m, R = random_collision(rng, dim)
    x1, x2 = x1 - x1 + shift, x2 - x1 + shift  # (x1 at the shift)
    lead = 0.3
    start = np.array([x1 - v1 * lead, x2 - v2 * lead])
    wrapped = (start + 5.0) % 10.0 - 5.0
    state = State(position=wrapped, velocity=[v1, v2], angular_velocity=[w1, w2], radius=R, mass=m, box=[10.0] * dim)
    return state, (x1, x2, v1, v2, w1, w2, m, R), lead, start - wrapped


@pytest.mark.parametrize("shift", [0.0, 4.7], ids=["inside", "across the periodic face"])
def test_frictional_contact_matches_a_lab_frame_integration(dim, shift):
    """A and B events of a frictional contact: afterwards positions, velocities and spins equal an
    independent integration of the same laws in lab coordinates (scipy DOP853, rtol 1e-13) to 1e-8."""
    contact, friction = FRICTIONAL["dashpot-linear"]
    rng = np.random.default_rng(zlib.crc32(f"frictional eMD* {dim} {shift}".encode()))
    for _ in range(2):
        state, (x1, x2, v1, v2, w1, w2, m, R), lead, offset = spinning_pair(dim, np.full(dim, shift), rng)
        sim = Simulation(state, collision=EMDStar(contact, friction=friction, rtol=1e-12))
        y, t_c = reference(contact, friction, x1, x2, v1, v2, w1, w2, m, R, dim)
        after = 2.0 * t_c
        sim.run(until_time=lead + t_c + after)
        s = sim.state
        assert not s.has_pending and sim.engine.emd_counters()["emd_contacts"] == 1
        speed = np.abs(np.r_[v1, v2]).max() + max(np.abs(w1).max() * R[0], np.abs(w2).max() * R[1])
        for k in range(2):
            v = y[6 + 3 * k : 6 + 3 * k + dim]
            assert np.abs(s.velocity[k] - v).max() < 1e-8 * speed
            assert np.abs(s.unwrapped_position[k] + offset[k] - (y[3 * k : 3 * k + dim] + v * after)).max() < 1e-8 * speed * t_c
            w = y[14 + 3 * k] if dim == 2 else y[12 + 3 * k : 15 + 3 * k]
            assert np.abs(s.angular_velocity[k] - w).max() * R[k] < 1e-8 * speed


@pytest.mark.parametrize("law", list(FRICTIONAL))
def test_frictional_gas_conserves_momentum_and_balances_energy(law, dim):
    """A dense frictional soft gas with every exception: momentum stays zero, and kinetic + rotational
    + dissipated energy stays constant to round-off (the A event books the loss, spins included)."""
    contact, friction = FRICTIONAL[law]
    state = edmd.maxwell_boltzmann(edmd.lattice(64 if dim == 2 else 125, 0.3, dim=dim), 1.0, seed=3, spin=True)
    soft = Hertz(young=2e3, poisson=0.3, A=2e-3) if law == "hertz-mindlin" else LinearDashpot(k=2e3, gamma=2.0)
    if law == "dashpot-linear":
        friction = Friction(mu=0.3, stiffness=2e3 * 2 / 7, damping=0.5)
    sim = Simulation(state, collision=EMDStar(soft, friction=friction))
    e0 = state.kinetic_energy() + state.rotational_energy()
    sim.run(until_time=5.0)
    c = sim.engine.emd_counters()
    assert c["emd_contacts"] > 100 and c["emd_exceptions_b"] > 0 and c["emd_exceptions_a"] > 0 and c["emd_fallbacks"] > 0
    s = sim.state
    np.testing.assert_allclose(s.momentum(), 0.0, atol=1e-12)
    assert s.kinetic_energy() + s.rotational_energy() + sim.totals().dissipated == pytest.approx(e0, rel=1e-11)
    assert s.rotational_energy() != state.rotational_energy()


def test_frictional_exception_a_is_walton_with_the_sticking_restitution():
    """a) with friction: the instantaneous rough rule (Walton) with the central e_n(v_n), the
    friction's mu and the sticking beta_0 of the laws, as a Rough rule of those numbers gives it."""
    contact = Hertz(young=50.0, poisson=0.3, A=0.01)
    friction = Friction(mu=0.2, law="mindlin")
    state = exception_a_state()
    rule = EMDStar(contact, tables="exact", friction=friction)
    sim = Simulation(state, collision=rule)
    sim.run(max_events=1)
    c = sim.engine.emd_counters()
    assert c["emd_exceptions_a"] == 1 and c["emd_fallbacks"] == 1 and c["emd_contacts"] == 0
    beta = rule.for_dim(3).fallback_beta
    walton = Simulation(state, collision=Rough(e_n=contact, beta=beta, mu=0.2))
    walton.run(max_events=1)
    for name in ("position", "velocity", "angular_velocity"):
        np.testing.assert_array_equal(getattr(sim.state, name), getattr(walton.state, name))
    assert np.abs(sim.state.angular_velocity).max() > 0.01  # the fallback is rough


@pytest.mark.parametrize("q", [0.4, 0.5])
def test_sticking_restitution_of_the_laws(q):
    """beta_0: exact for an undamped linear spring on a dashpot, -cos(pi sqrt(k_t/k (1 + 1/q)));
    Mindlin on Hertz agrees with a (hard) two-body solve of a head-on collision with a little slip."""
    sticking_beta = edmd.physics.emdstar.sticking_beta
    assert sticking_beta(LinearDashpot(k=1e6), Friction(mu=1.0, stiffness=2e5), q) == pytest.approx(-math.cos(math.pi * math.sqrt(0.2 * (1 + 1 / q))), abs=1e-8)
    hertz, mindlin = Hertz(young=1e9, poisson=0.3, A=0.0), Friction(mu=math.inf, law="mindlin")  # Lambda ~ 3e-4
    dim = 3 if q == 0.4 else 2
    x1, x2 = np.zeros(dim), -np.eye(dim)[0]
    v1 = np.zeros(dim)
    v1[:2] = -0.5, 1e-3
    w = np.zeros(3) if dim == 3 else 0.0
    end = collide_frictional(hertz, mindlin, x1, x2, v1, 0.5 * np.eye(dim)[0], w, w, 1.0, 1.0, 0.5, 0.5)
    spin_z = (end.omega1 if dim == 2 else end.omega1[2]) + (end.omega2 if dim == 2 else end.omega2[2])
    u_end = (end.v1 - end.v2)[1] - 0.5 * spin_z  # contact-point velocity along y: g - R (w1 + w2) x e_x
    assert -u_end / 1e-3 == pytest.approx(sticking_beta(hertz, mindlin, q), abs=1e-3)  # O(Lambda)


def test_frictional_settings_name_the_problem():
    with pytest.raises(EMDStarError, match="friction must be"):
        EMDStar(Hertz(1e7, 0.3), friction=0.3)
    with pytest.raises(EMDStarError, match="needs friction"):
        EMDStar(Hertz(1e7, 0.3), fallback_beta=0.5)
    with pytest.raises(EMDStarError, match=r"fallback_beta must be a number in \[-1, 1\]"):
        EMDStar(Hertz(1e7, 0.3), friction=Friction(mu=0.3, law="mindlin"), fallback_beta=2.0)
    with pytest.raises(EMDStarError, match="give fallback_beta"):
        EMDStar(Hertz(1e7, 0.3), friction=Friction(mu=0.3, stiffness=1e4))
    with pytest.raises(EMDStarError, match="Mindlin friction takes its stiffness from a Hertz"):
        EMDStar(LinearDashpot(k=1e4), friction=Friction(mu=0.3, law="mindlin"))
    with pytest.raises(EMDStarError, match="use damping = 0 with Mindlin"):
        EMDStar(LinearDashpot(k=1e4, gamma=5.0), friction=Friction(mu=0.3, law="mindlin", stiffness=1e6, damping=0.5), fallback_beta=0.3)
    with pytest.raises(EMDStarError, match="solved directly"):
        EMDStar(Hertz(1e7, 0.3), tables="some_table.npz", friction=Friction(mu=0.3, law="mindlin"))
    EMDStar(Hertz(1e7, 0.3), friction=Friction(mu=0.3, stiffness=1e4), fallback_beta=0.2)  # given: fine


@pytest.mark.parametrize("law", list(FRICTIONAL))
def test_frictional_gas_follows_force_based_md(law, dim):
    """Same initial state with spins: eMD* particles follow the frictional DEM trajectories, which
    converge to them as dt -> 0 (positions, velocities and spins; medians over the particles that
    had a contact and are not in one now)."""
    state = edmd.maxwell_boltzmann(edmd.random_packing(1000, 0.02, dim=dim, seed=4), 1.0, seed=5, spin=True)
    if law == "hertz-mindlin":  # t_c ~ 0.01, e_n ~ 0.9 at the thermal speed
        contact, friction = Hertz(young=2.5e6, poisson=0.3, A=2e-4), Friction(mu=0.3, law="mindlin")
    else:
        contact = LinearDashpot.from_restitution(0.9, k=4.9e4, mass=1.0)
        friction = Friction(mu=0.3, stiffness=4.9e4 * 2 / 7, damping=0.5)
    emd = Simulation(state, collision=EMDStar(contact, friction=friction))
    emd.engine.enable_log()
    emd.run(until_time=1.0)
    collided = np.zeros(state.n, bool)
    collided[emd.engine.take_log()[:, 1:3].astype(int).ravel()] = True
    sel = collided & (emd.state.pending_partner < 0)
    assert sel.sum() > 60
    errors = []
    for steps in (100, 400):
        dem = edmd.DEMSimulation(state, contact, steps_per_contact=steps, friction=friction)
        dem.run(until_time=1.0)
        a, b = emd.state, dem.state
        dx = np.linalg.norm(a.unwrapped_position - b.unwrapped_position, axis=1)[sel]
        dv = np.linalg.norm(a.velocity - b.velocity, axis=1)[sel]
        dw = np.abs(a.angular_velocity - b.angular_velocity).reshape(state.n, -1).max(axis=1)[sel]
        errors.append([np.median(dx), np.median(dv), np.median(dw)])
    coarse, fine = np.array(errors)
    assert np.all(fine < 1e-5)
    assert np.all(fine < coarse / 4)  # the DEM's time-step error, not a difference of physics
