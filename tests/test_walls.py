"""Walls and gravity: the bouncing ball (physics.md §1.3, §3 Zeno test, T13) and wall bookkeeping."""

import math

import numpy as np
import pytest

import edmd
from edmd import collide
from edmd.run.engine import CollapseError

G = 9.81
R = 0.01


def ball(dim, h0, e_w, rule=None, up=0.0):
    """One ball at gap ``h0`` above the floor of a box closed on every axis, gravity along the last axis."""
    box = [1.0] * dim
    pos = np.zeros((1, dim))
    pos[0, -1] = -0.5 + R + h0
    vel = np.zeros((1, dim))
    vel[0, -1] = up
    s = edmd.State(position=pos, velocity=vel, radius=R, mass=1.0, box=box, periodic=[False] * dim)
    g = np.zeros(dim)
    g[-1] = -G
    return edmd.Simulation(s, collision=rule, walls=collide.Wall(e_n=e_w), gravity=g)


def bounce_times(sim, count):
    times = []
    while len(times) < count:
        before = sim.totals().wall_collisions
        sim.run(max_events=1)
        if sim.totals().wall_collisions > before:
            times.append(sim.time)
    return np.array(times)


def test_t13_first_hit_and_elastic_period(dim):
    h0 = 0.3
    sim = ball(dim, h0, 1.0)
    t = bounce_times(sim, 4)
    t1 = math.sqrt(2 * h0 / G)
    assert t[0] == pytest.approx(t1, rel=1e-13)
    assert np.diff(t) == pytest.approx(np.full(3, 2 * t1), rel=1e-12)  # 2u/|G| with u = G t1


def test_zeno_sequence_matches_the_analytic_one(dim):
    h0, e = 0.3, 0.8
    sim = ball(dim, h0, e)
    t = bounce_times(sim, 40)
    t1 = math.sqrt(2 * h0 / G)
    v1 = G * t1
    k = np.arange(1, 41)
    expected = t1 + 2 * v1 / G * np.array([sum(e**l for l in range(1, kk)) for kk in k])
    assert t == pytest.approx(expected, rel=1e-11, abs=1e-13)


def test_zeno_without_tc_stops_with_a_clear_message(dim):
    h0, e = 0.3, 0.8
    sim = ball(dim, h0, e)
    t_inf = math.sqrt(2 * h0 / G) * (1 + e) / (1 - e)
    with pytest.raises(CollapseError, match="without the clock advancing.*TC model"):
        sim.run(until_time=10.0)
    # stopped at the accumulation point; the last bounces are as high as the round-off of a
    # position (h ~ 5e-17), lasting tau = 2 sqrt(2h / G) ~ 7e-9, and the bounces they stand for
    # tau e / (1 - e) ~ 3e-8: the time is resolved to that (where in it the run stops depends on
    # the round-off of the clock's re-basings, i.e. on how many other events, such as cell
    # crossings, the run had)
    assert sim.time == pytest.approx(t_inf, abs=5e-8)
    assert sim.state.position[0, -1] - R + 0.5 >= -1e-12  # consistent state: on the floor, not through it


def test_zeno_in_reduced_units_stops_instead_of_creeping(dim):
    # g = 1, sigma = 1: once at rest, the ball bounces by round-off and each bounce moves the clock
    # on by ~10 ulps, which the stall count once took for progress (the run hung). Released at gap
    # h0: t_inf = sqrt(2 h0) (1 + e) / (1 - e), to the bounce of a round-off height (h ~ 1e-15, 1e-7
    # long). (A gap of 2 happens to end on exact zeros: that run stopped before the fix too.)
    e, h0 = 0.5, 1.3
    pos, vel = np.zeros((1, dim)), np.zeros((1, dim))
    pos[0, -1] = -5.0 + 0.5 + h0
    s = edmd.State(position=pos, velocity=vel, radius=0.5, mass=1.0, box=[10.0] * dim, periodic=[False] * dim)
    g = np.zeros(dim)
    g[-1] = -1.0
    sim = edmd.Simulation(s, walls=collide.Wall(e_n=e), gravity=g)
    with pytest.raises(CollapseError, match="without the clock advancing"):
        sim.run(until_time=100.0, max_events=200_000)
    assert sim.time == pytest.approx(math.sqrt(2 * h0) * (1 + e) / (1 - e), abs=1e-6)


def test_zeno_with_tc_keeps_bouncing_with_a_fixed_period(dim):
    h0, e, tc = 0.3, 0.8, 1e-3
    sim = ball(dim, h0, e, rule=collide.TC(collide.Inelastic(1.0), tc))
    sim.run(until_time=3.0)  # far past t_inf = 2.2: the run does not stall
    t = bounce_times(sim, 6)
    period = np.diff(t)
    assert np.allclose(period, period[0], rtol=1e-9)  # elastic bounces from now on
    # the first interval below t_TC follows a dissipative bounce, Delta_k = e Delta_{k-1} >= e t_TC,
    # and repeats from then on: e t_TC <= period < t_TC (physics.md §3 says t_TC..t_TC/e, an off-by-one)
    assert e * tc <= period[0] < tc
    # energy is conserved from then on
    e0 = sim.state.kinetic_energy() + sim.state.potential_energy(sim.gravity)
    sim.run(until_time=4.0)
    assert sim.state.kinetic_energy() + sim.state.potential_energy(sim.gravity) == pytest.approx(e0, rel=1e-10)


def test_wall_pressure_of_a_dilute_gas_in_a_box(dim):
    """Contact theorem: force on a wall = kT x centre density at contact x area the centres reach.

    Centres live in V_acc = prod(L - 2R) and reach (L - 2R)^(d-1) of a face, so the mechanical
    pressure (force / full face area) is N kT / V_acc * prod_{j != k}(1 - 2R/L_j), times the
    dilute virial factor 1 + 2^(d-1) eta. Each hit carries 2 m v_n (relative spread ~0.5), so
    with > 5000 hits the statistical error is below 1 %.
    """
    n, eta = (1000, 0.01 if dim == 2 else 0.002)
    s = edmd.maxwell_boltzmann(edmd.random_packing(n, eta, dim=dim, periodic=[False] * dim, seed=3), 1.0, seed=4)
    sim = edmd.Simulation(s)
    th = sim.add(edmd.Thermo(interval=100.0))
    sim.run(until_time=1500.0 if dim == 2 else 600.0)
    table = th.table()
    L = s.box
    reach = np.prod(1 - 1.0 / L) / (1 - 1.0 / L[0])  # cubic/square box: same for every axis
    expected = n / np.prod(L - 1.0) * reach * (1 + 2 ** (dim - 1) * eta)
    measured = np.mean([table[f"wall_pressure_{a}"][1:].mean() for a in "xyz"[:dim]])
    assert sim.totals().wall_collisions > 5_000
    assert measured == pytest.approx(expected, rel=0.025)


def test_energy_balance_with_gravity_walls_and_rough_particles(dim):
    s = edmd.random_packing(300, 0.15, dim=dim, periodic=[True] * (dim - 1) + [False], seed=5, radius={"kind": "uniform", "min": 0.4, "max": 0.6}, density=1.0)
    s = edmd.maxwell_boltzmann(s, 2.0, seed=6, spin=True)
    g = np.zeros(dim)
    g[-1] = -0.5
    sim = edmd.Simulation(s, collision=collide.TC(collide.Rough(0.8, beta=0.2, mu=0.3), 1e-4), walls=collide.Wall(0.7, beta=0.0), gravity=g)
    th = sim.add(edmd.Thermo(interval=5.0))
    sim.run(max_events=300_000)
    sim.add(edmd.Thermo(interval=1.0))
    table = th.table()
    balance = table["energy_balance"]
    assert table["dissipated_energy"][-1] > 0.3 * (s.kinetic_energy() + s.rotational_energy())
    assert np.abs(balance / balance[0] - 1).max() < 1e-10
    final = sim.state
    total = final.kinetic_energy() + final.rotational_energy() + final.potential_energy(g) + sim.totals().dissipated
    assert total == pytest.approx(balance[0], rel=1e-10)
    assert sim.totals().wall_collisions > 100


@pytest.mark.parametrize("mode, intruders", [("list", False), ("cells", False), ("cells", True)])
def test_column_in_gravity_matches_brute_force(dim, mode, intruders):
    """Inelastic disks/spheres between a floor and a ceiling in gravity, periodic sideways; also
    two intruders (a Brazil-nut bed: size ratio 10 in 2D, 5 in 3D, equal masses) taken out of
    cells mode's cell size (physics.md §1.4 "Big particles").

    Same collision and wall-bounce sequence as the independent reference (eager updates,
    np.roots for the wall parabolas) and the same final state to 1e-9.
    """
    from reference import run_reference

    from edmd._core.cells import GI_BIGS

    periodic = [True] * (dim - 1) + [False]
    aspect = [1] * (dim - 1) + [2]
    if intruders:  # (short enough that chaos keeps round-off < 1e-9)
        n, eta, t_end, small = (150, 0.1, 1.4, 0.1) if dim == 2 else (300, 0.03, 1.2, 0.2)
        radius, density = {"kind": "discrete", "values": [small, 1.0], "fractions": [1 - 2 / n, 2 / n]}, None
    else:
        n, eta, t_end = (60, 0.2, 2.5) if dim == 2 else (150, 0.2, 1.2)
        radius, density = {"kind": "uniform", "min": 0.4, "max": 0.6}, 1.0
    s = edmd.random_packing(n, eta, dim=dim, periodic=periodic, seed=7, aspect=aspect, radius=radius, density=density)
    s = edmd.maxwell_boltzmann(s, 1.0, seed=8)
    g = np.zeros(dim)
    g[-1] = -2.0
    sim = edmd.Simulation(s, e_n=0.9, walls=collide.Wall(e_n=0.8), gravity=g, engine={"neighbours": mode, "debug": True})
    assert sim.engine.grid.shape[GI_BIGS] == (2 if intruders else 0)
    sim.engine.enable_log()
    bounces = []
    while sim.time < t_end:
        before = sim.totals().wall_collisions
        sim.run(until_time=t_end, max_events=1)
        if sim.totals().wall_collisions > before:
            bounces.append(sim.engine.now)
    log = sim.engine.take_log()
    pos, vel, ref = run_reference(s.position, s.velocity, s.radius, s.mass, s.box, t_end, e_n=0.9, gravity=g, periodic=periodic, e_wall=0.8)
    ref_pairs = np.array([r for r in ref if r[2] >= 0])
    ref_walls = np.array([r[0] for r in ref if r[2] < 0])
    assert len(ref_walls) > 10 and len(ref_pairs) > (n // 3 if intruders else n)
    assert np.array_equal(np.sort(log[:, 1:3], axis=1).astype(int), ref_pairs[:, 1:].astype(int))
    assert np.abs(log[:, 0] - ref_pairs[:, 0]).max() < 1e-9
    assert np.abs(np.array(bounces) - ref_walls).max() < 1e-9
    final = sim.state
    d = final.position - pos
    d -= np.where(final.periodic, final.box * np.round(d / final.box), 0.0)
    assert np.abs(d).max() < 1e-9 and np.abs(final.velocity - vel).max() < 1e-9
