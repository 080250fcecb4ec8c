"""GSD files: exact round trip of every field, frame contents, readers."""

import tracemalloc

import gsd.fl
import gsd.hoomd
import numpy as np
import pytest

import edmd
from edmd import StateError, Trajectory, read_state, write_state
from edmd.files.trajectory import frame_count, iter_states, truncate_frames


def _state(dim):
    s = edmd.random_packing(50, 0.1, dim=dim, radius={"kind": "uniform", "min": 0.3, "max": 0.6}, density=1.5, seed=1)
    s = edmd.maxwell_boltzmann(s, 0.7, seed=2, spin=True)
    s.image = np.arange(50 * dim).reshape(50, dim) % 5 - 2
    s.time = 12.345678901234567
    return s


def test_state_gsd_state_is_exact(tmp_path, dim):
    s = _state(dim)
    write_state(tmp_path / "s.gsd", s)
    r = read_state(tmp_path / "s.gsd")
    for field in ("position", "velocity", "radius", "mass", "box", "angular_velocity", "inertia", "image", "periodic"):
        assert np.array_equal(getattr(r, field), getattr(s, field)), field
    assert r.time == s.time


def test_trajectory_frames(tmp_path, dim):
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(64, 0.2, dim=dim), 1.0))
    sim.add(Trajectory(tmp_path / "t.gsd", interval=0.5))
    sim.run(until_time=1.0)
    sim.close()
    with gsd.hoomd.open(tmp_path / "t.gsd") as f:
        assert len(f) == 3
        fr = f[2]
        assert fr.particles.position.dtype == np.float64
        assert fr.configuration.dimensions == dim
        assert fr.log["time"][0] == 1.0
        assert fr.log["collisions"][0] == sim.collisions
        assert np.allclose(fr.particles.diameter, 1.0)
    assert np.array_equal(read_state(tmp_path / "t.gsd").velocity, sim.state.velocity)


def test_corrupt_file_is_a_clear_error(tmp_path):
    p = tmp_path / "bad.gsd"
    p.write_bytes(b"not a gsd file at all" * 10)
    with pytest.raises(StateError, match="cannot read a state from"):
        read_state(p)
    with pytest.raises(StateError, match="cannot read a state from"):
        read_state(tmp_path / "missing.gsd")


def test_a_tilted_box_of_another_program_is_refused(tmp_path):
    frame = gsd.hoomd.Frame()
    frame.particles.N = 2
    frame.particles.position = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    frame.configuration.box = [10.0, 10.0, 10.0, 0.5, 0.0, 0.0]
    with gsd.hoomd.open(tmp_path / "tilted.gsd", "w") as f:
        f.append(frame)
    with pytest.raises(StateError, match=r"box is tilted \(tilt factors xy, xz, yz = \[0\.5, 0\.0, 0\.0\]\)"):
        read_state(tmp_path / "tilted.gsd")


# ---------------------------------------------------------------------------- HOOMD fields, readers
def test_angmom_and_orientation_follow_hoomd(tmp_path, dim):
    s = _state(dim)
    write_state(tmp_path / "s.gsd", s)
    with gsd.hoomd.open(tmp_path / "s.gsd") as f:
        fr = f[0]
    assert np.array_equal(fr.particles.orientation, np.tile([1.0, 0.0, 0.0, 0.0], (s.n, 1)))
    p = fr.particles.angmom
    assert p.dtype == np.float64 and np.all(p[:, 0] == 0)
    # identity orientation: P = 2 q x (0, S) = (0, 2 I omega); S = I omega in the body frame
    spin = s.angular_velocity if dim == 3 else np.column_stack([np.zeros((s.n, 2)), s.angular_velocity])
    assert np.allclose(p[:, 1:], 2 * s.inertia[:, None] * spin, rtol=1e-15, atol=0)
    # a frame without edmd's log (another program's file) gets its spins from angmom
    del fr.log["particles/angular_velocity"]
    assert np.allclose(edmd.files.trajectory.frame_to_state(fr).angular_velocity, s.angular_velocity, rtol=1e-14)


def test_freud_reads_a_frame(tmp_path, dim):
    freud = pytest.importorskip("freud")
    s = _state(dim)
    write_state(tmp_path / "s.gsd", s)
    with gsd.hoomd.open(tmp_path / "s.gsd") as f:
        fr = f[0]
    box = freud.box.Box.from_box(fr.configuration.box, dimensions=fr.configuration.dimensions)
    assert box.is2D == (dim == 2)
    assert np.allclose(box.L[:dim], s.box, rtol=1e-6)
    images = box.get_images(box.wrap(fr.particles.position))
    assert np.array_equal(images, np.zeros_like(images))  # every point lies inside freud's box
    nq = freud.locality.AABBQuery(box, fr.particles.position)
    pairs = nq.query(fr.particles.position, {"r_max": 0.999 * 2 * s.radius.min(), "exclude_ii": True}).toNeighborList()
    assert len(pairs) == 0  # no overlaps seen through freud either


def _trajectory(path, until, interval=0.5, n=108):
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(n, 0.2), 1.0, seed=4))
    sim.add(Trajectory(path, interval=interval, start=0.25))
    sim.run(until_time=until)
    sim.close()
    return sim


def test_step_is_the_event_count(tmp_path):
    sim = _trajectory(tmp_path / "t.gsd", 1.25)
    with gsd.hoomd.open(tmp_path / "t.gsd") as f:
        steps = [int(fr.configuration.step) for fr in f]
        assert steps == [int(fr.log["events"][0]) for fr in f]
    assert steps[-1] == sim.events and np.all(np.diff(steps) > 0)


def test_mdanalysis_reads_a_trajectory(tmp_path):
    mda = pytest.importorskip("MDAnalysis")
    _trajectory(tmp_path / "t.gsd", 1.25)
    # the documented mapping: frame k is at time_offset + k * dt (MDAnalysis ignores the step)
    u = mda.Universe(str(tmp_path / "t.gsd"), dt=0.5, time_offset=0.25)
    assert len(u.trajectory) == 3 and len(u.atoms) == 108
    states = list(iter_states(tmp_path / "t.gsd"))
    with gsd.hoomd.open(tmp_path / "t.gsd") as f:
        events = [int(fr.log["events"][0]) for fr in f]
    for ts, s, e in zip(u.trajectory, states, events):
        assert ts.time == pytest.approx(s.time, rel=1e-15) and ts.data["step"] == e
    assert [s.time for s in states] == [0.25, 0.75, 1.25]
    u.trajectory[-1]
    assert np.allclose(u.atoms.positions, states[-1].points, atol=1e-5)
    assert np.allclose(u.dimensions[:3], states[-1].box, rtol=1e-6)


def test_box_is_stored_once_in_single_precision_and_exactly_under_log(tmp_path):
    s = edmd.lattice(32, 0.2)
    assert not np.array_equal(s.box.astype(np.float32), s.box)  # this box needs double precision
    sim = edmd.Simulation(edmd.maxwell_boltzmann(s, 1.0))
    sim.add(Trajectory(tmp_path / "t.gsd", interval=0.5))
    sim.run(until_time=1.0)
    sim.close()
    with gsd.fl.open(str(tmp_path / "t.gsd"), "r") as f:
        assert [f.chunk_exists(k, "configuration/box") for k in range(f.nframes)] == [True, False, False]
        assert np.array_equal(f.read_chunk(0, "configuration/box")[:3], s.box.astype(np.float32))
        assert [f.chunk_exists(k, "log/configuration/box") for k in range(f.nframes)] == [True, False, False]
        assert np.array_equal(f.read_chunk(0, "log/configuration/box"), s.box)
    with gsd.hoomd.open(tmp_path / "t.gsd") as f:  # (later frames read it from frame 0)
        assert all(np.array_equal(frame.log["configuration/box"], s.box) for frame in f)
    assert np.array_equal(read_state(tmp_path / "t.gsd").box, s.box)


def test_truncated_trajectory_is_byte_for_byte_the_shorter_one(tmp_path):
    # enough frames that GSD grows its index: the frames are replayed as the writer wrote them
    _trajectory(tmp_path / "long.gsd", 4.0, interval=0.05, n=27)
    _trajectory(tmp_path / "short.gsd", 3.0, interval=0.05, n=27)
    frames = frame_count(tmp_path / "short.gsd")
    assert frame_count(tmp_path / "long.gsd") > frames > 50
    truncate_frames(tmp_path / "long.gsd", frames)
    assert (tmp_path / "long.gsd").read_bytes() == (tmp_path / "short.gsd").read_bytes()


def test_a_partial_frame_left_by_a_kill_is_cut_off(tmp_path):
    # kill -9 while a frame is written: its data lie after the last complete frame, outside the index
    _trajectory(tmp_path / "killed.gsd", 1.0, interval=0.25, n=27)
    _trajectory(tmp_path / "clean.gsd", 1.0, interval=0.25, n=27)
    with open(tmp_path / "killed.gsd", "ab") as f:
        f.write(np.random.default_rng(0).bytes(3000))
    assert frame_count(tmp_path / "killed.gsd") == 4  # frames at 0.25, 0.5, 0.75, 1.0
    size = (tmp_path / "clean.gsd").stat().st_size
    truncate_frames(tmp_path / "killed.gsd", 4, size)  # (the checkpoint's size: the partial frame is still cut off)
    assert (tmp_path / "killed.gsd").read_bytes() == (tmp_path / "clean.gsd").read_bytes()


def test_a_trajectory_as_it_was_at_the_checkpoint_is_not_rewritten(tmp_path):
    """A restart from the final checkpoint of a finished run (extending it) finds the file with the
    frames and size it had at the checkpoint: kept as it is, not copied frame by frame."""
    _trajectory(tmp_path / "t.gsd", 1.0, interval=0.25, n=27)
    before = (tmp_path / "t.gsd").stat()
    truncate_frames(tmp_path / "t.gsd", 4, before.st_size)
    after = (tmp_path / "t.gsd").stat()
    assert (after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns)
    truncate_frames(tmp_path / "t.gsd", 4)  # (no size, an older checkpoint's: copied, the same bytes)
    assert (tmp_path / "t.gsd").stat().st_ino != before.st_ino and (tmp_path / "t.gsd").stat().st_size == before.st_size


def test_frames_selection_and_truncation(tmp_path):
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(32, 0.2), 1.0))
    sim.add(Trajectory(tmp_path / "t.gsd", interval=0.25))
    sim.run(until_time=1.0)
    sim.close()
    p = tmp_path / "t.gsd"
    assert frame_count(p) == 5 and frame_count(tmp_path / "none.gsd") == 0
    assert [s.time for s in iter_states(p, 1, None, 2)] == [0.25, 0.75]
    with pytest.raises(StateError, match="there is no frame 7"):
        read_state(p, 7)
    before = [s.velocity for s in iter_states(p)]
    truncate_frames(p, 3)
    assert frame_count(p) == 3
    assert all(np.array_equal(a.velocity, b) for a, b in zip(iter_states(p), before))
    with pytest.raises(StateError, match="fewer than the 4"):
        truncate_frames(p, 4)


def test_frames_appended_with_a_run_id_to_a_file_without_one_stay_readable(tmp_path):
    # a run directory of an older edmd continued by this one: GSD reads a log entry a frame lacks
    # from frame 0, and failed (KeyError) for the old frames when only the new ones had a run id
    p = tmp_path / "t.gsd"
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(32, 0.2), 1.0, seed=3))
    old = sim.add(Trajectory(p, interval=0.5))
    sim.run(until_time=1.0)
    sim.close()
    sim.observers.remove(old)
    sim.add(Trajectory(p, interval=0.5, start=1.5, mode="a", run_id="abc"))
    sim.run(until_time=2.0)
    sim.close()
    assert [s.time for s in iter_states(p)] == [0.0, 0.5, 1.0, 1.5, 2.0]
    with gsd.hoomd.open(p) as f:
        assert all("edmd/run_id" not in frame.log for frame in f)


@pytest.mark.parametrize("dim", [2, 3])
def test_writing_frames_is_silent(tmp_path, caplog, dim):
    """Every array handed to GSD is contiguous (a smooth run's spins are a broadcast constant): GSD
    would log "implicit data copy" for each frame otherwise (the CLI shows such warnings)."""
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(27, 0.1, dim=dim), 1.0, seed=1))
    sim.add(Trajectory(tmp_path / "t.gsd", 0.5))
    with caplog.at_level("WARNING"):
        sim.run(until_time=1.0)
    assert not [r for r in caplog.records if "copy" in r.getMessage()]


# ---------------------------------------------------------------------------- reading chunk by chunk
def _hoomd_file(path, dim):
    """Two frames as another program writes them (single precision, no edmd log); frame 1 has no
    velocities (read from frame 0) and frame 2 other particles and no masses (the defaults)."""
    rng = np.random.default_rng(3)
    frames = []
    for n in (4, 4, 3):
        f = gsd.hoomd.Frame()
        f.configuration.box = [20.0, 20.0, 20.0 if dim == 3 else 0.0, 0.0, 0.0, 0.0]
        f.configuration.dimensions = dim
        f.particles.N = n
        pos = np.zeros((n, 3), np.float32)
        pos[:, :dim] = 3.0 * np.arange(n)[:, None] - 4.0
        f.particles.position = pos
        frames.append(f)
    frames[0].particles.velocity = np.pad(rng.normal(size=(4, dim)), ((0, 0), (0, 3 - dim))).astype(np.float32)
    frames[0].particles.mass = np.array([1.0, 2.0, 3.0, 4.0], np.float32)
    frames[0].particles.diameter = np.array([1.0, 1.5, 0.5, 1.0], np.float32)
    with gsd.hoomd.open(path, "w") as out:
        for f in frames:
            out.append(f)


def test_a_file_of_another_program_reads_as_gsd_hoomd_reads_its_frames(tmp_path, dim):
    _hoomd_file(tmp_path / "h.gsd", dim)
    with gsd.hoomd.open(tmp_path / "h.gsd") as f:
        expected = [edmd.files.trajectory.frame_to_state(fr) for fr in f]
    got = list(iter_states(tmp_path / "h.gsd"))
    assert [s.n for s in got] == [4, 4, 3]
    assert np.array_equal(got[1].velocity, got[0].velocity) and np.any(got[1].velocity)  # (frame 0's)
    assert np.array_equal(got[2].mass, np.ones(3)) and np.array_equal(got[2].radius, np.full(3, 0.5))  # (defaults: frame 0 has 4)
    for a, b in zip(got, expected):
        for field in ("position", "velocity", "radius", "mass", "box", "angular_velocity", "inertia", "image", "periodic", "last_collision"):
            assert np.array_equal(getattr(a, field), getattr(b, field)), field


def _traced_peak(fn):
    """Peak bytes numpy and Python allocate while ``fn`` runs (``tracemalloc``) and its result."""
    tracemalloc.start()
    try:
        out = fn()
        return tracemalloc.get_traced_memory()[1], out
    finally:
        tracemalloc.stop()


def test_reading_a_state_holds_no_frame_beside_it(tmp_path):
    """A frame is read a chunk at a time (gsd.hoomd built every chunk of the schema at once,
    defaults filled, and deep-copied frame 0: 586 B per particle for a State of 96). What is
    left: the chunks read and the State's checked copies of them (2 x 96), and the overlap check."""
    s = edmd.maxwell_boltzmann(edmd.lattice(8000, 0.3), 1.0, seed=1)
    s.image = np.ones((s.n, 3), np.int64)
    write_state(tmp_path / "s.gsd", s)
    own = sum(getattr(s, f).nbytes for f in ("position", "velocity", "radius", "mass", "inertia", "image"))
    peak, r = _traced_peak(lambda: read_state(tmp_path / "s.gsd"))
    assert np.array_equal(r.image, s.image) and r.last_collision.strides == (0,)  # (defaults stay constants)
    assert peak <= 3 * own, f"reading took {peak / s.n:.0f} B per particle for a State of {own / s.n:.0f}"


def test_one_radius_and_mass_read_back_as_one_and_a_short_chunk_is_still_refused(tmp_path, dim):
    """A file of particles of one radius and mass reads back with them kept as one number (a
    restart's State then holds no array of them); a radius chunk of another length than N is
    still named, never taken for one radius."""
    s = edmd.maxwell_boltzmann(edmd.lattice(64, 0.2, dim=dim), 1.0, seed=1)
    write_state(tmp_path / "s.gsd", s)
    back = read_state(tmp_path / "s.gsd")
    for name in ("radius", "mass", "inertia"):
        assert not any(getattr(back, name).strides) and getattr(back, name).tobytes() == getattr(s, name).tobytes(), name
    chunks = {
        "configuration/box": np.array([10.0, 10.0, 10.0, 0.0, 0.0, 0.0], np.float32),
        "particles/N": np.array([2], np.uint32),
        "particles/position": np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], np.float32),
        "particles/diameter": np.ones(3, np.float32),  # (three diameters for two particles)
    }
    with gsd.fl.open(tmp_path / "short.gsd", "w", application="test", schema="hoomd", schema_version=[1, 4]) as f:
        for name, value in chunks.items():
            f.write_chunk(name, value)
        f.end_frame()
    with pytest.raises(StateError, match=r"radius must be one number or 2 numbers"):
        read_state(tmp_path / "short.gsd")
