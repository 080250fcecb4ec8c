"""The cost model that sizes the cells of cells mode."""

import math

import numpy as np
import pytest

from edmd.run.engine import Engine, EngineOptions
from edmd.run.neighbours import MAX_BIGS, big_count, cell_cost, cell_edge, local_densities, mean_free_path


def test_mean_free_path_has_the_boltzmann_dilute_limit(dim):
    n = 1e-6
    boltzmann = 1.0 / (math.sqrt(2.0) * math.pi * n) if dim == 3 else 1.0 / (2.0 * math.sqrt(2.0) * n)
    assert mean_free_path(n, 1.0, dim) == pytest.approx(boltzmann, rel=1e-5)
    # Enskog: chi > 1 shortens it (3D eta = 0.3: chi = (1 - 0.15) / 0.7^3 = 2.478)
    if dim == 3:
        n = 0.3 * 6 / math.pi
        assert mean_free_path(n, 1.0, 3) == pytest.approx(0.343 / (0.85 * math.sqrt(2.0) * math.pi * n), rel=1e-12)


@pytest.mark.parametrize("eta", [0.002, 0.01, 0.05, 0.1, 0.4])
def test_cell_edge_minimises_the_cost_and_is_at_least_the_contact_distance(dim, eta):
    n = eta / (math.pi / 6.0) if dim == 3 else eta / (math.pi / 4.0)
    edge = cell_edge(n, 1.0, 1.5, dim)
    assert edge >= 1.5
    path = mean_free_path(n, 1.0, dim)
    grid = np.linspace(1.5, 100.0, 20000)
    best = min(cell_cost(float(e), n, path, dim) for e in grid)
    assert cell_cost(edge, n, path, dim) <= best * (1 + 1e-4)


def test_cells_widen_as_the_density_falls(dim):
    edges = [cell_edge(n, 1.0, 1.0, dim) for n in (0.5, 0.1, 0.02, 0.004)]
    assert edges == sorted(edges) and edges[-1] > 3.0


def test_a_stratified_system_is_sized_by_its_dense_part(dim):
    # 90 % of the particles in a dense layer, 10 % spread above: the work per unit time is the
    # dense layer's (its collisions are far more frequent), and the edge is its own
    dense, dilute = (0.5, 0.005) if dim == 3 else (0.6, 0.006)
    edge = cell_edge([dense, dilute], 1.0, 1.0, dim, weights=[0.9, 0.1])
    assert edge == pytest.approx(cell_edge(dense, 1.0, 1.0, dim), rel=0.05)
    assert edge < 0.5 * cell_edge(0.9 * dense + 0.1 * dilute / 100, 1.0, 1.0, dim) or edge == 1.0
    # one region: the homogeneous model, whatever its weight
    assert cell_edge([0.02], 1.0, 1.0, dim, weights=[7.0]) == cell_edge(0.02, 1.0, 1.0, dim)


def test_local_densities_count_every_particle_once(dim, rng):
    box = np.array([20.0, 30.0, 25.0][:dim])
    pos = rng.uniform(-0.5, 0.5, (3000, dim)) * box
    pos[:2000, -1] = -0.5 * box[-1] + rng.uniform(0.0, 3.0, 2000)  # two thirds in a slab of height 3
    density, weights = local_densities(pos, box, 1.0)
    assert weights.sum() == 3000 and np.all(density > 0)
    mean = 3000 / np.prod(box)
    assert np.average(density, weights=weights) > 3 * mean  # most particles are in the slab


def test_a_bed_under_gravity_gets_cells_of_its_dense_layers():
    # a 2D bed settled on the floor (random start, then lowered into ten layers): the engine sizes
    # its cells at load by the local densities, not by the box's mean density
    import edmd

    state = edmd.random_packing(2000, 0.05, dim=2, seed=1, periodic=[True, False], aspect=[1.0, 2.0])
    settled = state.position.copy()
    settled[:, 1] = -0.5 * state.box[1] + 0.55 + (settled[:, 1] + 0.5 * state.box[1]) * 0.06  # squeezed down ~17x
    bed = edmd.State(settled, state.velocity, state.radius, state.mass, box=state.box, periodic=state.periodic, check_overlaps=False)
    # (the squeezed bed overlaps: the engines are made directly, a Simulation refuses such a state)
    options = EngineOptions(neighbours="cells")
    free, heavy = Engine(bed, options), Engine(bed, options, gravity=[0.0, -1.0])
    edge = lambda engine: engine.box[0] / engine.grid_cells[0]  # noqa: E731
    assert edge(heavy) < 0.6 * edge(free) and edge(heavy) < 1.3


def test_crowded_small_particles_do_not_blow_up_the_cells(dim):
    # a layer of small spheres counted at the mean diameter exceeds close packing: the cells
    # stay at the dense layers' size (a negative free path once picked the widest cells)
    n_close = (0.6 / (math.pi / 6.0)) if dim == 3 else (0.8 / (math.pi / 4.0))
    edge = cell_edge([0.01, 2.0 * n_close], 1.0, 1.0, dim, weights=[10, 1000])
    assert edge == pytest.approx(cell_edge(n_close, 1.0, 1.0, dim), rel=0.05) and edge < 2.0


def test_a_few_big_particles_are_taken_out_of_the_cell_size(dim):
    """An intruder (size ratio 10) in a gas is taken out; so are a few large ones, never more than
    MAX_BIGS, never a tie, never particles whose sizes barely differ (nothing to gain)."""
    n = 0.05 / (math.pi / 6.0) if dim == 3 else 0.05 / (math.pi / 4.0)
    small = np.full(9990, 0.5)
    assert big_count(np.r_[5.0, small], n, dim) == 1
    assert big_count(np.r_[5.0, 4.0, 3.0, small], n, dim) == 3
    assert big_count(np.r_[np.full(MAX_BIGS + 1, 5.0), small], n, dim) == 0  # (a tie at the cap: none split)
    assert big_count(np.r_[0.52, small], n, dim) == 0
    assert big_count(small, n, dim) == 0
    assert big_count(np.linspace(0.1, 1.0, 10000), n, dim) == 0
