"""Export of one frame: CSV (exact) and extended XYZ as ASE and OVITO read it."""

import numpy as np
import pytest

import edmd
from edmd import StateError, Trajectory
from edmd.files.export import csv_columns, export_frame, write_csv, write_xyz

from test_trajectory import _state


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
    assert np.array_equal(rows[:, 6 : 6 + dim], s.mass[:, None] * s.velocity)  # momenta
    assert np.array_equal(rows[:, 9], s.radius)
    assert np.array_equal(rows[:, 10], s.mass) and np.array_equal(rows[:, 11], s.mass)
    assert np.array_equal(rows[:, 12], s.inertia)
    assert np.array_equal(rows[:, 16 : 16 + dim], s.image)


def test_ase_reads_velocities_and_masses(tmp_path, dim):
    ase_io = pytest.importorskip("ase.io")
    s = _state(dim)
    assert np.ptp(s.mass) > 0  # masses differ: ASE's defaults would not pass
    write_xyz(tmp_path / "f.xyz", s)
    atoms = ase_io.read(tmp_path / "f.xyz", format="extxyz")
    assert len(atoms) == s.n
    assert np.allclose(atoms.cell.lengths()[:dim], s.box)
    assert list(atoms.pbc) == [True] * dim + [False] * (3 - dim)
    assert np.allclose(atoms.positions[:, :dim], s.position + s.box / 2)
    assert np.array_equal(atoms.get_masses(), s.mass)
    # get_velocities() = momenta / masses (no unit conversion): (m v) / m is v to 2 roundings
    v = atoms.get_velocities()
    np.testing.assert_allclose(v[:, :dim], s.velocity, rtol=1e-15, atol=0)
    assert np.all(v[:, dim:] == 0)
    assert np.array_equal(atoms.arrays["radius"], s.radius)
    spin = atoms.arrays["angular_velocity"]
    assert np.array_equal(spin if dim == 3 else spin[:, 2], s.angular_velocity)
    assert atoms.info["Time"] == s.time


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
