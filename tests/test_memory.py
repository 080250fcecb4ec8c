"""Memory: the estimate and guard before allocation, and a cell grid bounded by the particle number."""

import numpy as np
import pytest

import edmd
from edmd._core.cells import grid_shape as one_diameter_grid
from edmd.run.memory import MemoryLimitError, check_memory, estimate_bytes, grid_shape, max_cells, parse_bytes


def test_guard_names_the_cause_and_the_remedy():
    with pytest.raises(MemoryLimitError, match=r"N = 1e\+09 particles needs about 664 GB .*use fewer particles, or raise the limit"):
        check_memory(10**9)  # no machine here has 0.66 TB available
    check_memory(10**6, max_memory="2GB")
    with pytest.raises(MemoryLimitError, match="not a memory size"):
        check_memory(10, max_memory="lots")
    assert estimate_bytes(10**7) == 10**7 * estimate_bytes(1)


@pytest.mark.parametrize("text, size", [("8G", 8 * 10**9), ("500 MB", 5 * 10**8), ("2GiB", 2 * 2**30), (4096, 4096), ("1.5k", 1500)])
def test_memory_sizes(text, size):
    assert parse_bytes(text) == size


def test_grid_is_bounded_by_the_particle_number(dim):
    n = 200
    state = edmd.random_packing(n, 1e-6, dim=dim, seed=1)  # one-diameter cells: 1e8 (3D), 3e7 (2D)
    nc = grid_shape(np.r_[state.box, [1.0] * (3 - dim)], [True] * dim + [False] * (3 - dim), 1.0, n, dim)
    assert np.prod(nc) <= max_cells(n) and np.all(nc[:dim] >= 4)
    sim = edmd.Simulation(edmd.maxwell_boltzmann(state, 1.0, seed=2), engine={"neighbours": "cells"})
    assert np.prod(sim.engine.grid_cells) <= max_cells(n)


@pytest.mark.parametrize("mode", ["cells", "list"])
def test_disks_in_si_units_get_one_cell_across_the_plane(mode):
    """2D boxes carry a placeholder third length of 1: disks of radius 1 mm once had 63 (cells)
    or 153 (lists) cells across it, every walk visited three layers of them, and the cell cap took
    cells from the plane (0.64 of the speed). The plane's cells must equal those of the same
    system in units of the diameter."""
    grids = []
    for radius in (0.5, 1e-3):
        s = edmd.maxwell_boltzmann(edmd.random_packing(2000, 0.05 if mode == "cells" else 0.7, dim=2, seed=1, radius=radius), radius**2, seed=2)
        grids.append(edmd.Simulation(s, engine={"neighbours": mode}).engine.grid_cells.tolist())
    assert grids[0] == grids[1] and grids[1][2] == 1


def test_coarse_cells_give_the_same_collisions_as_lists(dim):
    # eta = 1e-3: one-diameter cells would be 500 (3D) or 800 (2D) per particle, above max_cells: the
    # bounded grid is coarser and must
    # change nothing but the bookkeeping: the same collisions as neighbour lists, to round-off (1e-16
    # relative, amplified by ~lambda/sigma ~ 100 per collision of the chaotic dilute gas: < 1e-6 sigma here)
    state = edmd.maxwell_boltzmann(edmd.random_packing(400, 1e-3, dim=dim, seed=3), 1.0, seed=4)
    runs = {}
    for mode in ("cells", "list"):
        sim = edmd.Simulation(state, e_n=0.9, engine={"neighbours": mode})
        sim.run(until_time=60.0)
        runs[mode] = sim
    e = runs["cells"].engine
    assert np.prod(e.grid_cells) <= max_cells(400) < np.prod(one_diameter_grid(e.box, np.r_[e.periodic, [False] * (3 - dim)], 1.0))
    assert runs["cells"].collisions == runs["list"].collisions > 50
    a, b = runs["cells"].state, runs["list"].state
    assert np.allclose(a.unwrapped_position, b.unwrapped_position, rtol=0, atol=1e-6)
    assert np.allclose(a.velocity, b.velocity, rtol=0, atol=1e-6)
