"""Force-based MD (DEM): two-body convergence to the solver, energy conservation, exact output
times, conservation laws, interface shared with the event-driven Simulation, errors."""

import doctest
import math

import numpy as np
import pytest

import edmd
import edmd.run.dem
import edmd.run.neighbours
from edmd.physics.contact import Hertz, LinearDashpot
from edmd.run.dem import DEMSimulation
from edmd.run.engine import EngineError
from edmd.state import StateError
from edmd.physics.twobody import collide, lab_frame_update

M, R = (1.0, 2.5), (0.5, 0.8)
SIGMA = R[0] + R[1]


def exact_two_body(contact, r0, v0, t_end):
    """Free flight to first contact, the solver's matrix of restitution and the eMD* map
    (physics.md §4.6; checked against direct integration in test_twobody.py), free flight to t_end."""
    d, g = r0[0] - r0[1], v0[0] - v0[1]
    a, b, c = g @ g, d @ g, d @ d - SIGMA**2
    t0 = (-b - math.sqrt(b * b - a * c)) / a
    r1, r2 = r0[0] + v0[0] * t0, r0[1] + v0[1] * t0
    n = (r1 - r2) / SIGMA
    vn = -(g @ n)
    vt = float(np.linalg.norm(g + vn * n))
    res = collide(contact, M[0], M[1], R[0], R[1], vn, vt)
    u = lab_frame_update(r1, r2, v0[0], v0[1], M[0], M[1], R[0], R[1], res)
    after = t_end - t0 - res.t_c
    vel = [u.V + u.delta1, u.V + u.delta2]
    pos = [u.r1 + u.V * res.t_c + vel[0] * after, u.r2 + u.V * res.t_c + vel[1] * after]
    return pos, vel, t0, res.t_c


def dem_two_body_error(contact, dim, steps_per_contact, gap, b=0.6):
    """Largest position (in sigma) and velocity error of a DEM oblique collision after the contact."""
    r0 = [np.zeros(3), np.array([SIGMA + gap, b * SIGMA, 0.0])]
    v0 = [np.array([0.7, 0.0, 0.0]), np.array([-0.3, 0.0, 0.1 if dim == 3 else 0.0])]
    _p, _v, t0, tc = exact_two_body(contact, r0, v0, 1.0)
    t_end = t0 + 3 * tc
    pos, vel, _t0, _tc = exact_two_body(contact, r0, v0, t_end)
    state = edmd.State(position=[x[:dim] for x in r0], velocity=[x[:dim] for x in v0], radius=R, mass=M, box=[30.0] * dim)
    sim = DEMSimulation(state, contact, dt=tc / steps_per_contact)
    sim.run(until_time=t_end)
    s = sim.state
    assert sim.collisions == 1
    ep = max(np.abs(s.unwrapped_position[k] - pos[k][:dim]).max() for k in range(2)) / SIGMA
    ev = max(np.abs(s.velocity[k] - vel[k][:dim]).max() for k in range(2))
    return ep, ev


CONTACTS = {
    "dashpot-elastic": (LinearDashpot(k=1e4), 1.7),
    "dashpot-dissipative": (LinearDashpot(k=1e4, gamma=20.0), 1.7),
    "hertz-elastic": (Hertz(young=1e6, poisson=0.3), 1.7),
    # the viscoelastic damping force grows as sqrt(s) after onset: order 2 at these steps,
    # ~1.5 asymptotically (see edmd._core.dem._onset_weight)
    "hertz-viscoelastic": (Hertz(young=1e6, poisson=0.3, A=1e-3), 1.4),
}


@pytest.mark.parametrize("name", list(CONTACTS))
def test_two_body_collision_converges_to_the_solver(name, dim):
    contact, min_order = CONTACTS[name]
    steps = [20, 40, 80, 160, 320]
    # the error depends on where in a step the contact begins: average over onset phases
    gaps = np.linspace(0.3, 0.5, 9)
    errors = np.array([[dem_two_body_error(contact, dim, n, g) for g in gaps] for n in steps])
    rms = np.sqrt((errors**2).mean(axis=1))  # (steps, [position, velocity])
    for k, what in enumerate(["position", "velocity"]):
        order = -np.polyfit(np.log(steps), np.log(rms[:, k]), 1)[0]
        print(f"{name} {dim}D {what}: rms errors {rms[:, k]}, order {order:.2f}")
        assert order >= min_order
    assert rms[-1, 1] < 1e-4


@pytest.mark.parametrize("contact", [LinearDashpot(k=1e4), Hertz(young=1e5, poisson=0.3)], ids=["dashpot", "hertz"])
def test_elastic_energy_conservation_is_second_order(contact, dim):
    # rms over time of (E_kin + E_el)/E0 - 1, averaged over 3 initial states (hundreds of collisions each)
    steps = [10, 20, 40, 80]
    rms = []
    for n in steps:
        dev = []
        for seed in (1, 2, 3):
            state = edmd.maxwell_boltzmann(edmd.lattice(500, 0.25, dim=dim), kT=1.0, seed=seed)
            sim = DEMSimulation(state, contact, steps_per_contact=n)
            energy = []
            sim.add(edmd.Callback(lambda s, _tot, sim=sim: energy.append(s.kinetic_energy() + sim.elastic_energy), interval=0.02))
            sim.run(until_time=2.0)
            e = np.array(energy)
            dev.append(np.mean((e / e[0] - 1) ** 2))
            assert sim.totals().dissipated == 0.0
        rms.append(math.sqrt(np.mean(dev)))
    order = -np.polyfit(np.log(steps), np.log(rms), 1)[0]
    print(f"{contact.name} {dim}D energy: rms deviations {rms}, order {order:.2f}")
    assert order >= 1.5
    assert rms[2] < 1e-4


def cooling_slopes(dim, seed, n=None, k=1e5):
    """Cooling of a dilute dashpot gas (constant e_n = 0.9) by DEM and by EDMD with e_n = 0.9.

    Same melted initial state for both; T(t) is summarised by the slope of 1/sqrt(T) (Haff:
    1/sqrt(T) = (1 + t/tau0)/sqrt(T0), physics.md §5.4). A control EDMD run starts from the
    state with velocities perturbed by 1e-4 (relative): chaos then decorrelates it from the
    reference as fast as the DEM's soft contacts do, so it measures the statistical spread.
    Returns the relative slope differences (DEM, control) and the DEM's contact count.
    """
    n = n or (1000 if dim == 3 else 2000)
    eta, t_end = (0.05, 40.0) if dim == 3 else (0.1, 20.0)
    state = edmd.maxwell_boltzmann(edmd.lattice(n, eta, dim=dim), kT=1.0, seed=seed)
    melt = edmd.Simulation(state)
    melt.run(until_time=5.0)
    state = melt.state
    state.time = 0.0

    def slope(sim):
        th = sim.add(edmd.Thermo(interval=t_end / 20))
        sim.run(until_time=t_end)
        t = th.table()
        return np.polyfit(t["time"], 1 / np.sqrt(t["temperature"]), 1)[0]

    dem = DEMSimulation(state, LinearDashpot.from_restitution(0.9, k=k, mass=1.0), steps_per_contact=20)
    s_dem = slope(dem)
    s_ref = slope(edmd.Simulation(state, e_n=0.9))
    perturbed = state.copy()
    perturbed.velocity = perturbed.velocity * (1 + 1e-4 * np.random.default_rng(seed).normal(size=perturbed.velocity.shape))
    s_control = slope(edmd.Simulation(perturbed, e_n=0.9))
    return s_dem / s_ref - 1, s_control / s_ref - 1, dem.collisions


def test_cooling_matches_event_driven_gas(dim):
    # the statistical spread of the slope is ~2 % (3D, N = 1000; 2D, N = 2000; ~1e4 contacts);
    # the DEM must agree within 3 spreads; a wrong restitution (0.85) changes the slope by ~45 %
    diff, control, contacts = cooling_slopes(dim, seed=11)
    print(f"{dim}D: slope DEM/EDMD - 1 = {diff:.4f}, control {control:.4f}, {contacts} contacts")
    assert abs(diff) < 3 * max(abs(control), 0.015)
    assert contacts > 4000


def test_observers_fire_at_exact_times_and_runs_split(dim):
    state = edmd.maxwell_boltzmann(edmd.lattice(64, 0.2, dim=dim), kT=1.0, seed=4)
    contact = Hertz(young=1e5, poisson=0.4, A=1e-4)
    a = DEMSimulation(state, contact)
    th = a.add(edmd.Thermo(interval=0.3))
    a.run(until_time=1.0)
    assert [r["time"] for r in th.rows] == [k * 0.3 for k in range(4)]  # Observer times: start + k * interval
    assert a.time == 1.0
    # the same run split at the observation times is bit for bit the same
    b = DEMSimulation(state, contact)
    b.add(edmd.Thermo(interval=0.3))
    for t in (0.3, 0.6, 3 * 0.3, 1.0):  # the observer times (3 * 0.3 != 0.9 in floating point)
        b.run(until_time=t)
    assert np.array_equal(a.state.position, b.state.position)
    assert np.array_equal(a.state.velocity, b.state.velocity)
    assert a.events == b.events and a.collisions == b.collisions
    # the step never exceeds dt; max_events counts steps
    c = DEMSimulation(state, contact)
    c.run(max_events=10)
    assert c.events == 10 and c.time == pytest.approx(10 * c.dt, rel=1e-12)


def test_conservation_and_invariants(dim):
    state = edmd.maxwell_boltzmann(edmd.lattice(200, 0.3, dim=dim), kT=1.0, seed=8)
    state.angular_velocity = np.ones_like(state.angular_velocity)
    sim = DEMSimulation(state, LinearDashpot.from_restitution(0.7, k=1e4, mass=1.0))
    th = sim.add(edmd.Thermo(interval=0.25))
    sim.run(until_time=1.0)
    s = sim.state
    np.testing.assert_allclose(s.momentum(), state.momentum(), atol=1e-12)
    assert np.array_equal(s.angular_velocity, state.angular_velocity)  # frictionless: spins untouched
    # energy balance: E_kin + E_el + dissipated = E0 (to the integrator's accuracy)
    e0 = state.kinetic_energy()
    total = s.kinetic_energy() + sim.elastic_energy + sim.totals().dissipated
    assert total == pytest.approx(e0, rel=2e-3)
    assert sim.totals().dissipated > 0.05 * e0
    rows = th.table()
    # thermo's energy balance includes the elastic energy of the contacts
    np.testing.assert_allclose(rows["energy_balance"], e0 + state.rotational_energy(), rtol=2e-3)
    assert np.all(np.diff(rows["temperature"]) < 0)
    assert np.all(rows["pressure"][1:] > 0) and np.all(rows["collision_rate"][1:] > 0)


FRICTIONS = [None, edmd.Friction(mu=0.3, stiffness=3e4)]


def assert_same_run(a, b, order=None):
    """Two DEM runs at the same state to 1e-9 (forces summed in another order); ``order``: ``b``'s
    particle of each of ``a``'s."""
    sa, sb = a.state, b.state
    order = np.arange(sa.n) if order is None else order
    assert a.collisions == b.collisions > 500
    for field in ("position", "velocity", "angular_velocity"):
        np.testing.assert_allclose(getattr(sa, field), getattr(sb, field)[order], rtol=0, atol=1e-9, err_msg=field)


def gas_with_intruders(dim, friction):
    """1500 spheres (disks) of radius 0.25 with two of radius 1.5 (ratio 6), melted velocities (and spins)."""
    n = 1500
    radius = {"kind": "discrete", "values": [0.25, 1.5], "fractions": [n - 2, 2]}
    eta = 0.15 if dim == 3 else 0.3
    return edmd.maxwell_boltzmann(edmd.random_packing(n, eta, dim=dim, radius=radius, seed=3), kT=1.0, seed=4, spin=friction is not None)


@pytest.mark.parametrize("friction", FRICTIONS, ids=["smooth", "frictional"])
def test_big_particles_give_the_same_run(dim, friction, monkeypatch):
    """Two intruders of size ratio 6 in a gas (cells of the small particles' contact, the bigs'
    contacts in the small ones' rows) run as with cells of the bigs' contact (no big taken out):
    the same state to 1e-9, the springs of frictional contacts included (which needs onset jumps
    that do not depend on the order of the pairs: see :func:`test_relabelling_gives_the_same_run`).
    """
    state = gas_with_intruders(dim, friction)
    contact = LinearDashpot.from_restitution(0.8, k=1e5, mass=float(state.mass[0]))
    runs = []
    for split in (True, False):
        if not split:
            monkeypatch.setattr(edmd.run.neighbours, "big_count", lambda *a: 0)
        sim = DEMSimulation(state, contact, friction=friction)
        assert sim.engine.grid.shape[5] == (2 if split else 0)
        sim.run(until_time=0.3)
        runs.append(sim)
    split, wide = runs
    assert split.engine.capacity < wide.engine.capacity / 3  # (a row of a wide grid has room for a big's partners)
    big, rows = np.flatnonzero(state.radius == 1.5), split.engine
    assert sum(np.isin(rows.nbl[i, : rows.nbl_n[i]], big).sum() for i in range(state.n)) > 5  # (bigs listed in small rows)
    assert_same_run(split, wide)
    e = split.state.kinetic_energy() + split.state.rotational_energy()
    assert e < 0.99 * (state.kinetic_energy() + state.rotational_energy())


@pytest.mark.parametrize("friction", FRICTIONS, ids=["smooth", "frictional"])
def test_relabelling_gives_the_same_run(dim, friction):
    """The same gas with its particles in reverse order runs to the same state to 1e-9.

    The onset correction of a dashpot contact (:func:`edmd._core.dem._onset_weight`) is a
    velocity jump; a frictional spring grows with the sliding velocity. Were the jumps applied
    during the force loop, a spring of a pair met later in the loop would grow with them, one
    met earlier without: an O(h) difference per onset step that a relabelling changes (1e-5 in
    the positions here).
    """
    state = gas_with_intruders(dim, friction)
    order = np.arange(state.n)[::-1]
    flipped = state.copy()
    for field in ("position", "velocity", "radius", "mass", "angular_velocity", "inertia"):
        setattr(flipped, field, np.ascontiguousarray(getattr(state, field)[order]))
    contact = LinearDashpot.from_restitution(0.8, k=1e5, mass=float(state.mass[0]))
    runs = [DEMSimulation(s, contact, friction=friction) for s in (state, flipped)]
    for sim in runs:
        sim.run(until_time=0.3)
    assert_same_run(*runs, order=order)


def test_gravity_free_fall_is_exact(dim):
    g = [0.0] * dim
    g[1] = -9.81
    state = edmd.State(position=[[0.0] * dim], velocity=[[0.3] + [1.0] * (dim - 1)], radius=[0.5], mass=[1.0], box=[5.0] * dim)
    sim = DEMSimulation(state, LinearDashpot(k=1e3), gravity=g, dt=1e-3)
    sim.run(until_time=1.7)
    s = sim.state
    expected = np.array([0.3 * 1.7] + [1.7 - 0.5 * 9.81 * 1.7**2] + [1.7] * (dim - 2))
    np.testing.assert_allclose(s.unwrapped_position[0], expected, rtol=1e-12, atol=1e-12)
    if dim == 2:
        assert s.position.shape == (1, 2)


def test_pressure_of_a_stiff_elastic_gas_is_carnahan_starling():
    # elastic, stiff contacts: the virial pressure approaches the hard-sphere value (physics.md §5.2);
    # softness lowers it by O(Lambda) ~ 0.3 %, statistics (2e4 contacts) ~0.5 %
    state = edmd.maxwell_boltzmann(edmd.lattice(500, 0.1), kT=1.0, seed=2)
    sim = DEMSimulation(state, LinearDashpot(k=1e5), steps_per_contact=15)
    sim.run(until_time=2.0)
    before = sim.totals()
    sim.run(until_time=22.0)
    after = sim.totals()
    s = sim.state
    ke_mean = (after.kinetic_integral - before.kinetic_integral) / 20.0
    p = edmd.files.thermo.pressure(s, after.kinetic_integral - before.kinetic_integral, after.virial - before.virial, 20.0)
    z = p / (2 * ke_mean / (3 * s.volume))  # P / (n T) with T = 2 <E_kin> / (3 N)
    eta = 0.1
    z_cs = (1 + eta + eta**2 - eta**3) / (1 - eta) ** 3
    assert z == pytest.approx(z_cs, rel=0.02)


def test_trajectory_of_overlapping_states(tmp_path):
    state = edmd.maxwell_boltzmann(edmd.lattice(108, 0.3), kT=1.0, seed=1)
    sim = DEMSimulation(state, Hertz(young=1e3, poisson=0.3))  # very soft: contacts overlap a lot
    path = tmp_path / "t.gsd"
    sim.add(edmd.Trajectory(path, interval=0.5))
    sim.run(until_time=1.0)
    sim.close()
    last = edmd.read_state(path, check_overlaps=False)
    assert np.array_equal(last.position, sim.state.position) and last.time == 1.0
    # a DEM can continue from any snapshot (overlaps are contacts)
    sim.state = last
    sim.run(until_time=1.2)


def test_bad_input():
    state = edmd.maxwell_boltzmann(edmd.lattice(32, 0.1), kT=1.0)
    with pytest.raises(TypeError, match="contact must be"):
        DEMSimulation(state, "dashpot")
    with pytest.raises(ValueError, match="dt must be a positive number"):
        DEMSimulation(state, LinearDashpot(k=1e4), dt=-1.0)
    with pytest.raises(ValueError, match="steps_per_contact"):
        DEMSimulation(state, LinearDashpot(k=1e4), steps_per_contact=0)
    with pytest.raises(ValueError, match="steps_per_contact must be a number >= 10"):  # (3 ran, gaining 19 % energy)
        DEMSimulation(state, LinearDashpot(k=1e4), steps_per_contact=3)
    walls = edmd.State(position=[[0.0, 0.0]], velocity=[[1.0, 0.0]], radius=[0.5], mass=[1.0], box=[5.0, 5.0], periodic=[True, False])
    with pytest.raises(StateError, match="periodic box"):
        DEMSimulation(walls, LinearDashpot(k=1e4))
    still = edmd.State(position=[[0.0, 0.0]], velocity=[[0.0, 0.0]], radius=[0.5], mass=[1.0], box=[5.0, 5.0])
    with pytest.raises(ValueError, match="at rest"):
        DEMSimulation(still, Hertz(young=1e6, poisson=0.3))
    with pytest.raises(EngineError, match="time step .* too large"):
        DEMSimulation(state, LinearDashpot(k=1e4), dt=0.5).run(until_time=5.0)
    with pytest.raises(StateError, match="must have the simulation's box"):  # (it ran in the old box)
        DEMSimulation(state, LinearDashpot(k=1e4)).state = edmd.maxwell_boltzmann(edmd.lattice(32, 0.3), kT=1.0)
    from edmd.files.checkpoint import Checkpoint

    with pytest.raises(TypeError, match="checkpoints .* not available for the DEM"):
        DEMSimulation(state, LinearDashpot(k=1e4)).add(Checkpoint("c.gsd", interval=1.0))


DEM_CONFIG = """
[system]
dim = {dim}
n = 200
packing_fraction = 0.1
[run]
until_time = 1.0
output_interval = 0.25
progress = false
[integrator]
kind = "dem"
steps_per_contact = 30
[contact]
model = "dashpot"
k = 1e4
e_n = 0.8
"""


def test_config_sections():
    from edmd.app.config import ConfigError, dump_config, parse_config

    cfg = parse_config({"integrator": {"kind": "dem"}, "contact": {"model": "hertz", "young": 1e7, "poisson": 0.3, "A": 1e-5}})
    assert cfg.contact.build(1.0) == Hertz(1e7, 0.3, 1e-5)
    d = parse_config({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "k": 1e4, "e_n": 0.8}}).contact.build(2.0)
    assert d.central(2.0, 2.0, 0.5, 0.5, 1.0).e_n == pytest.approx(0.8, rel=1e-12)
    import tomllib

    for c in (cfg, parse_config({})):
        assert parse_config(tomllib.loads(dump_config(c))) == c
    assert "[contact]" not in dump_config(parse_config({}))
    bad = [
        ({"integrator": {"kind": "dem"}}, "needs a \\[contact\\] section"),
        ({"contact": {"model": "dashpot", "k": 1.0}}, "used by integrator.kind = 'dem' only"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "hertz", "young": 1e7}}, "needs young and poisson"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "k": 1.0, "young": 3.0}}, "young not used by the 'dashpot' contact law"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "k": 1.0, "gamma": 1.0, "e_n": 0.5}}, "gamma or e_n, not both"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "kk": 1.0}}, "contact.kk: unknown key \\(did you mean 'k'\\?\\)"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "hertz", "young": 1e7, "poisson": 0.6}}, "contact.poisson"),
        ({"integrator": {"kind": "dem", "dt": -1.0}, "contact": {"model": "dashpot", "k": 1.0}}, "integrator.dt"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "k": 1.0}, "collision": {"rule": "inelastic", "e_n": 0.9}}, "dissipation from \\[contact\\]"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "k": 1.0}, "walls": {"axes": ["x"]}}, "periodic box"),
    ]
    for data, words in bad:
        with pytest.raises(ConfigError, match=words):
            parse_config(data)


def test_cli_runs_dem(tmp_path, dim):
    import json

    from typer.testing import CliRunner

    from edmd.app.cli import app

    cfg = tmp_path / "dem.toml"
    cfg.write_text(DEM_CONFIG.format(dim=dim))
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["run", str(cfg), "--out", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    table = edmd.read_thermo(out / "thermo.csv")
    assert table["time"].tolist() == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert np.all(np.diff(table["temperature"]) <= 0) and table["temperature"][-1] < 0.99  # e_n = 0.8: the gas cools
    summary = json.loads((out / "summary.json").read_text())
    assert summary["neighbours"] == "dem" and summary["particle_steps_per_second"] > 0
    last = edmd.read_state(out / "trajectory.gsd", check_overlaps=False)
    assert last.time == 1.0 and last.dim == dim


def test_examples_in_docstrings():
    assert doctest.testmod(edmd.run.dem, raise_on_error=False).failed == 0
