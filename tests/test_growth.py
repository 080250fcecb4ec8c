"""Growing particles (docs/physics.md §1.7): pair times with growing radii, compression, restarts."""

import math
import tomllib

import numpy as np
import pytest

import edmd
from edmd import Growth, Simulation, compress
from edmd.run.compress import compression_time
from edmd._core.growth import growing_contact_time
from edmd.files.checkpoint import Checkpoint, load_checkpoint
from edmd.state import StateError


def brute_force_growing_contact(d, g, s, ds, horizon):
    """First time the gap |d + g t| - (s + ds t) turns from positive to <= 0, on a fine grid then by bisection."""
    gap = lambda t: np.linalg.norm(d + g * t) - (s + ds * t)  # noqa: E731
    if gap(0.0) <= 0.0:
        return math.nan  # (the predictor's convention at contact is checked separately)
    ts = np.linspace(0.0, horizon, 200001)
    values = np.linalg.norm(d[None, :] + ts[:, None] * g[None, :], axis=1) - (s + ds * ts)
    below = np.flatnonzero(values <= 0.0)
    if below.size == 0:
        return math.inf
    lo, hi = ts[below[0] - 1], ts[below[0]]
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if gap(mid) > 0.0 else (lo, mid)
    return hi


def test_pair_times_with_growing_radii_match_a_brute_force_search(rng):
    """Random separations and velocities, radii growing slowly or fast (pairs moving apart that
    meet only because they grow): the predicted time is the first root of the gap."""
    checked = met_by_growth = 0
    for _ in range(400):
        d = rng.normal(size=3) * rng.uniform(1.0, 3.0)
        g = rng.normal(size=3) * rng.uniform(0.0, 2.0)
        s = rng.uniform(0.3, 0.95) * np.linalg.norm(d)
        ds = rng.choice([0.01, 0.3, 1.5]) * rng.uniform(0.0, 1.0)
        predicted = growing_contact_time(*d, *g, s, ds)
        reference = brute_force_growing_contact(d, g, s, ds, horizon=20.0)
        if predicted > 20.0 or reference == math.inf:
            assert predicted > 19.99 and reference == math.inf or reference > 19.99, (d, g, s, ds, predicted, reference)
            continue
        assert predicted == pytest.approx(reference, rel=1e-9, abs=1e-12), (d, g, s, ds)
        checked += 1
        met_by_growth += float(d @ g) >= 0.0
    assert checked > 100 and met_by_growth > 10, (checked, met_by_growth)
    assert growing_contact_time(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.1) == 0.0  # touching and closing: now
    assert growing_contact_time(2.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0) == math.inf  # apart, no growth
    # |g|^2 underflowing, no growth: no event, not a finite wrong time (~1e162; see test_predict)
    assert growing_contact_time(0.0, 3.0, 0.0, 0.0, -7.6e-163, 0.0, 2.0, 0.0) == math.inf


def test_compression_reaches_the_target_without_overlap(dim):
    """Polydisperse, debug checks at every collision: the target is reached exactly, size ratios kept."""
    start = edmd.random_packing(400, 0.1, dim=dim, seed=3, radius={"kind": "uniform", "min": 0.35, "max": 0.65})
    start = edmd.maxwell_boltzmann(start, kT=1.0, seed=4)
    target = 0.5 if dim == 3 else 0.72
    dense = compress(start, target, rate=0.05, kT=1.5, engine={"debug": True})
    assert dense.packing_fraction == pytest.approx(target, rel=1e-12)
    ratio = dense.radius / start.radius
    assert np.ptp(ratio) < 1e-12 * ratio.mean()
    assert dense.temperature() == pytest.approx(1.5, rel=1e-12)
    dense.check_no_overlap()
    assert np.allclose(dense.momentum(), 0.0, atol=1e-9)


def test_a_compression_restarts_bit_for_bit(tmp_path, dim):
    """Checkpoints between the segment ends (where velocities are rescaled) continue exactly."""
    start = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.1, dim=dim, seed=5), kT=1.0, seed=6)
    sim = Simulation(start, growth=Growth(rate=0.02))
    segment = sim.params["growth"]["segment"]  # (0.2 x skin 0.5 / (sigma 1 x rate 0.02) = 5)
    sim.add(Checkpoint(tmp_path / "ck.gsd", interval=0.37 * segment))
    sim.run(until_time=0.37 * segment * 4)
    frozen = (tmp_path / "ck.gsd").read_bytes()
    sim.run(until_time=3.0 * segment)
    (tmp_path / "ck.gsd").write_bytes(frozen)
    again = load_checkpoint(tmp_path / "ck.gsd", [Checkpoint(tmp_path / "ck2.gsd", interval=0.37 * segment)])
    again.run(until_time=3.0 * segment)
    a, b = sim.state, again.state
    for field in ("position", "velocity", "radius"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    assert sim.collisions == again.collisions > 1000
    assert a.packing_fraction == pytest.approx(0.1 * (1.0 + 0.02 * 3.0 * segment) ** dim, rel=1e-12)


def test_compression_from_the_configuration():
    cfg = edmd.parse_config(tomllib.loads('[system]\nn = 300\npacking_fraction = 0.4\ninit = "compress"\ncompress_rate = 0.05\nseed = 2\n'))
    from edmd.app.runner import build_state

    state = build_state(cfg)
    assert state.packing_fraction == pytest.approx(0.4, rel=1e-12) and np.all(state.radius == 0.5)
    assert state.time == 0.0 and state.temperature() == pytest.approx(1.0, rel=1e-12)
    state.check_no_overlap()
    walled = build_state(edmd.parse_config(tomllib.loads('[system]\nn = 200\npacking_fraction = 0.4\ninit = "compress"\ncompress_rate = 0.05\n[walls]\naxes = ["z"]\n')))
    assert walled.packing_fraction == pytest.approx(0.4, rel=1e-12) and list(walled.periodic) == [True, True, False]
    assert np.all(np.abs(walled.position[:, 2]) + walled.radius <= 0.5 * walled.box[2])


def test_bad_input_is_named(dim):
    state = edmd.maxwell_boltzmann(edmd.random_packing(50, 0.1, dim=dim, seed=1), kT=1.0, seed=2)
    with pytest.raises(ValueError, match="rate"):
        Growth(rate=0.0)
    with pytest.raises(StateError, match="must exceed"):
        compress(state, 0.05)
    with pytest.raises(StateError, match="close packing"):
        compress(state, 0.95)
    with pytest.raises(StateError, match="constant e_n"):
        Simulation(state, growth=Growth(0.1), collision=edmd.collide.Rough(0.9, beta=0.0))
    with pytest.raises(StateError, match="neighbours='list'"):
        Simulation(state, growth=Growth(0.1), engine={"neighbours": "cells"})
    with pytest.raises(StateError, match="square well"):
        Simulation(state, growth=Growth(0.1), well=edmd.SquareWell(1.5, 1.0))


def test_an_event_budget_counts_the_events_of_every_segment(dim):
    """Segment ends (velocity rescalings) cut the loop's chunks; the events before each still count."""
    start = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, dim=dim, seed=7), kT=1.0, seed=8)
    sim = Simulation(start, growth=Growth(rate=0.02, segment=0.05))
    sim.run(max_events=5000)
    assert sim.events == 5000 and sim.time > 0.2  # (more than four segment ends on the way)


def test_segments_end_after_their_event_count_near_jamming(dim):
    """Dense (the time-based segment ends are far off): a segment ends every Growth.events x N events,
    where the velocities are rescaled, so the heating between rescalings stays bounded."""
    start = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.1, dim=dim, seed=9), kT=1.0, seed=10)
    dense = compress(start, 0.56 if dim == 3 else 0.78, rate=0.05)
    sim = Simulation(dense, growth=Growth(rate=0.002, events=2.0))
    sim.run(max_events=300 * 2 * 7 + 5)
    assert len(sim.engine.segments) == 7
    assert [c for *_, c in sim.engine.segments] == sorted(c for *_, c in sim.engine.segments)
    assert sim.state.temperature() < 1.05  # rescaled 5 events per particle ago: about 0.4 % warmer at g = 0.002


def test_the_reduced_pressure_of_slow_growth_follows_the_equation_of_state(dim):
    """At a slow rate the compressing fluid stays near equilibrium: each segment's Z = PV/(NkT) is the
    hard-sphere equation of state at its packing fraction (Carnahan-Starling in 3D, Henderson in 2D)
    within 2 % in 3D, 3 % in 2D: the mean over ~40 segments has a standard error of 0.3 %, the 2D
    equation of state is good to ~0.5 % at 0.65, and the fluid lags the growth (measured: 0.1 % in
    3D; in 2D 1.45 % at this rate, standard deviation 0.45 % over 7 starting seeds, 0.979-0.992;
    6 % in 3D at a rate ten times faster)."""
    start = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.1, dim=dim, seed=11), kT=1.0, seed=12)
    lo, hi = (0.3, 0.45) if dim == 3 else (0.4, 0.65)
    run = edmd.compression(start, hi, rate=0.005)
    h = run.history[(run.history["packing_fraction"] > lo)]
    ratio = h["pressure"] / np.array([edmd.analysis.compressibility_factor(eta, dim) for eta in h["packing_fraction"]])
    assert len(h) > 20 and abs(ratio.mean() - 1.0) < (0.02 if dim == 3 else 0.03), (len(h), ratio.mean())
    assert np.all(np.diff(run.history["packing_fraction"]) > 0) and np.all(np.diff(run.history["collisions"]) >= 0)


def test_growth_stops_at_a_pressure_then_the_run_continues_at_fixed_size(dim):
    start = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, dim=dim, seed=13), kT=1.0, seed=14)
    sim = Simulation(start, growth=Growth(rate=0.05, pressure=20.0))
    sim.run(until_grown=True)
    z = [z for _, _, z, _ in sim.engine.segments]
    assert z[-1] >= 20.0 and max(z[:-1]) < 20.0 and not sim.engine.growing
    assert "grow" not in sim.engine.loop.name
    jammed = sim.state
    assert sim.time == sim.engine.segments[-1][0]
    sim.run(until_time=sim.time + 1.0)
    after = sim.state
    assert np.array_equal(after.radius, jammed.radius)
    assert after.kinetic_energy() == pytest.approx(jammed.kinetic_energy(), rel=1e-12)  # elastic, fixed radii: conserved
    with pytest.raises(ValueError, match="until_grown"):
        sim.run(until_grown=True)


def test_growth_stops_exactly_at_a_packing_fraction(dim):
    start = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, dim=dim, seed=15), kT=1.0, seed=16)
    sim = Simulation(start, growth=Growth(rate=0.05, packing_fraction=0.3))
    sim.run(until_time=100.0)
    assert sim.state.packing_fraction == pytest.approx(0.3, rel=1e-13)
    assert sim.params["growth"]["end"] == pytest.approx(compression_time(start, 0.3, 0.05), rel=1e-13)
    with pytest.raises(ValueError, match="must exceed"):
        Simulation(start, growth=Growth(rate=0.05, packing_fraction=0.05))


def test_restarts_are_bit_for_bit_across_count_ends_and_the_stop(tmp_path, dim):
    """Checkpoints between segment ends by count, and one before the growth stops at a pressure."""
    start = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, dim=dim, seed=17), kT=1.0, seed=18)
    growth = Growth(rate=0.05, events=0.5, pressure=15.0)
    sim = Simulation(start, growth=growth)
    sim.add(Checkpoint(tmp_path / "ck.gsd", interval=0.7))
    sim.run(until_time=4.2)
    frozen = (tmp_path / "ck.gsd").read_bytes()
    sim.run(until_time=40.0)
    assert not sim.engine.growing and sim.engine.segments[-1][0] > 4.2
    (tmp_path / "ck.gsd").write_bytes(frozen)
    again = load_checkpoint(tmp_path / "ck.gsd", [Checkpoint(tmp_path / "ck2.gsd", interval=0.7)])
    again.run(until_time=40.0)
    a, b = sim.state, again.state
    for field in ("position", "velocity", "radius"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    assert sim.collisions == again.collisions and sim.engine.segments[-1] == again.engine.segments[-1]


def test_compression_slows_down_in_stages(dim):
    start = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, dim=dim, seed=19), kT=1.0, seed=20)
    run = edmd.compression(start, pressure=200.0, rate=0.05, slowdown=((50.0, 0.5),))
    assert run.reached == "pressure" and run.pressure >= 200.0
    assert np.all(np.diff(run.history["collisions"]) > 0)  # counted on across the stages
    first = np.flatnonzero(run.history["pressure"] >= 50.0)[0]
    assert run.history["time"][first + 1] > run.history["time"][first]
    with pytest.raises(StateError, match="slowdown"):
        edmd.compression(start, pressure=200.0, slowdown=((50.0, 0.5), (20.0, 0.1)))
    with pytest.raises(StateError, match="above 1"):
        edmd.compression(start, pressure=0.5)
    with pytest.raises(StateError, match="target"):
        edmd.compression(start)


def test_jamming_gives_an_isostatic_packing(dim):
    """Compressed to Z = 1e12 (debug checks at every collision in 2D): no overlap, the non-rattlers
    isostatic, z = 2d within 1 % (finite N: 2d(1 - 1/N') + 2/N'), rattlers a few per cent; the
    packing fraction in the random-jamming range (monodisperse spheres about 0.64, 50:50 disks of size
    ratio 1.4 about 0.84; tests/validation/test_jamming.py checks larger systems against the literature)."""
    radius = 0.5 if dim == 3 else {"kind": "discrete", "values": [0.5, 0.7], "fractions": [0.5, 0.5]}
    start = edmd.maxwell_boltzmann(edmd.random_packing(250, 0.1, dim=dim, seed=1, radius=radius), kT=1.0, seed=2)
    jammed = edmd.compression(start, pressure=edmd.run.compress.JAMMED, rate=0.02, engine={"debug": dim == 2})
    net = jammed.contacts()
    assert jammed.reached == "pressure" and jammed.pressure >= 1e12
    assert jammed.state.overlapping_pair(1e-13) is None
    assert abs(net.mean_contact_number / (2 * dim) - 1.0) < 0.01, net.mean_contact_number
    assert net.rattler_fraction < 0.1
    assert (0.62 < jammed.packing_fraction < 0.66) if dim == 3 else (0.83 < jammed.packing_fraction < 0.85)


def test_a_film_compressed_between_walls_reaches_its_separation_without_overlap(dim):
    """The upper wall moves in at constant speed (debug checks at every collision); the other axes stay
    fixed; the bath holds the temperature; every particle ends inside the new box."""
    periodic = [True] * (dim - 1) + [False]
    start = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.2, dim=dim, seed=21, periodic=periodic), kT=1.0, seed=22)
    axis = "xyz"[dim - 1]
    target = 0.5 if dim == 3 else 0.6
    separation = start.box[-1] * 0.2 / target
    film = edmd.compress_film(start, separation, axis=axis, speed=0.05, kT=1.0, engine={"debug": True})
    assert film.packing_fraction == pytest.approx(target, rel=1e-12)
    assert np.array_equal(film.box[:-1], start.box[:-1]) and film.box[-1] == separation
    film.check_no_overlap()
    z, r = film.position[:, -1], film.radius
    assert np.all(np.abs(z) + r <= 0.5 * separation * (1 + 1e-12))
    assert film.temperature() == pytest.approx(1.0, rel=0.15)  # 300 particles: 1/sqrt(N d / 2) ~ 7 % spread, bath-held
    with pytest.raises(StateError, match="closed by walls"):
        edmd.compress_film(start, separation, axis="x")
    with pytest.raises(StateError, match="between the largest diameter"):
        edmd.compress_film(start, 0.5, axis=axis)


def test_a_target_beyond_jamming_is_refused_once_jammed():
    """Monodisperse spheres cannot reach 0.72 without crystallising: the compression stops at jamming
    (it would otherwise grow forever at a vanishing rate) and says so."""
    start = edmd.maxwell_boltzmann(edmd.random_packing(60, 0.1, seed=1), kT=1.0, seed=2)
    with pytest.raises(StateError, match="jammed .* before the target 0.72"):
        edmd.compression(start, 0.72, rate=0.2)
    with pytest.raises(StateError, match="at most 1e\\+13"):
        edmd.compression(start, pressure=1e15)


def test_growth_cannot_start_in_the_future():
    start = edmd.maxwell_boltzmann(edmd.random_packing(50, 0.1, seed=1), kT=1.0, seed=2)
    with pytest.raises(ValueError, match="after the state's time"):
        Simulation(start, growth=Growth(rate=0.05, start=1.1))


def test_the_final_pressure_merges_a_segment_cut_short():
    """A packing-fraction target cuts the last segment: with fewer than half the collisions of the one
    before, the two are averaged by collisions."""
    state = edmd.lattice(8, 0.1)
    rows = [(1.0, 0.2, 1.0, 100), (2.0, 0.3, 2.0, 200), (2.1, 0.31, 5.0, 210)]
    cut = edmd.Compression(state, np.array(rows, dtype=edmd.run.compress.HISTORY), "packing_fraction")
    assert cut.pressure == pytest.approx((2.0 * 100 + 5.0 * 10) / 110, rel=1e-15)
    full = edmd.Compression(state, np.array(rows[:2], dtype=edmd.run.compress.HISTORY), "packing_fraction")
    assert full.pressure == 2.0
    assert math.isnan(edmd.Compression(state, np.array([], dtype=edmd.run.compress.HISTORY), "pressure").pressure)


def test_a_growing_sphere_meets_a_wall_as_if_the_wall_moved_in(dim):
    """At rest, radius 0.5, its surface 0.5 from the lower wall, growing at g = 0.1: contact when
    0.5 (1 + 0.1 t) = 1, t = 10; elastic, it leaves at twice the surface's speed, 2 R(0) g = 0.1, and
    the wall takes that momentum."""
    box = np.full(dim, 12.0)
    pos = np.zeros((1, dim))
    pos[0, -1] = -6.0 + 1.0
    ball = edmd.State(position=pos, velocity=np.zeros((1, dim)), radius=np.array([0.5]), mass=np.array([1.0]), box=box,
                      periodic=np.array([True] * (dim - 1) + [False]))  # fmt: skip
    sim = Simulation(ball, growth=Growth(rate=0.1, segment=15.0, events=1e6))  # (no rescaling before t = 15)
    sim.run(until_time=9.999)
    assert sim.totals().wall_collisions == 0
    sim.run(until_time=10.5)
    after = sim.state
    assert sim.totals().wall_collisions == 1
    assert after.velocity[0, -1] == pytest.approx(0.1, rel=1e-12)
    assert after.position[0, -1] == pytest.approx(-5.0 + 0.1 * 0.5, rel=1e-12)
    assert sim.totals().wall_impulse[-1, 0] == pytest.approx(0.1, rel=1e-12)  # (normal momentum given to the lower wall)
    assert sim.totals().energy_input == pytest.approx(0.5 * 0.1**2, rel=1e-12)  # the growth's work


def test_compression_between_walls_without_overlap(dim):
    """Polydisperse, walls on the last axis (debug checks at every collision): the target is reached
    exactly, every particle stays inside the walls, the wall pressure is recorded."""
    periodic = [True] * (dim - 1) + [False]
    start = edmd.random_packing(300, 0.1, dim=dim, seed=23, periodic=periodic, radius={"kind": "uniform", "min": 0.4, "max": 0.6})
    start = edmd.maxwell_boltzmann(start, kT=1.0, seed=24)
    target = 0.5 if dim == 3 else 0.7
    dense = compress(start, target, rate=0.05, engine={"debug": True})
    assert dense.packing_fraction == pytest.approx(target, rel=1e-12)
    dense.check_no_overlap()
    assert np.all(np.abs(dense.position[:, -1]) + dense.radius <= 0.5 * dense.box[-1] * (1 + 1e-12))
