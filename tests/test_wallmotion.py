"""Riding on the vibrating wall, the sticking solution (physics.md §1.6.3, _core/wallmotion.py):
the closed-form take-off of a chattering bouncing ball, the release at the ends of the linear
waves' pieces, the contact times of riders against a brute-force search, beds that ride without
the TC model (energy balance, lists against cells), restarts and the checks of bad input."""

import math

import numpy as np
import pytest
from typer.testing import CliRunner

import edmd
from edmd._core import layout as L
from edmd._core.wallmotion import ride_end
from edmd._core.walls import ride_contact_time
from edmd.app.cli import app
from edmd.physics.vibration import VibratingWall

BALL_BOX = {2: [1.0, 1.0], 3: [1.0, 1.0, 1.0]}


def _ball(dim):
    pos = np.zeros((1, dim))
    return edmd.State(pos, pos.copy(), [0.05], [1.0], box=BALL_BOX[dim], periodic=[True] * (dim - 1) + [False])


def _take_offs(sim, count, until=60.0):
    """Times and velocities (along the vibration axis) at which the ball leaves the wall, event by event."""
    riding, out = False, []
    while sim.time < until and len(out) < count:
        sim.run(max_events=1)
        now = bool(sim.state.riding[0])
        if riding and not now:
            out.append((sim.time, sim.state.velocity[0, -1]))
        riding = now
    return np.array(out)


@pytest.mark.parametrize("e, om", [(0.5, 15.0), (0.4, 15.0), (0.5, 12.0)])
def test_chattering_ball_takes_off_where_the_floor_stops_pressing(dim, e, om):
    # complete chattering: the bounces converge, the ball rides, and leaves the floor where its
    # acceleration -a omega^2 sin(theta) falls below -g, sin(theta*) = 1/Gamma, at the floor's
    # velocity a omega cos(theta*); the motion is then exactly periodic (a whole number of periods)
    a, g = 0.01, 1.0
    floor = VibratingWall(amplitude=a, omega=om, phase=-0.5 * math.pi, axis="xyz"[dim - 1])
    grav = [0.0] * (dim - 1) + [-g]
    sim = edmd.Simulation(_ball(dim), walls=edmd.collide.Wall(e_n=e), gravity=grav, vibration=floor)
    before = sim.state.kinetic_energy() + sim.state.potential_energy(grav)
    offs = _take_offs(sim, 4)
    assert len(offs) == 4
    theta = np.mod(om * offs[:, 0] + floor.phase, 2 * math.pi)
    star = math.asin(g / (a * om * om))
    assert np.abs(theta - star).max() < 1e-12
    assert np.abs(offs[:, 1] - a * om * math.cos(star)).max() < 1e-12
    periods = np.diff(offs[:, 0]) / floor.period
    assert np.abs(periods - np.round(periods)).max() < 1e-9 and np.round(periods).min() >= 1
    t = sim.totals()
    after = sim.state.kinetic_energy() + sim.state.potential_energy(grav)
    assert abs(t.energy_input - t.dissipated - (after - before)) < 1e-12 * t.dissipated


@pytest.mark.parametrize("wave, ends", [("triangle", [0.5, 1.5]), ("sawtooth", [1.0])])
def test_linear_waves_release_riders_at_the_ends_of_their_pieces(wave, ends):
    # on a linear piece the floor does not accelerate and gravity presses the ball: it rides to
    # the piece's end with the floor's velocity (a triangle's peak and trough, the sawtooth's drop)
    a, om = 0.01, 15.0
    floor = VibratingWall(amplitude=a, omega=om, wave=wave)
    sim = edmd.Simulation(_ball(3), walls=edmd.collide.Wall(e_n=0.3), gravity=[0.0, 0.0, -20.0], vibration=floor)
    offs = _take_offs(sim, 6)
    assert len(offs) == 6
    at = np.mod(om * offs[:, 0], 2 * math.pi) / math.pi
    assert all(min(abs(x - y) for y in ends) < 1e-12 for x in at)
    speed = a * om * (4.0 if wave == "triangle" else 2.0) / (2 * math.pi)  # the piece's slope
    up = np.abs(at - ends[0]) < 1e-9  # rising pieces end at ends[0]
    assert np.allclose(offs[up, 1], speed, rtol=1e-12) and np.allclose(offs[~up, 1], -speed, rtol=1e-12)


def test_no_riding_without_a_stick_speed():
    # stick_speed = 0: the chattering ball piles up its bounces and the run stops, as before riding
    floor = VibratingWall(amplitude=0.01, omega=15.0, phase=-0.5 * math.pi, stick_speed=0.0)
    sim = edmd.Simulation(_ball(3), walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0], vibration=floor)
    with pytest.raises(edmd.CollapseError, match="Zeno"):
        sim.run(until_time=30.0)


# ---------------------------------------------------------------- contact times of riders
A, OMEGA, G, HALF = 0.1, 3.0, 0.5, 5.0  # Gamma = 1.8: the ride ends at sin(theta) = 1/Gamma


def _rider_geo(wave, phase):
    code = {"sine": L.WAVE_SINE, "triangle": L.WAVE_TRIANGLE}[wave]
    return L.make_geo(np.full(3, 2 * HALF), np.array([HALF, HALF, np.inf]), np.array([0.0, 0.0, -G]), (2, 0, code, A, OMEGA, phase, 1e-6))


def _wall(wave, th):
    if wave == "sine":
        return A * (1.0 + np.sin(th))
    q = np.mod(th / (2 * np.pi) + 0.25, 1.0)
    return A * (1.0 + np.where(q < 0.5, -1.0 + 4.0 * q, 3.0 - 4.0 * q))


def _separation(wave, case, s):
    """``f(s) = |r_rider - r_free|^2 - sigma^2`` along the flights of a case (vectorised over ``s``)."""
    th, xr, vr, rr, xf, vf, rf = case
    d = xr[:2, None] + vr[:2, None] * s - xf[:2, None] - vf[:2, None] * s
    zr = -HALF + _wall(wave, th + OMEGA * s) + rr
    zf = xf[2] + vf[2] * s - 0.5 * G * s * s
    return (d**2).sum(axis=0) + (zr - zf) ** 2 - (rr + rf) ** 2


def _brute_force(wave, case, horizon, m=20001):
    """First closing root of ``f`` before ``horizon`` (inf: none): a fine grid, each sign change and
    each positive grid minimum (a graze between the points) refined by bisection."""
    s = np.linspace(0.0, horizon, m)
    f = _separation(wave, case, s)
    fs = lambda x: _separation(wave, case, np.atleast_1d(x))[0]  # noqa: E731
    best = np.inf
    down = np.flatnonzero((f[:-1] > 0.0) & (f[1:] <= 0.0))
    if down.size:
        lo, hi = s[down[0]], s[down[0] + 1]
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if fs(mid) > 0.0 else (lo, mid)
        best = hi
    minima = np.flatnonzero((f[1:-1] <= f[:-2]) & (f[1:-1] <= f[2:]) & (f[1:-1] > 0.0)) + 1
    for k in minima:
        if s[k] >= best:
            break
        lo, hi = s[k - 1], s[k + 1]
        for _ in range(100):  # the minimum: bisection of the slope
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if fs(mid + 1e-10) < fs(mid - 1e-10) else (lo, mid)
        if fs(lo) <= 0.0:
            a_, b_ = s[k - 1], lo
            for _ in range(100):
                mid = 0.5 * (a_ + b_)
                a_, b_ = (mid, b_) if fs(mid) > 0.0 else (a_, mid)
            return b_
    return best


def _cases(wave, n, rng):
    """A rider (pressed at local time 0) and a free particle clear of it; a third graze it."""
    out = []
    c = G / (A * OMEGA * OMEGA)
    while len(out) < n:
        th = rng.uniform(0.0, 2 * np.pi)
        if wave == "sine" and not np.sin(th) < c:
            continue
        rr, rf = rng.uniform(0.3, 0.6, 2)
        xr = np.array([0.0, 0.0, -HALF + _wall(wave, th) + rr])
        vr = np.array([*rng.normal(0.0, 0.3, 2), 0.0])
        vf = rng.normal(0.0, 0.5, 3)
        xf = xr + rng.normal(0.0, 1.0, 3) * (rr + rf) * rng.uniform(1.0, 2.5)
        xf[2] = max(xf[2], -HALF + rf)
        case = (th, xr, vr, rr, xf, vf, rf)
        if _separation(wave, case, np.zeros(1))[0] <= 0.0:
            continue
        if len(out) % 3 == 0:  # aim the free particle at the rider's future position, off by a hair
            s0 = rng.uniform(0.05, 0.4)
            f0 = _separation(wave, case, np.array([s0]))[0]
            target = xr[:2] + vr[:2] * s0
            miss = math.sqrt(max((rr + rf) ** 2 - 0.0, 0.0)) * (1.0 + rng.choice([-1, 1]) * 10.0 ** rng.uniform(-9, -4))
            zr = -HALF + _wall(wave, th + OMEGA * s0) + rr
            direction = rng.normal(0.0, 1.0, 3)
            direction /= np.linalg.norm(direction)
            point = np.array([*target, zr]) + miss * direction
            xf = point - vf * s0 + np.array([0.0, 0.0, 0.5 * G * s0 * s0])
            case = (th, xr, vr, rr, xf, vf, rf)
            if _separation(wave, case, np.zeros(1))[0] <= 0.0 or not np.isfinite(f0):
                continue
        out.append(case)
    return out


def check_rider_contacts(wave, n, seed):
    """No missed or spurious contact of a rider and a free particle, and times to 1e-9."""
    rng = np.random.default_rng(seed)
    found = 0
    for case in _cases(wave, n, rng):
        th, xr, vr, rr, xf, vf, rf = case
        geo = _rider_geo(wave, th)
        P = np.zeros((1, L.ROW + 1))
        P[0, :3], P[0, 3:6], P[0, L.R], P[0, L.RIDE] = xr, vr, rr, 1.0
        horizon = ride_end(0.0, geo)
        got = ride_contact_time(*xf, *vf, rf, P, 0, 0.0, geo)
        ref = _brute_force(wave, case, min(horizon, 3.0))
        if ref == np.inf:
            assert got == np.inf or got >= 3.0 - 1e-12, (case, got)
        else:
            found += 1
            assert got == pytest.approx(ref, abs=1e-9), case
    assert found > n // 5


@pytest.mark.parametrize("wave", ["sine", "triangle"])
def test_rider_contact_times_against_brute_force(wave):
    check_rider_contacts(wave, 300, 11 if wave == "sine" else 12)


@pytest.mark.slow
@pytest.mark.parametrize("wave", ["sine", "triangle"])
def test_rider_contact_times_against_brute_force_1e4(wave):
    check_rider_contacts(wave, 10000, 21 if wave == "sine" else 22)


# ---------------------------------------------------------------- beds
def _ball_bed(dim, mode):
    """Thirty balls on a floor at Gamma = 1.5, inelastic walls and pairs, no TC model: most of
    them come to rest on the floor and ride on it for part of every period."""
    periodic = [True] * (dim - 1) + [False]
    state = edmd.maxwell_boltzmann(edmd.random_packing(30, 0.02, dim=dim, seed=3, periodic=periodic, aspect=[1.0] * (dim - 1) + [0.5]), 0.01, seed=4)
    floor = VibratingWall(amplitude=0.05, omega=5.5, phase=-0.5 * math.pi, axis="xyz"[dim - 1])
    grav = [0.0] * (dim - 1) + [-1.0]
    walls = edmd.collide.Wall(e_n=0.5)
    return edmd.Simulation(state, collision=edmd.collide.Inelastic(0.9), walls=walls, gravity=grav, vibration=floor, engine={"neighbours": mode, "debug": True})


def test_riding_bed_keeps_its_energy_balance_in_lists_and_cells(dim):
    # the two neighbour structures give the same collisions and rides (debug checks on). The
    # last bounces before a ride amplify round-off (their heights are ~1e-13), so the number of
    # bounces before each stick may differ by one; the rides are the same
    runs = []
    for mode in ("list", "cells"):
        sim = _ball_bed(dim, mode)
        sim.engine.enable_log(walls=True)
        thermo = sim.add(edmd.Thermo(0.5))
        sim.run(until_time=10.0)
        t = sim.totals()
        balance = np.array([r["energy_balance"] for r in thermo.rows])
        assert np.ptp(balance) < 1e-11 * t.dissipated
        log = sim.engine.take_log()
        floor = log[:, 2] == -1 - 2 * (dim - 1)
        sticks = int(np.sum(floor & (0.5 * log[:, 3] <= sim.engine.geo[L.G_WALL_STICK])))
        runs.append((sim.state.position, sim.collisions, sticks, t.wall_collisions))
    (pa, ca, sa, wa), (pb, cb, sb, wb) = runs
    assert (ca, sa) == (cb, sb) and sa >= 3 and ca > 20
    assert abs(wa - wb) <= sa
    assert np.abs(pa - pb).max() < 1e-6


VISCO = edmd.collide.Viscoelastic(young=6.3e10, poisson=0.2, A=1e-6)


def test_bead_bed_keeps_going_without_the_tc_model(dim):
    # millimetre glass beads with e_n(v) on a floor at Gamma = 10: e_n(v) -> 1 alone does not stop
    # the chattering of a bead that comes to rest on the floor (in 3D one did at t = 0.08 s, and
    # the run stopped there before riding); it now rides
    state = edmd.random_packing(300, 0.05, dim=dim, seed=3, periodic=[True] * (dim - 1) + [False], aspect=[1.0] * (dim - 1) + [2.0], radius=1e-3, density=2500.0)
    state = edmd.maxwell_boltzmann(state, 1e-9 if dim == 2 else 1e-12, seed=4)
    floor = VibratingWall(amplitude=1e-3, omega=2 * math.pi * 50, phase=-0.5 * math.pi, axis="xyz"[dim - 1])
    sim = edmd.Simulation(state, collision=VISCO, walls=edmd.collide.Wall(e_n=VISCO), gravity=[0.0] * (dim - 1) + [-9.81], vibration=floor)
    thermo = sim.add(edmd.Thermo(0.01))
    sim.run(until_time=0.3)
    t = sim.totals()
    assert t.collisions > 5000 and t.wall_collisions > 500
    balance = np.array([r["energy_balance"] for r in thermo.rows])
    assert np.ptp(balance) < 1e-10 * t.energy_input


# ---------------------------------------------------------------- states, restarts, bad input
def test_riders_that_no_longer_move_with_the_wall_fly_on():
    # a state's riders go on riding only where they are on the wall and move with it
    floor = VibratingWall(amplitude=0.01, omega=15.0, phase=-0.5 * math.pi)
    sim = edmd.Simulation(_ball(3), walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0], vibration=floor)
    while not sim.state.riding[0]:
        sim.run(max_events=1)
    state = sim.state
    again = edmd.Simulation(state, walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0], vibration=floor)
    assert again.state.riding[0]
    state.velocity = state.velocity * 1.01 + 1e-3  # (an updater's work)
    moved = edmd.Simulation(state, walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0], vibration=floor)
    assert not moved.state.riding[0]
    no_wall = edmd.Simulation(state, walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0])
    assert not no_wall.state.riding[0]


def test_bad_riding_field_is_named():
    with pytest.raises(edmd.StateError, match="riding must be 2 booleans"):
        edmd.State([[0.0, 0.0], [2.0, 0.0]], [[0.0, 0.0]] * 2, 0.5, 1.0, box=[10.0, 10.0], riding=[0.5, 1.0])
    with pytest.raises(ValueError, match="stick_speed must be a number >= 0"):
        VibratingWall(amplitude=0.1, omega=1.0, stick_speed=-1.0)


BALLS = """
[system]
dim = 2
n = 4
packing_fraction = 0.01
init = "random"
seed = 2
kT = 0.01
gravity = [0.0, -1.0]
[walls]
axes = ["y"]
e_n = 0.3
[vibration]
axis = "y"
amplitude = 0.05
omega = 4.7
phase = -1.5707963267948966
[run]
until_time = {until}
output_interval = 0.25
progress = false
[output]
trajectory_interval = 0.25
checkpoint_interval = 0.5
plots = false
"""


def test_restart_in_the_middle_of_rides_is_bit_for_bit(tmp_path):
    # balls chattering to rest on a floor at Gamma = 1.1 spend most of each period riding: the
    # checkpoints fall in the middle of rides, and a restart continues them exactly
    from test_restart import assert_same_files

    runner = CliRunner()
    for name, until in (("ref", 12.0), ("x", 5.5)):
        cfg = tmp_path / f"{name}.toml"
        cfg.write_text(BALLS.format(until=until))
        r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / name)])
        assert r.exit_code == 0, r.output
    ck = edmd.read_checkpoint(tmp_path / "x" / "checkpoint.gsd")
    assert ck.state.riding.any()
    r = runner.invoke(app, ["run", "--restart", str(tmp_path / "x"), "--until-time", "12.0"])
    assert r.exit_code == 0, r.output
    assert_same_files(tmp_path / "ref", tmp_path / "x", traj="trajectory.gsd")


@pytest.mark.parametrize("x0", np.linspace(0.40, 0.44, 6))
def test_a_rider_bouncing_off_a_side_wall_rides_on(x0):
    # a smooth side wall ends the ride without a kick along the axis: the ball is still on the
    # pressing floor, moving with it, and rides on (it used to wait for a bounce that never came)
    floor = VibratingWall(amplitude=0.01, omega=15.0, phase=-0.5 * math.pi)
    state = edmd.State([[x0, 0.0, -0.45]], [[1.0, 0.0, 0.0]], [0.05], [1.0], box=[1.0, 1.0, 1.0], periodic=[False, True, False], riding=[True])
    sim = edmd.Simulation(state, walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0], vibration=floor)
    before = sim.state.kinetic_energy() + sim.state.potential_energy([0.0, 0.0, -1.0])
    sim.run(until_time=3.0)
    t = sim.totals()
    bounces = math.log2(1.0 / abs(sim.state.velocity[0, 0]))  # the side walls' e_n = 0.5 (smooth: only vx changes)
    assert t.wall_collisions >= 3 and bounces >= 1 and bounces == round(bounces)
    after = sim.state.kinetic_energy() + sim.state.potential_energy([0.0, 0.0, -1.0])
    assert abs(t.energy_input - t.dissipated - (after - before)) < 1e-12 * max(abs(t.energy_input), 1e-3)


@pytest.mark.parametrize("x0", np.linspace(0.10, 0.14, 4))
def test_two_riders_colliding_head_on_ride_on(x0):
    floor = VibratingWall(amplitude=0.01, omega=15.0, phase=-0.5 * math.pi)
    state = edmd.State([[-x0, 0.0, -0.45], [x0, 0.0, -0.45]], [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]], [0.05, 0.05], [1.0, 1.0],
                       box=[1.0, 1.0, 1.0], periodic=[True, True, False], riding=[True, True])  # fmt: skip
    sim = edmd.Simulation(state, collision=edmd.collide.Inelastic(0.9), walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0], vibration=floor)
    sim.run(until_time=0.3)
    assert sim.collisions >= 1 and np.allclose(np.abs(sim.state.velocity[:, 0]), 0.9 ** sim.collisions)
