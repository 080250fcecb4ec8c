"""The cost model that sizes the cells of cells mode."""

import math

import numpy as np
import pytest

from edmd.run.neighbours import cell_cost, cell_edge, mean_free_path


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
