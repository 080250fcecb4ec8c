"""GSD files: exact round trip of every field, frame contents, readers."""

import gsd.hoomd
import numpy as np
import pytest

import edmd
from edmd import StateError, Trajectory, read_state, write_state
from edmd.export import csv_columns, export_frame, write_csv, write_xyz
from edmd.trajectory import frame_count, iter_states, truncate_frames


def _state(dim):
    s = edmd.random_packing(50, 0.1, dim=dim, radius={"kind": "uniform", "min": 0.3, "max": 0.6}, density=1.5, seed=1)
    s = edmd.maxwell_boltzmann(s, 0.7, seed=2, spin=True)
    s.image[:] = np.arange(50 * dim).reshape(50, dim) % 5 - 2
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
    assert np.allclose(edmd.trajectory.frame_to_state(fr).angular_velocity, s.angular_velocity, rtol=1e-14)


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


def test_mdanalysis_reads_a_trajectory(tmp_path):
    mda = pytest.importorskip("MDAnalysis")
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), 1.0))
    sim.add(Trajectory(tmp_path / "t.gsd", interval=0.5))
    sim.run(until_time=1.0)
    sim.close()
    u = mda.Universe(str(tmp_path / "t.gsd"))
    assert len(u.trajectory) == 3 and len(u.atoms) == 108
    u.trajectory[-1]
    final = read_state(tmp_path / "t.gsd")
    assert np.allclose(u.atoms.positions, final.points, atol=1e-5)
    assert np.allclose(u.dimensions[:3], final.box, rtol=1e-6)


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


# ---------------------------------------------------------------------------- export
def test_export_csv_is_exact(tmp_path, dim):
    s = _state(dim)
    write_csv(tmp_path / "f.csv", s)
    table = np.genfromtxt(tmp_path / "f.csv", delimiter=",", names=True)
    assert list(table.dtype.names) == csv_columns(dim)
    axes = "xyz"[:dim]
    assert np.array_equal(np.column_stack([table[a] for a in axes]), s.position)
    assert np.array_equal(np.column_stack([table["v" + a] for a in axes]), s.velocity)
    assert np.array_equal(table["radius"], s.radius) and np.array_equal(table["inertia"], s.inertia)
    assert np.array_equal(np.column_stack([table["image_" + a] for a in axes]), s.image)
    spin = table["omega_z"] if dim == 2 else np.column_stack([table["omega_" + a] for a in "xyz"])
    assert np.array_equal(spin, s.angular_velocity)


def _read_xyz(path):
    lines = path.read_text().splitlines()
    header = lines[1]
    rows = np.array([[float(x) for x in line.split()[1:]] for line in lines[2:]])
    return int(lines[0]), header, rows


def test_export_extended_xyz(tmp_path, dim):
    s = _state(dim)
    write_xyz(tmp_path / "f.xyz", s)
    n, header, rows = _read_xyz(tmp_path / "f.xyz")
    assert n == s.n and f"Time={s.time!r}" in header
    assert ('pbc="T T T"' if dim == 3 else 'pbc="T T F"') in header
    assert np.allclose(rows[:, :dim], s.position + s.box / 2, rtol=0, atol=1e-12 * s.box.max())
    assert np.all((rows[:, :dim] >= 0) & (rows[:, :dim] < s.box))
    assert np.array_equal(rows[:, 3 : 3 + dim], s.velocity)
    assert np.array_equal(rows[:, 6], s.radius) and np.array_equal(rows[:, 7], s.mass)
    assert np.array_equal(rows[:, 12:12 + dim], s.image)


def test_ase_reads_the_extended_xyz(tmp_path, dim):
    ase_io = pytest.importorskip("ase.io")
    s = _state(dim)
    write_xyz(tmp_path / "f.xyz", s)
    atoms = ase_io.read(tmp_path / "f.xyz", format="extxyz")
    assert len(atoms) == s.n
    assert np.allclose(atoms.cell.lengths()[:dim], s.box)
    assert list(atoms.pbc) == [True] * dim + [False] * (3 - dim)
    assert np.allclose(atoms.positions[:, :dim], s.position + s.box / 2)
    assert np.allclose(atoms.arrays["velo"][:, :dim], s.velocity) and np.allclose(atoms.arrays["radius"], s.radius)


def test_export_frame_chooses_the_format(tmp_path):
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(32, 0.2), 1.0))
    sim.add(Trajectory(tmp_path / "trajectory.gsd", interval=0.5))
    sim.run(until_time=1.0)
    sim.close()
    s = export_frame(tmp_path, tmp_path / "out.csv", frame=1)
    assert s.time == 0.5 and (tmp_path / "out.csv").exists()
    with pytest.raises(ValueError, match="use a .xyz, .extxyz or .csv"):
        export_frame(tmp_path, tmp_path / "out.pdb")
    with pytest.raises(StateError, match="no GSD file"):
        export_frame(tmp_path / "missing.gsd", tmp_path / "x.xyz")
