"""Run control: exact observer times, split runs, budgets."""

import numpy as np
import pytest

import edmd
from edmd import Callback, Simulation


def _sim(dim, **kw):
    s = edmd.maxwell_boltzmann(edmd.lattice(256, 0.3, dim=dim), 1.0, seed=1)
    return Simulation(s, **kw)


def test_split_run_is_bit_for_bit_the_whole_run(dim):
    a = _sim(dim, engine={"resync_every": 3.0})
    a.run(until_time=4.0)
    b = _sim(dim, engine={"resync_every": 3.0})
    for t in (0.5, 1.25, 2.0, 3.7):
        b.run(until_time=t)
    b.run(max_events=100)
    assert b.time < 4.0
    b.run(until_time=4.0)
    sa, sb = a.state, b.state
    assert a.collisions == b.collisions
    assert np.array_equal(sa.position, sb.position)
    assert np.array_equal(sa.velocity, sb.velocity)


def test_observers_fire_at_exact_times_with_streamed_particles(dim):
    sim = _sim(dim)
    seen = []
    sim.add(Callback(lambda s, tot: seen.append((s.time, s.copy())), interval=0.25))
    sim.run(until_time=1.0)
    assert [t for t, _ in seen] == [0.0, 0.25, 0.5, 0.75, 1.0]
    # a snapshot is the true state at that instant: no overlaps, energy exact
    for t, s in seen:
        assert s.overlapping_pair(1e-9) is None
        assert s.kinetic_energy() == pytest.approx(seen[0][1].kinetic_energy(), rel=1e-12)


def test_observing_does_not_disturb_the_trajectory(dim):
    a = _sim(dim)
    a.add(Callback(lambda s, t: None, interval=0.01))
    a.run(until_time=2.0)
    b = _sim(dim)
    b.run(until_time=2.0)
    assert np.array_equal(a.state.velocity, b.state.velocity)


def test_max_events_and_time(dim):
    sim = _sim(dim)
    sim.run(max_events=5000)
    assert sim.events == 5000
    assert sim.time > 0
    with pytest.raises(ValueError, match="until_time must be"):
        sim.run(until_time=sim.time / 2)
    with pytest.raises(ValueError, match="needs until_time"):
        sim.run()


def test_wall_time_budget_stops_the_run(dim):
    sim = _sim(dim)
    sim.run(until_time=1e9, wall_time=0.2)
    assert sim.time < 1e9 and sim.events > 0


def test_state_assignment_restarts_from_it(dim):
    sim = _sim(dim)
    sim.run(until_time=0.5)
    s = sim.state
    s.velocity *= 2.0
    sim.state = s
    assert sim.state.temperature() == pytest.approx(4.0, rel=1e-12)
    sim.run(until_time=1.0)
    assert sim.time == 1.0


def test_bad_parameters(dim):
    with pytest.raises(ValueError, match="e_n must be a number in"):
        _sim(dim, e_n=1.5)
    with pytest.raises(ValueError, match="neighbours must be"):
        _sim(dim, engine={"neighbours": "octree"})
    with pytest.raises(ValueError, match="engine option 'neighbors' does not exist \\(did you mean 'neighbours'\\?\\)"):
        _sim(dim, engine={"neighbors": "list"})
    with pytest.raises(ValueError, match="observer interval"):
        Callback(lambda s, t: None, interval=0.0)


def _bad_run_arguments(sim):
    for kw, msg in [({"max_events": -5}, "max_events must be a whole number"), ({"max_events": 2.7}, "max_events must be a whole number"),
                    ({"wall_time": -1.0}, "wall_time must be"), ({"wall_time": float("nan")}, "wall_time must be")]:
        with pytest.raises(ValueError, match=msg):
            sim.run(**kw)


def test_bad_run_arguments_and_observers(dim, tmp_path):
    sim = _sim(dim)
    _bad_run_arguments(sim)
    with pytest.raises(TypeError, match="add\\(\\) takes an edmd Observer"):
        sim.add(5)
    with pytest.raises(TypeError, match="Simulation needs an edmd.State"):
        Simulation(np.zeros((4, 3)))
    with pytest.warns(UserWarning, match="walls= has no effect: the state's box is periodic on every axis"):
        _sim(dim, walls=edmd.collide.Wall(e_n=0.5))
    with pytest.raises(ValueError, match="observer start must be a finite time"):
        edmd.Thermo(1.0, start=float("nan"))
    with pytest.raises(ValueError, match="debug_tolerance must be a number >= 0"):
        edmd.EngineOptions(debug_tolerance=-1.0)
    with pytest.raises(ValueError, match="seed must be a non-negative integer, got -1"):
        edmd.maxwell_boltzmann(sim.state, 1.0, seed=-1)
    sim.add(edmd.Trajectory(tmp_path / "same.gsd", 0.5))
    with pytest.raises(ValueError, match="same.gsd, which the attached Trajectory writes"):
        sim.add(edmd.Checkpoint(tmp_path / "same.gsd", 0.5))


#: a field of a valid State replaced afterwards, and what the Simulation must say about it
MUTATIONS = {
    "NaN velocity": (lambda s: setattr(s, "velocity", np.where(np.arange(s.n)[:, None] == 3, np.nan, s.velocity)), "velocity is not finite .* particle 3"),
    "negative mass": (lambda s: setattr(s, "mass", -np.ones(s.n)), "mass must be positive: particle 0"),
    "negative radius": (lambda s: setattr(s, "radius", np.full(s.n, -0.5)), "radius must be positive"),
    "overlap": (lambda s: setattr(s, "position", np.vstack([s.position[:1], s.position[:1] + 0.01, s.position[2:]])), "particles 0 and 1 overlap"),
    "outside the box": (lambda s: setattr(s, "position", np.vstack([s.position[:1] + 1000.0, s.position[1:]])), "particle 0 .* lies outside the box"),
    "wrong shape": (lambda s: setattr(s, "velocity", s.velocity[:5]), "velocity must have shape"),
}


@pytest.mark.parametrize("how", ["constructor", "assignment"])
@pytest.mark.parametrize("mutation", list(MUTATIONS))
def test_a_state_changed_after_it_was_made_is_checked(dim, mutation, how):
    """A NaN velocity ran with T = nan, a negative mass hung the loop, overlaps ran unnoticed."""
    change, message = MUTATIONS[mutation]
    state = edmd.maxwell_boltzmann(edmd.lattice(64, 0.2, dim=dim), 1.0, seed=1)
    sim = Simulation(state) if how == "assignment" else None
    change(state)
    with pytest.raises(edmd.StateError, match=message):
        if sim is None:
            Simulation(state)
        else:
            sim.state = state


def _progress_lines(out: str) -> list[tuple[float, int]]:
    """(percent, events) of each plain progress line (stdout is not a terminal under pytest)."""
    lines = [line.split() for line in out.splitlines() if line.startswith("edmd:")]
    return [(float(w[1].rstrip("%")), int(w[w.index("events") + 2])) for w in lines]


def test_batch_progress_of_an_event_budget_counts_from_the_start_of_the_call(capsys):
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0, seed=2))
    sim.run(until_time=0.5)
    start = sim.events
    sim.run(max_events=400_000, progress=True)
    lines = _progress_lines(capsys.readouterr().out)
    assert len(lines) >= 4 and lines[-1] == (100.0, start + 400_000)
    for percent, events in lines:
        assert percent == pytest.approx(100 * (events - start) / 400_000, abs=0.05)


def test_batch_progress_of_a_wall_time_budget_is_the_wall_clock(capsys):
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0, seed=2))
    sim.run(wall_time=1.5, progress=True)
    percents = [p for p, _ in _progress_lines(capsys.readouterr().out)]
    assert percents[-1] == 100.0 and len(percents) >= 3
    assert all(p < 100.0 for p in percents[:-1]) and percents == sorted(percents)


def test_outputs_that_read_their_state_once_take_no_copy_of_it(tmp_path):
    """Thermo rows and trajectory frames are made from a view of the engine (each array made as
    it is read): less than one State copy beyond the run (153 B per particle before, when they
    shared a copy), while a callback, which may keep its state, gets a copy of its own."""
    import tracemalloc

    from edmd.state import StateView

    n = 8000
    sim = Simulation(edmd.maxwell_boltzmann(edmd.lattice(n, 0.5), 1.0, seed=2), engine={"neighbours": "cells"})
    sim.add(edmd.Thermo(0.05, path=tmp_path / "t.csv"))
    sim.add(edmd.Trajectory(tmp_path / "t.gsd", 0.05))
    sim.run(until_time=0.11)  # (three frames: the later ones compared with the first)
    tracemalloc.start()
    try:
        sim.run(until_time=0.16)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= 96 * n, f"an output took {peak / n:.0f} B per particle"
    kept = []
    sim.add(Callback(lambda s, tot: kept.append(s), 0.05))
    sim.run(until_time=0.26)
    assert kept and all(type(s) is edmd.State and not isinstance(s, StateView) for s in kept)
    assert kept[0].time == 0.16 and np.isfinite(kept[0].position).all()  # (readable after the run went on)
