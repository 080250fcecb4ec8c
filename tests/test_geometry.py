"""Overlap searches of the set-up (``_core/geometry.py``) with big particles taken out of the cell size."""

import numpy as np
import pytest

from edmd._core.geometry import close_pairs
from edmd._core.layout import make_geo
from edmd.run.neighbours import overlap_grid


def _system(dim, rng, walls):
    """600 small spheres (radius 0.5) and 3 bigs (radius 3) at random (overlaps allowed) in a box of 16."""
    n, box = 603, np.ones(3)
    box[:dim] = 16.0
    radius = np.r_[np.full(600, 0.5), np.full(3, 3.0)]
    rng.shuffle(radius)
    periodic = np.zeros(3, bool)
    periodic[:dim] = True
    if walls:
        periodic[0] = False
    pos = np.zeros((n, 3))
    pos[:, :dim] = rng.uniform(-8.0, 8.0, (n, dim))
    half = np.where(periodic, 0.5 * box, np.inf)
    return pos, radius, box, periodic, make_geo(box, half)


def _all_pairs(pos, radius, box, periodic, scale):
    """Every pair closer than ``scale (R_i + R_j)``, by numpy over all pairs and the nearest image."""
    d = pos[:, None, :] - pos[None, :, :]
    d -= np.where(periodic, box * np.round(d / box), 0.0)
    r = np.sqrt((d * d).sum(-1))
    i, j = np.nonzero(np.triu(r < scale * (radius[:, None] + radius[None, :]), 1))
    return i, j, r[i, j]


@pytest.mark.parametrize("walls", [False, True])
@pytest.mark.parametrize("scale", [1.0, 1.3])
def test_close_pairs_with_big_particles_are_all_pairs(dim, rng, walls, scale):
    pos, radius, box, periodic, geo = _system(dim, rng, walls)
    grid = overlap_grid(radius, box, periodic, dim, scale)
    assert grid.shape[5] == 3 and grid.shape[6] > 1  # three bigs, each scanning several cells to each side
    i, j, d = close_pairs(pos, radius, geo, grid, scale)
    assert np.all(i < j)
    got = sorted(zip(i.tolist(), j.tolist(), d[:, 3].tolist()))
    want = sorted(zip(*(a.tolist() for a in _all_pairs(pos, radius, box, periodic, scale))))
    assert [p[:2] for p in got] == [p[:2] for p in want]  # each pair once, none missed
    assert np.allclose([p[2] for p in got], [p[2] for p in want], rtol=1e-12)
    big = np.isin(i, np.flatnonzero(radius > 1)) | np.isin(j, np.flatnonzero(radius > 1))
    assert big.sum() > 10  # the bigs' blocks found partners


def test_overlap_grid_takes_no_big_where_its_block_would_wrap_or_the_box_shears(dim):
    radius = np.r_[np.full(999, 0.5), 5.0]
    box = np.ones(3)
    box[:dim] = 12.0  # 12 cells of 1: a block of 2 * 6 + 1 = 13 would hold cells twice
    periodic = np.arange(3) < dim
    assert overlap_grid(radius, box, periodic, dim).shape[5] == 0
    box[:dim] = 40.0
    assert overlap_grid(radius, box, periodic, dim).shape[5] == 1
    sheared = overlap_grid(radius, box, periodic, dim, shear=True)
    assert sheared.shape[5] == 0 and sheared.size[0] >= 10.0  # cells of the largest contact
