"""GSD files: exact round trip of every field, frame contents, readers."""

import gsd.hoomd
import numpy as np
import pytest

import edmd
from edmd import StateError, Trajectory, read_state, write_state


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
