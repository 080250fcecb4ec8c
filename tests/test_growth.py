"""Growing particles (docs/physics.md §1.7): pair times with growing radii, compression, restarts."""

import math
import tomllib

import numpy as np
import pytest

import edmd
from edmd import Growth, Simulation, compress
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
    with pytest.raises(edmd.ConfigError, match="periodic box"):
        edmd.parse_config(tomllib.loads('[system]\ninit = "compress"\n[walls]\naxes = ["z"]\n'))


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
    walled = edmd.maxwell_boltzmann(edmd.random_packing(50, 0.1, dim=dim, seed=1, periodic=[False] + [True] * (dim - 1)), kT=1.0, seed=2)
    with pytest.raises(StateError, match="periodic box"):
        Simulation(walled, growth=Growth(0.1))
    with pytest.raises(StateError, match="square well"):
        Simulation(state, growth=Growth(0.1), well=edmd.SquareWell(1.5, 1.0))


def test_an_event_budget_counts_the_events_of_every_segment(dim):
    """Segment ends (velocity rescalings) cut the loop's chunks; the events before each still count."""
    start = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, dim=dim, seed=7), kT=1.0, seed=8)
    sim = Simulation(start, growth=Growth(rate=0.02, segment=0.05))
    sim.run(max_events=5000)
    assert sim.events == 5000 and sim.time > 0.2  # (more than four segment ends on the way)
