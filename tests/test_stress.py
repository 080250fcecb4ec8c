"""The stress tensor (``edmd._core.stress``, ``Totals.stress_integral``, thermo's ``pressure_<ab>``)."""

import numpy as np
import pytest

import edmd
from edmd._core import layout as L
from edmd.files.thermo import pressure_tensor
from edmd.physics.collide import TC, Rough, Wall
from edmd.physics.contact import Hertz
from edmd.physics.emdstar import EMDStar
from edmd.physics.friction import Friction


def _gas(dim, n=256, eta=0.2, seed=1, **kw):
    return edmd.maxwell_boltzmann(edmd.random_packing(n, eta, dim=dim, seed=seed, **kw), 1.0, seed=seed + 1)


def _tensor(state):
    """The six components of sum_i m_i v_i (x) v_i of a state (committed velocities, 3-vectors, 2D padded with zeros)."""
    v = np.zeros((state.n, 3))
    v[:, : state.dim] = state.committed_velocity
    k = np.einsum("i,ij,ik->jk", state.mass, v, v)
    return np.array([k[a, b] for a, b in L.TENSOR_AXES])


def _running(sim):
    return sim.engine.accumulators_at(sim.time)[L.A_KT : L.A_KT + 6]


def _energies(state):
    """e_i = m v^2 / 2 + I w^2 / 2 with committed velocities."""
    w = np.asarray(state.angular_velocity).reshape(state.n, -1)
    return 0.5 * state.mass * np.sum(state.committed_velocity**2, axis=1) + 0.5 * state.inertia * np.sum(w**2, axis=1)


def _current(state):
    """sum_i e_i v_i of a state (3 components)."""
    out = np.zeros(3)
    out[: state.dim] = _energies(state) @ state.committed_velocity
    return out


def _features(dim):
    """Runs with every kind of velocity change the core books: collisions of every rule, walls,
    gravity, the heat bath, white noise, square wells, growth and eMD* (smooth, frictional, and
    frictional from the hard-limit table)."""
    closed = [True] * (dim - 1) + [False]
    g = np.zeros(dim)
    g[-1] = -0.5
    return {
        "elastic": (_gas(dim), {}),
        "rough_walls_gravity": (_gas(dim, periodic=closed), {"collision": TC(Rough(0.8, beta=0.3), duration=1e-3), "walls": Wall(0.9, beta=0.2), "gravity": g}),
        "bath": (_gas(dim), {"e_n": 0.8, "thermostat": edmd.Andersen(kT=1.0, rate=0.5, seed=3)}),
        "white_noise": (_gas(dim), {"e_n": 0.8, "forcing": edmd.WhiteNoise(xi0=1.0, interval=0.05, seed=3)}),
        "square_well": (_gas(dim), {"well": edmd.SquareWell(width=1.5, depth=1.0)}),
        "growth": (_gas(dim), {"growth": edmd.Growth(rate=0.01)}),
        "emdstar": (_gas(dim, eta=0.3), {"collision": EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3))}),
        "emdstar_friction": (
            edmd.maxwell_boltzmann(edmd.random_packing(256, 0.3, dim=dim, seed=1), 1.0, seed=2, spin=True),
            {"collision": EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3), friction=Friction(mu=0.3, law="mindlin"))},
        ),
        "emdstar_friction_table": (
            edmd.maxwell_boltzmann(edmd.random_packing(256, 0.3, dim=dim, seed=1), 1.0, seed=2, spin=True),
            {"collision": EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3), friction=Friction(mu=0.3, law="mindlin"), friction_table=True)},
        ),
    }


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("feature", list(_features(2)))
def test_running_kinetic_tensor_follows_every_velocity_change(dim, feature):
    """The core's running sum_i m v (x) v equals the state's after thousands of events of each kind
    (1e-10 of its scale: round-off of ~1e5 updates), and its trace is twice the kinetic energy; so
    does the running energy current sum_i e_i v_i where the engine keeps it."""
    state, kw = _features(dim)[feature]
    sim = edmd.Simulation(state, **kw)
    sim.run(until_time=8.0)
    assert sim.collisions > 1000
    s = sim.state
    expect = _tensor(s)
    scale = np.abs(expect[:3]).sum()
    np.testing.assert_allclose(_running(sim), expect, rtol=0, atol=1e-10 * scale)
    acc = sim.engine.accumulators_at(sim.time)
    if sim.engine.keeps_energy_current:
        expect = _current(s)
        np.testing.assert_allclose(acc[L.A_JE : L.A_JE + 3], expect, rtol=0, atol=1e-10 * np.abs(expect).sum())
    assert acc[L.A_KT : L.A_KT + 3].sum() == pytest.approx(2.0 * acc[L.A_KE], rel=1e-12)
    # the time integral's trace is twice the kinetic-energy integral, the virial's the scalar virial
    assert acc[L.A_KT_INT : L.A_KT_INT + 3].sum() == pytest.approx(2.0 * acc[L.A_KE_INT], rel=1e-12)
    assert acc[L.A_VT : L.A_VT + 3].sum() == pytest.approx(acc[L.A_VIRIAL], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_collisionless_gas_has_the_kinetic_pressure_tensor(dim):
    """Point-like particles that never meet in the interval: P = sum m v (x) v / V - P (x) P / (M V) exactly."""
    rng = np.random.default_rng(5)
    n, box = 20, 1000.0
    pos = (np.arange(n)[:, None] * 40.0 - 400.0) * np.ones(dim)
    vel = rng.normal(size=(n, dim)) + 0.3
    state = edmd.State(position=pos, velocity=vel, radius=np.full(n, 0.01), mass=np.ones(n), box=np.full(dim, box))
    sim = edmd.Simulation(state)
    thermo = sim.add(edmd.Thermo(interval=2.0))
    sim.run(until_time=2.0)
    assert sim.collisions == 0
    row = thermo.rows[-1]
    v = np.zeros((n, 3))
    v[:, :dim] = vel
    p = v.sum(axis=0)
    for a, b in L.TENSOR_AXES:
        if max(a, b) < dim:
            expect = (v[:, a] @ v[:, b] - p[a] * p[b] / n) / state.volume
            assert row[f"pressure_{'xyz'[a]}{'xyz'[b]}"] == pytest.approx(expect, rel=1e-12, abs=1e-15)


def test_free_fall_integral_is_exact():
    """One particle falling without collisions: int v_a v_b dt in closed form."""
    state = edmd.State(position=[[0.0, 0.0, 5.0]], velocity=[[1.0, 0.5, 2.0]], radius=[0.5], mass=[1.0], box=[20.0, 20.0, 20.0])
    sim = edmd.Simulation(state, gravity=[0.0, 0.0, -1.0])
    sim.run(until_time=1.5)
    t = 1.5
    vz2 = 4.0 * t - 2.0 * t**2 + t**3 / 3.0  # int (2 - s)^2 ds
    vz = 2.0 * t - 0.5 * t**2  # int (2 - s) ds
    expect = [t, 0.25 * t, vz2, 0.5 * t, vz, 0.5 * vz]  # xx, yy, zz, xy, xz, yz
    np.testing.assert_allclose(sim.totals().stress_integral, expect, rtol=1e-13)
    np.testing.assert_allclose(_running(sim), [1.0, 0.25, 0.5**2, 0.5, 0.5, 0.25], rtol=1e-13)


@pytest.mark.parametrize("dim", [2, 3])
def test_pressure_tensor_is_isotropic_and_its_trace_is_the_pressure(dim):
    """An elastic hard-sphere fluid at equilibrium: the trace over d equals the scalar pressure to
    round-off; the diagonal components agree with it and the off-diagonal ones vanish within the
    fluctuations (8 intervals of ~40 collisions per particle: a few per cent)."""
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(500, 0.3, dim=dim), 1.0, seed=3))
    sim.run(until_time=5.0)
    thermo = sim.add(edmd.Thermo(interval=5.0))
    sim.run(until_time=45.0)
    rows = thermo.rows[1:]
    comps = [c for c in rows[0] if c.startswith("pressure_")]
    assert comps == [f"pressure_{c}" for c in (("xx", "yy", "xy") if dim == 2 else L.TENSOR)]
    diag = np.array([[r[f"pressure_{a}{a}"] for a in "xyz"[:dim]] for r in rows])
    pressure = np.array([r["pressure"] for r in rows])
    np.testing.assert_allclose(diag.mean(axis=1), pressure, rtol=1e-12)
    np.testing.assert_allclose(diag.mean(axis=0), pressure.mean(), rtol=0.02)
    off = np.array([[r[c] for c in comps if c[-2] != c[-1]] for r in rows])
    assert np.abs(off.mean(axis=0)).max() < 0.02 * pressure.mean()


def test_pressure_tensor_formula():
    state = edmd.maxwell_boltzmann(edmd.lattice(27, 0.1), 1.0, seed=2)
    p = pressure_tensor(state, np.arange(6.0) * state.volume, 1.0)
    assert list(p) == [f"pressure_{c}" for c in L.TENSOR]
    np.testing.assert_allclose(list(p.values()), np.arange(6.0), atol=1e-12)  # zero momentum: no flow term


def test_not_reported_by_the_dem_or_with_a_vibrating_wall():
    state = _gas(3, n=64, eta=0.1)
    dem = edmd.DEMSimulation(state, Hertz(young=1e5, poisson=0.3))
    assert dem.totals().stress_integral is None
    closed = _gas(3, n=64, eta=0.1, periodic=[True, True, False])
    vib = edmd.Simulation(closed, gravity=[0, 0, -1.0], vibration=edmd.VibratingWall(amplitude=0.1, omega=5.0, phase=-np.pi / 2))
    thermo = vib.add(edmd.Thermo(interval=0.5))
    vib.run(until_time=1.0)
    assert vib.totals().stress_integral is None and not any(c.startswith("pressure_x") for c in thermo.rows[-1])


def test_totals_round_trip_with_the_stress_integral():
    sim = edmd.Simulation(_gas(2, n=64))
    sim.run(until_time=1.0)
    t = sim.totals()
    back = edmd.Totals.from_dict(t.to_dict())
    assert back == t and np.array_equal(back.stress_integral, t.stress_integral)


def _projected_position(state):
    """Where the moments place a particle in a pending eMD* contact: its end position at the B
    event, x + V (t_B - t), reached with the committed velocity c = V + Delta, x - Delta (t_B - t)."""
    ahead = np.where(np.isfinite(state.pending_until), state.pending_until - state.time, 0.0)
    return state.position - state.pending_velocity * ahead[:, None]


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("rule", ["smooth", "rough", "emdstar"])
def test_energy_and_stress_fluxes_are_the_growth_of_the_helfand_moments(dim, rule):
    """In a box closed by elastic smooth walls, energy is conserved at every collision and walls
    change no particle's energy, so d/dt sum_i r_i e_i = sum_i e_i v_i + sum_coll r_ij (De_i - De_j) / 2
    exactly: the accumulated energy flux equals the change of sum_i r_i e_i (1e-11 of its scale).
    Without walls (their impulses are no virial) the stress integral is the change of the symmetrised
    sum_i m_i r_i (x) v_i the same way (checked on one collision). eMD* (elastic Hertz contacts)
    relocates pairs and lets them fly with their centre-of-mass velocity until the B event:
    its A events book both (the moments use committed velocities; a particle still in a contact
    is placed where its committed velocity brings it to its position at the B event), so the
    identities hold for eMD* too."""
    collision = {
        "smooth": edmd.collide.Inelastic(1.0),
        "rough": Rough(1.0, beta=1.0),
        "emdstar": EMDStar(Hertz(young=2e3, poisson=0.3, A=0.0)),
    }[rule]
    walled = edmd.Simulation(_gas(dim, n=200, eta=0.2, periodic=[False] * dim), collision=collision)
    assert walled.engine.keeps_energy_current
    start = walled.state
    walled.run(until_time=12.0)
    end = walled.state
    assert walled.collisions > 1000 and walled.totals().wall_collisions > 100
    moment = _energies(end) @ _projected_position(end) - _energies(start) @ start.position
    flux = walled.totals().energy_flux_integral[:dim]
    scale = np.abs(_energies(start)).sum() * start.box.max()
    np.testing.assert_allclose(flux, moment, rtol=0, atol=1e-11 * scale)
    if rule == "rough":
        assert end.rotational_energy() > 0.1 * end.kinetic_energy()  # energy went into spins and back
    if rule == "emdstar":
        assert walled.engine.emd_counters()["emd_exceptions_b"] > 0  # early B events give back their share

    # the stress: two spheres meeting obliquely in a large periodic box (no wall impulses, no
    # collision across the boundary), up to the middle of the contact and long after it
    pos = np.array([[-1.0, 0.35, 0.1], [1.0, -0.35, -0.1]])[:, :dim]
    vel = np.array([[1.0, 0.1, 0.0], [-1.2, 0.0, 0.2]])[:, :dim]
    spins = np.array([[0.0, 0.0, 2.0], [0.5, 0.0, -1.0]]) if dim == 3 else np.array([2.0, -1.0])
    pair = edmd.State(position=pos, velocity=vel, radius=[0.5, 0.6], mass=[1.0, 1.5], box=np.full(dim, 20.0), angular_velocity=spins if rule == "rough" else None)
    sim = edmd.Simulation(pair, collision=collision)
    start = sim.state
    for until in (0.7, 0.8, 3.0):  # (eMD*: the contact of t_c ~ 0.07 starts near 0.64)
        sim.run(until_time=until)
        end = sim.state
        k = np.zeros((3, 3))
        k[:dim, :dim] = np.einsum("i,ij,ik->jk", end.mass, _projected_position(end), end.committed_velocity)
        k[:dim, :dim] -= np.einsum("i,ij,ik->jk", start.mass, start.position, start.committed_velocity)
        k = 0.5 * (k + k.T)
        np.testing.assert_allclose(sim.totals().stress_integral, [k[a, b] for a, b in L.TENSOR_AXES], rtol=0, atol=1e-10)
    assert sim.collisions == 1


def test_energy_flux_columns_and_where_they_are_left_out():
    sim = edmd.Simulation(_gas(3, n=64))
    thermo = sim.add(edmd.Thermo(interval=0.5))
    sim.run(until_time=1.0)
    assert [c for c in thermo.rows[-1] if c.startswith("energy_flux_")] == ["energy_flux_x", "energy_flux_y", "energy_flux_z"]
    for kw in ({"gravity": [0, 0, -1.0]}, {"well": edmd.SquareWell(width=1.5, depth=1.0)}, {"forcing": edmd.WhiteNoise(xi0=1.0, interval=0.05)}):
        other = edmd.Simulation(_gas(3, n=64, periodic=[True, True, False]) if "gravity" in kw else _gas(3, n=64), **kw)
        assert other.totals().energy_flux_integral is None and other.totals().stress_integral is not None
