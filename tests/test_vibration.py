"""The vibrating wall (physics.md §1.6, _core/walls.py and physics/vibration.py): contact times against an independent brute-force search,
the wall-frame collision, the bouncing ball's period-one orbit and its period doubling, the
energy balance, and the checks of bad input."""

import math
import tomllib

import numpy as np
import pytest
from scipy.signal import sawtooth

import edmd
from edmd._core import layout as L
from edmd._core.walls import moving_wall_time
from edmd.physics.vibration import VibratingWall

A, OMEGA = 0.1, 2.0 * math.pi
WAVES = {"sine": np.sin, "triangle": lambda th: sawtooth(th + 0.5 * np.pi, 0.5), "sawtooth": lambda th: sawtooth(th + np.pi, 1.0)}


def _geo(wave, phase):
    box, half = np.full(3, 10.0), np.array([np.inf, np.inf, 5.0])
    return L.make_geo(box, half, None, (2, 0, VibratingWall(A, OMEGA, wave=wave).geo_entries(0.0)[2], A, OMEGA, phase))


def _gap(wave, h, v, g, th, s):
    """The gap between particle and wall, ``f(s) = h + v s + g s^2/2 - a (1 + w(th + omega s))``."""
    return h + v * s + 0.5 * g * s * s - A * (1.0 + WAVES[wave](th + OMEGA * s))


def _bisect(fun, lo, hi, iters=80):
    """Vectorised bisection of ``fun`` with ``fun(lo) > 0 >= fun(hi)``: the bracket's upper end."""
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        pos = fun(mid) > 0.0
        lo, hi = np.where(pos, mid, lo), np.where(pos, hi, mid)
    return hi


def brute_force_times(wave, h, v, g, th, horizon, m=4001):
    """Earliest closing root of every flight (``inf``: none before ``horizon``): a fine grid, where
    each sign change is bisected, and each grid minimum that stays positive at the grid points is
    refined (bisection of the slope) in case the gap dips below zero between them (grazing). The
    grid of a sawtooth also holds the instant just before each of its jumps."""
    s = np.broadcast_to(np.linspace(0.0, horizon, m), (len(h), m))
    if wave == "sawtooth":  # jumps where th + omega s = pi (mod 2 pi)
        jump = np.mod(np.pi - th, 2 * np.pi) / OMEGA - 1e-12
        s = np.sort(np.concatenate([s, np.clip(jump, 0.0, horizon)[:, None]], axis=1), axis=1)
    f = _gap(wave, h[:, None], v[:, None], g[:, None], th[:, None], s)
    fs = lambda x, k: _gap(wave, h[k], v[k], g[k], th[k], x)  # noqa: E731
    best = np.full(len(h), np.inf)
    rows, cols = np.nonzero((f[:, :-1] > 0.0) & (f[:, 1:] <= 0.0))
    first = {}
    for r, c in zip(rows, cols):
        first.setdefault(r, c)
    k = np.array(list(first), int)
    if k.size:
        c = np.array([first[r] for r in k])
        best[k] = _bisect(lambda x: fs(x, k), s[k, c], s[k, c + 1])
    # dips between grid points: interior grid minima with f > 0 at the points
    interior = (f[:, 1:-1] <= f[:, :-2]) & (f[:, 1:-1] <= f[:, 2:]) & (f[:, 1:-1] > 0.0)
    rows, cols = np.nonzero(interior)
    if rows.size:
        lo, hi = s[rows, cols], s[rows, cols + 2]
        ds = 1e-9
        slope = lambda x: (fs(x + ds, rows) - fs(x - ds, rows)) / (2 * ds)  # noqa: E731
        tmin = _bisect(lambda x: -slope(x), lo, hi, 60)  # slope < 0 left of the minimum
        dip = fs(tmin, rows) <= 0.0
        k = rows[dip]
        np.minimum.at(best, k, _bisect(lambda x: fs(x, k), lo[dip], tmin[dip]))
    return best


def random_flights(wave, n, rng):
    """Flights that start clear of the wall; a third of them graze the wall's path (they touch it
    tangentially at a random time, shifted by +-1e-9 ... 1e-5)."""
    th = rng.uniform(0.0, 2 * np.pi, n)
    g = -rng.uniform(0.0, 30.0, n)
    d0 = A * (1.0 + WAVES[wave](th))
    h = d0 + rng.uniform(0.0, 0.3, n) ** 2
    v = rng.normal(0.0, 1.0, n)
    graze = np.arange(n) % 3 == 0
    s0 = rng.uniform(0.05, 0.55, n)
    eps = rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-9, -5, n)
    dw = 1e-7
    wall_v = A * (WAVES[wave](th + OMEGA * (s0 + dw)) - WAVES[wave](th + OMEGA * (s0 - dw))) / (2 * dw)
    vg = wall_v - g * s0
    hg = A * (1.0 + WAVES[wave](th + OMEGA * s0)) + eps - vg * s0 - 0.5 * g * s0 * s0
    keep = graze & (hg > d0)
    h, v = np.where(keep, hg, h), np.where(keep, vg, v)
    return h, v, g, th


def check_contact_times(wave, n, seed):
    rng = np.random.default_rng(seed)
    h, v, g, th = random_flights(wave, n, rng)
    horizon = 0.6
    ref = brute_force_times(wave, h, v, g, th, horizon)
    got = np.array([moving_wall_time(h[k], v[k], g[k], 0.0, _geo(wave, th[k]), horizon) for k in range(n)])
    missed = np.isinf(got) & np.isfinite(ref)
    spurious = np.isfinite(got) & np.isinf(ref)
    assert not missed.any(), f"missed contacts: {np.nonzero(missed)[0][:5]}"
    assert not spurious.any(), f"spurious contacts: {np.nonzero(spurious)[0][:5]}"
    both = np.isfinite(ref)
    assert np.abs(got[both] - ref[both]).max() < 1e-9
    assert both.sum() > n // 4  # the sample has many contacts (and many misses)


@pytest.mark.parametrize("wave", list(WAVES))
def test_contact_times_against_brute_force(wave):
    check_contact_times(wave, 3000, seed=11)


@pytest.mark.slow
@pytest.mark.parametrize("wave", list(WAVES))
def test_contact_times_against_brute_force_1e5(wave):
    for chunk in range(10):
        check_contact_times(wave, 10_000, seed=100 + chunk)


def test_contact_just_after_impact_is_not_repeated():
    # a particle leaving the wall at the wall's own position: no contact at s = 0 again
    geo = _geo("sine", 0.3)
    d, u = A * (1.0 + math.sin(0.3)), A * OMEGA * math.cos(0.3)
    assert moving_wall_time(d, u + 0.5, -1.0, 0.0, geo, 10.0) > 0.1
    assert moving_wall_time(d, u - 0.5, -1.0, 0.0, geo, 10.0) == 0.0  # touching and approaching: now


def _ball(dim, e, gamma, v_factor, phase_factor=1.0):
    """One ball on a sine floor (g = 1, period 1), started at the period-one impact with a perturbed take-off speed."""
    g, om = 1.0, 2.0 * math.pi
    a = gamma * g / om**2
    theta = math.acos(math.pi * (1 - e) / (gamma * (1 + e)))
    t0 = theta * phase_factor / om
    floor = VibratingWall(amplitude=a, omega=om, axis="xyz"[dim - 1])
    r = 0.05
    z = -0.5 + floor.displacement(t0) + r
    pos, vel = np.zeros((1, dim)), np.zeros((1, dim))
    pos[0, -1], vel[0, -1] = z, v_factor * math.pi * g / om
    periodic = np.array([True] * (dim - 1) + [False])
    state = edmd.State(pos, vel, np.array([r]), np.array([1.0]), box=np.ones(dim), periodic=periodic, time=t0)
    grav = [0.0] * (dim - 1) + [-g]
    sim = edmd.Simulation(state, walls=edmd.collide.Wall(e_n=e), gravity=grav, vibration=floor)
    sim.engine.enable_log(walls=True)
    return sim, theta, floor


@pytest.mark.parametrize("dim", [2, 3])
def test_bouncing_ball_locks_into_the_period_one_orbit(dim):
    # physics.md §1.6: cos(theta*) = pi (1 - e) / (Gamma (1 + e)), take-off speed pi g / omega
    e, gamma = 0.5, 1.2
    sim, theta, floor = _ball(dim, e, gamma, 1.05)
    sim.run(until_time=sim.time + 80.0)
    log = sim.engine.take_log()
    assert np.all(log[:, 2] == -1 - 2 * (dim - 1))  # the lower wall of the last axis
    last = log[-5:]
    phase = np.mod(floor.omega * last[:, 0], 2 * math.pi)
    takeoff = floor.velocity(last[:, 0]) + e * last[:, 3]
    assert phase == pytest.approx(theta, abs=1e-9)
    assert takeoff == pytest.approx(math.pi * 1.0 / floor.omega, rel=1e-9)
    assert np.diff(last[:, 0]) == pytest.approx(floor.period, rel=1e-9)


def test_bouncing_ball_period_doubles_above_the_stability_range():
    # stable while Gamma^2 < (pi (1-e)/(1+e))^2 + (2 (1+e^2)/(1+e)^2)^2 (1.527 for e = 0.5)
    e = 0.5
    bound = math.hypot(math.pi * (1 - e) / (1 + e), 2 * (1 + e * e) / (1 + e) ** 2)
    sim, _theta, floor = _ball(3, e, 1.05 * bound, 1.01)
    sim.run(until_time=sim.time + 150.0)
    t = sim.engine.take_log()[-6:, 0]
    phase = np.mod(floor.omega * t, 2 * math.pi)
    assert abs(phase[-1] - phase[-3]) < 1e-6 and abs(phase[-2] - phase[-4]) < 1e-6  # period two
    assert abs(phase[-1] - phase[-2]) > 1e-2


def _mechanical_energy(sim, grav):
    s = sim.state
    return s.kinetic_energy() + s.rotational_energy() - float(s.mass @ (s.position @ np.asarray(grav)))


@pytest.mark.parametrize("wave", list(WAVES))
@pytest.mark.parametrize("dim", [2, 3])
def test_vibrated_bed_energy_balance(dim, wave):
    # input (the walls' work) - dissipated - change of mechanical energy = 0 to round-off
    state = edmd.maxwell_boltzmann(edmd.random_packing(150, 0.05, dim=dim, seed=3, periodic=[True] * (dim - 1) + [False]), 1.0, seed=4)
    axis = "xyz"[dim - 1]
    phase = -math.pi if wave == "sawtooth" else -0.5 * math.pi  # the wall starts at its rest plane
    floor = VibratingWall(amplitude=0.5, omega=3.0, phase=phase, axis=axis, wave=wave)
    assert floor.displacement(0.0) == pytest.approx(0.0, abs=1e-15)
    grav = [0.0] * (dim - 1) + [-1.0]
    sim = edmd.Simulation(state, collision=edmd.collide.TC(edmd.collide.Inelastic(0.9), 1e-3), walls=edmd.collide.Wall(e_n=0.8), gravity=grav, vibration=floor)
    e0 = sim.totals()
    before = _mechanical_energy(sim, grav)
    sim.run(until_time=60.0)
    tot = sim.totals()
    change = _mechanical_energy(sim, grav) - before
    balance = (tot.energy_input - e0.energy_input) - (tot.dissipated - e0.dissipated) - change
    assert tot.energy_input > 0.1 * tot.dissipated > 0  # the wall works
    assert abs(balance) < 1e-9 * tot.energy_input


VISCO = edmd.collide.Viscoelastic(young=63e9, poisson=0.2, A=1e-7)


@pytest.mark.parametrize("dim", [2, 3])
def test_viscoelastic_bed_on_a_vibrating_floor_keeps_going(dim):
    # millimetre glass beads, e_n(v) at the floor and between beads, the TC model against the
    # chattering of beads that come to rest on the floor (e_n(v) alone lets it converge in finite time)
    state = edmd.random_packing(300, 0.05, dim=dim, seed=3, periodic=[True] * (dim - 1) + [False], aspect=[1.0] * (dim - 1) + [2.0], radius=1e-3, density=2500.0)
    state = edmd.maxwell_boltzmann(state, 1e-9 if dim == 2 else 1e-12, seed=4)
    material = edmd.collide.Viscoelastic(young=6.3e10, poisson=0.2, A=1e-6)
    floor = VibratingWall(amplitude=1e-3, omega=2 * math.pi * 50, phase=-0.5 * math.pi, axis="xyz"[dim - 1])  # Gamma = 10
    grav = [0.0] * (dim - 1) + [-9.81]
    rule = edmd.collide.TC(material, 1e-5)
    sim = edmd.Simulation(state, collision=rule, walls=edmd.collide.Wall(e_n=material), gravity=grav, vibration=floor)
    before = _mechanical_energy(sim, grav)
    sim.run(until_time=0.5)
    t = sim.totals()
    assert t.wall_collisions > 300 and t.collisions > 1000
    assert abs(t.energy_input - t.dissipated - (_mechanical_energy(sim, grav) - before)) < 1e-9 * t.energy_input


@pytest.mark.parametrize("law", [0.7, VISCO], ids=["constant", "viscoelastic"])
def test_moving_wall_collision_in_the_wall_frame(law):
    # a wall moving up at u: the rebound is u - e(|v - u|) (v - u), e taken at the speed relative to
    # the wall; the tangential velocity is kept (smooth wall); the wall's work is u J
    from edmd._core.collide import collide_wall

    u, v, m, radius = 0.4, -1.0, 1e-5, 1e-3
    box, half = np.full(3, 10.0), np.array([np.inf, np.inf, 5.0])
    a, om = u * math.pi, 1.0  # a sawtooth moves with the constant velocity 2 a omega / (2 pi) = u
    geo = L.make_geo(box, half, None, (2, 0, L.WAVE_SAWTOOTH, a, om, 0.0))
    P = np.zeros((1, L.ROW))
    P[0, L.VX], P[0, L.VZ], P[0, L.R] = 0.3, v, radius
    mass, inertia, omega = np.full(1, m), np.full(1, 0.4 * m * radius**2), np.zeros((1, 3))
    fp, ip = np.zeros(L.N_FP), np.zeros(L.N_IP, np.int64)
    edmd.collide.pack(edmd.collide.Inelastic(1.0), edmd.collide.Wall(e_n=law), fp, ip)
    acc = np.zeros(L.N_ACC)
    vn, _vt = collide_wall(0.0, P, mass, omega, inertia, np.full(1, -np.inf), 0, 2, 0, geo, fp, ip, edmd.collide.viscoelastic_table()[0], acc, 0.0)
    e = law if law == 0.7 else VISCO.restitution(u - v, mu=m, r_eff=radius)
    assert e < 0.99
    assert vn == pytest.approx(u - v)
    assert P[0, L.VZ] == pytest.approx(u + e * (u - v), rel=1e-6 if law is VISCO else 1e-14)  # (the core's e(v) is a spline)
    assert P[0, L.VX] == 0.3
    jz = m * (P[0, L.VZ] - v)
    assert acc[L.A_ENERGY_INPUT] == pytest.approx(u * jz, rel=1e-14)
    assert acc[L.A_DISSIPATED] == pytest.approx(0.5 * m * ((u - v) ** 2 - (P[0, L.VZ] - u) ** 2), rel=1e-12)
    assert acc[L.A_KE] == pytest.approx(acc[L.A_ENERGY_INPUT] - acc[L.A_DISSIPATED], rel=1e-12)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"amplitude": -1.0, "omega": 1.0}, "amplitude must be a positive"),
        ({"amplitude": 0.1, "omega": 1.0, "wave": "square"}, "wave must be one of sine, triangle, sawtooth"),
        ({"amplitude": 0.1, "omega": 1.0, "side": "top"}, "side must be one of lower, upper"),
        ({"amplitude": 0.1, "omega": math.inf}, "omega must be a positive"),
    ],
)
def test_bad_vibration_parameters(kwargs, message):
    with pytest.raises(ValueError, match=message):
        VibratingWall(**kwargs)


def test_vibration_needs_room_and_a_walled_axis():
    state = edmd.random_packing(20, 0.05, dim=2, seed=1, periodic=[True, False])
    with pytest.raises(edmd.StateError, match="must be closed by walls"):
        edmd.Simulation(state, vibration=VibratingWall(0.1, 1.0, axis="x"))
    with pytest.raises(edmd.StateError, match="no room left"):
        edmd.Simulation(state, vibration=VibratingWall(state.box[1], 1.0, axis="y"))
    with pytest.raises(edmd.StateError, match="overlaps the vibrating wall"):  # phase 0: the floor starts at a
        edmd.Simulation(state, vibration=VibratingWall(0.45 * state.box[1], 1.0, axis="y"))


def test_vibration_from_config(tmp_path):
    cfg = edmd.parse_config(tomllib.loads(
        '[system]\ndim = 2\nn = 50\npacking_fraction = 0.05\ninit = "random"\ngravity = [0.0, -1.0]\n'
        '[walls]\naxes = ["y"]\n[vibration]\naxis = "y"\namplitude = 0.5\nomega = 2.0\nphase = -1.5707963267948966\n'
        "[run]\nuntil_time = 5.0\noutput_interval = 1.0\n"
    ))
    from edmd.app.runner import build_simulation

    sim = build_simulation(cfg)
    assert sim.params["vibration"]["kind"] == "vibrating_wall"
    sim.run(until_time=5.0)
    assert sim.totals().energy_input != 0.0
    with pytest.raises(edmd.ConfigError, match="vibration.axis"):
        edmd.parse_config(tomllib.loads('[walls]\naxes = ["z"]\n[vibration]\naxis = "x"\namplitude = 1.0\nomega = 1.0\n'))


def test_emdstar_bed_on_a_vibrating_floor_keeps_its_energy_balance(dim):
    # soft contacts (eMD*): a relocation may not cross the moving floor (exception a uses its
    # position at the time), a pending contact that reaches it completes first (exception b)
    from edmd.physics.contact import Hertz
    from edmd.physics.emdstar import EMDStar

    periodic = [True] * (dim - 1) + [False]
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.2, dim=dim, periodic=periodic, seed=9), 1.0, seed=10)
    grav = [0.0] * (dim - 1) + [-0.5]
    floor = VibratingWall(amplitude=0.3, omega=3.0, phase=-0.5 * math.pi, axis="xyz"[dim - 1])
    sim = edmd.Simulation(s, collision=EMDStar(Hertz(young=2e3, poisson=0.3, A=2e-3)), gravity=grav, vibration=floor)
    thermo = sim.add(edmd.Thermo(0.5))
    sim.run(until_time=4.0)
    balance = np.array([r["energy_balance"] for r in thermo.rows])
    assert np.abs(balance / balance[0] - 1.0).max() < 1e-10
    assert sim.totals().energy_input > 0 and sim.engine.emd_counters()["emd_contacts"] > 100


@pytest.mark.parametrize("side, intruders", [("lower", False), ("upper", False), ("lower", True)])
def test_lists_and_cells_agree_with_a_vibrating_wall(dim, side, intruders):
    # two neighbour structures, one physics: the same impacts and collisions, the same final state
    # (to the round-off that 3 time units of chaos amplify), debug checks on; the upper wall
    # drives against gravity pointing up. With two intruders (a vibrated Brazil-nut bed: size
    # ratio 10 in 2D, 5 in 3D), which cells mode takes out of its cell size (physics.md §1.4), and
    # 1.5 time units (its small particles amplify round-off faster)
    from edmd._core.cells import GI_BIGS

    periodic = [True] * (dim - 1) + [False]
    n, eta, radius, t_end = 200, 0.15, 0.5, 3.0
    if intruders:
        n, eta, ratio, t_end = (200, 0.15, 10, 1.5) if dim == 2 else (600, 0.03, 5, 1.5)
        radius = {"kind": "discrete", "values": [1.0 / ratio, 1.0], "fractions": [1 - 2 / n, 2 / n]}
    s = edmd.random_packing(n, eta, dim=dim, periodic=periodic, seed=5, radius=radius, aspect=[1] * (dim - 1) + [2] if intruders else None)
    s = edmd.maxwell_boltzmann(s, 1.0, seed=6)
    grav = [0.0] * (dim - 1) + [-1.0 if side == "lower" else 1.0]
    wall = VibratingWall(amplitude=0.4, omega=4.0, phase=-0.5 * math.pi, axis="xyz"[dim - 1], side=side, wave="triangle")
    runs = []
    for mode in ("list", "cells"):
        rule = edmd.collide.TC(edmd.collide.Inelastic(0.9), 1e-3)
        sim = edmd.Simulation(s, collision=rule, walls=edmd.collide.Wall(e_n=0.8), gravity=grav, vibration=wall, engine={"neighbours": mode, "debug": True})
        assert sim.engine.grid.shape[GI_BIGS] == (2 if intruders and mode == "cells" else 0)
        sim.run(until_time=t_end)
        runs.append((sim.state.position, sim.totals().wall_collisions, sim.collisions))
    (pa, wa, ca), (pb, wb, cb) = runs
    assert (wa, ca) == (wb, cb) and wa > 20
    assert np.abs(pa - pb).max() < 1e-7


def test_rough_bed_on_a_sawtooth_keeps_its_energy_balance(dim):
    # rough spheres and a rough wall: spins are kicked at the moving wall too (the wall's
    # tangential velocity is zero); the balance includes the rotational energy
    periodic = [True] * (dim - 1) + [False]
    s = edmd.maxwell_boltzmann(edmd.random_packing(150, 0.05, dim=dim, periodic=periodic, seed=3), 1.0, seed=4)
    grav = [0.0] * (dim - 1) + [-1.0]
    wall = VibratingWall(amplitude=0.5, omega=3.0, phase=-math.pi, axis="xyz"[dim - 1], wave="sawtooth")
    rule = edmd.collide.TC(edmd.collide.Rough(0.9, beta=0.3), 1e-3)
    sim = edmd.Simulation(s, collision=rule, walls=edmd.collide.Wall(e_n=0.8, beta=0.2), gravity=grav, vibration=wall)
    thermo = sim.add(edmd.Thermo(1.0))
    sim.run(until_time=40.0)
    balance = np.array([r["energy_balance"] for r in thermo.rows])
    assert np.ptp(balance) < 1e-12 * sim.totals().energy_input
    assert sim.state.rotational_energy() > 0 and sim.totals().wall_collisions > 1000
