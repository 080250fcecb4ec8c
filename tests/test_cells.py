"""The cell grid: neighbourhoods and crossing layers against brute force."""

import itertools

import numpy as np
import pytest

from edmd._core.cells import cell_block, crossing_time, grid_shape, new_grid
from edmd._core.layout import make_geo


def _coords(c, nc):
    return c // (nc[1] * nc[2]), (c // nc[2]) % nc[1], c % nc[2]


@pytest.mark.parametrize("nc, periodic", [((5, 4, 3), (1, 1, 1)), ((4, 4, 1), (1, 1, 0)), ((5, 2, 3), (0, 0, 1)), ((3, 3, 3), (1, 1, 1))])
def test_cell_block_is_the_full_neighbourhood(nc, periodic):
    box = np.array(nc, float)
    half = np.where(np.array(periodic, bool), 0.5 * box, np.inf)
    grid = new_grid(1, box, np.array(nc))
    out = np.empty(27, np.int32)
    for c in range(int(np.prod(nc))):
        got = sorted(out[: cell_block(grid, c, make_geo(box, half), out, -1, 0)].tolist())
        cc = _coords(c, nc)
        want = set()
        for off in itertools.product((-1, 0, 1), repeat=3):
            q = []
            for k in range(3):
                x = cc[k] + off[k]
                if nc[k] == 1:
                    x = 0
                elif periodic[k]:
                    x %= nc[k]
                elif not 0 <= x < nc[k]:
                    break
                q.append(x)
            else:
                want.add((q[0] * nc[1] + q[1]) * nc[2] + q[2])
        assert got == sorted(want)


def test_layer_after_crossing_is_the_new_neighbourhood_part():
    nc = np.array([5, 5, 5])
    box = nc.astype(float)
    half = 0.5 * box
    grid = new_grid(1, box, nc)
    out = np.empty(27, np.int32)
    old, new = 62, 62 + 25  # +x neighbour
    full_old = set(out[: cell_block(grid, old, make_geo(box, half), out, -1, 0)].tolist())
    full_new = set(out[: cell_block(grid, new, make_geo(box, half), out, -1, 0)].tolist())
    layer = set(out[: cell_block(grid, new, make_geo(box, half), out, 0, 1)].tolist())
    assert layer == full_new - full_old
    assert len(layer) == 9


def test_grid_shape_uses_one_cell_on_short_periodic_axes():
    nc = grid_shape(np.array([10.0, 2.5, 1.0]), np.array([True, True, False]), 1.0)
    assert nc.tolist() == [10, 1, 1]


@pytest.mark.parametrize("v, g, expected_face", [(1.0, 0.0, 1), (-1.0, 0.0, 0), (0.5, -3.0, 0)])
def test_crossing_time(v, g, expected_face):
    # cell 2 of 5 on [-2.5, 2.5): faces at -0.5 and 0.5; particle at x = 0.1
    t, face = crossing_time(0.1, v, g, 2, 5, 5.0, 1.0, True)
    x = 0.1 + v * t + 0.5 * g * t * t
    assert face == expected_face
    assert x == pytest.approx(0.5 if face else -0.5, abs=1e-12)
    assert crossing_time(0.1, 0.0, 0.0, 2, 5, 5.0, 1.0, True)[0] == np.inf
