"""The cell grid: neighbourhoods and crossing layers against brute force."""

import itertools
import math

import numpy as np
import pytest

from edmd._core.cells import cell_block, cell_coords, cells_buffer_size, crossing_time, grid_shape, near_block, new_grid, walk_block
from edmd._core.images import image_offset
from edmd._core.layout import make_geo
from edmd._core.predict import gap_time


def _coords(c, nc):
    return c // (nc[1] * nc[2]), (c // nc[2]) % nc[1], c % nc[2]


def _block(cc, nc, periodic, reach):
    """Brute force: the cells within ``reach`` cells of coordinates ``cc`` on every axis."""
    want = set()
    for off in itertools.product(range(-reach, reach + 1), repeat=3):
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
    return want


@pytest.mark.parametrize("nc", [(5, 4, 3), (7, 1, 1), (1, 9, 11), (1290, 1290, 1290), (46340, 46340, 1)])
def test_cell_coords_invert_the_cell_index(nc):
    """Every cell of small grids, and the corners and random cells of grids near the int32 limit
    of cell indices (a 2D grid has nz = 1), against Python's divmod."""
    count = nc[0] * nc[1] * nc[2]
    rng = np.random.default_rng(1)
    cells = range(count) if count < 1000 else [0, 1, nc[2] - 1, nc[1] * nc[2], count - 1, *rng.integers(0, count, 200)]
    for c in cells:
        cxy, cz = divmod(int(c), nc[2])
        assert cell_coords(np.int32(c), np.int64(nc[1]), np.int64(nc[2])) == (*divmod(cxy, nc[1]), cz)


@pytest.mark.parametrize("nc, periodic", [((5, 4, 3), (1, 1, 1)), ((4, 4, 1), (1, 1, 0)), ((5, 2, 3), (0, 0, 1)), ((3, 3, 3), (1, 1, 1))])
def test_cell_block_is_the_full_neighbourhood(nc, periodic):
    box = np.array(nc, float)
    half = np.where(np.array(periodic, bool), 0.5 * box, np.inf)
    grid = new_grid(1, box, np.array(nc))
    out = np.empty(27, np.int32)
    for c in range(int(np.prod(nc))):
        got = sorted(out[: cell_block(grid, c, make_geo(box, half), out, -1, 0, 0.0, math.inf)].tolist())
        assert got == sorted(_block(_coords(c, nc), nc, periodic, 1))


@pytest.mark.parametrize("nc, periodic", [((5, 4, 3), (1, 1, 1)), ((4, 4, 1), (1, 1, 0)), ((5, 2, 3), (0, 0, 1))])
def test_near_block_drops_exactly_the_cells_beyond_reach(nc, periodic):
    # a rebuild's candidates: of the full neighbourhood, every cell whose nearest point (through
    # any periodic image) is within reach of a point in c, and none that is beyond reach on the
    # axes of 3 cells or more alone (an axis of 1 or 2 cells may reach one cell both ways)
    lengths = np.array([1.5, 1.2, 1.7])
    box = np.array(nc) * lengths
    half = np.where(np.array(periodic, bool), 0.5 * box, np.inf)
    geo = make_geo(box, half)
    grid = new_grid(1, box, np.array(nc))
    out = np.empty(27, np.int32)
    rng = np.random.default_rng(4)
    dropped = 0
    for c in range(int(np.prod(nc))):
        full = out[: cell_block(grid, c, geo, out, -1, 0, 0.0, math.inf)].tolist()
        lower = np.array(_coords(c, nc)) * lengths - 0.5 * box
        for _ in range(5):
            p = lower + rng.uniform(0.0, 1.0, 3) * lengths
            reach = rng.uniform(0.3, 1.6)
            kept = out[: near_block(grid, c, geo, out, *p, reach)].tolist()
            for c2 in full:
                lo = np.array(_coords(c2, nc)) * lengths - 0.5 * box
                gap = [min(max(lo[k] + s - p[k], 0.0, p[k] - lo[k] - s - lengths[k]) for s in ((-box[k], 0.0, box[k]) if periodic[k] else (0.0,))) for k in range(3)]
                if math.hypot(*gap) < reach:
                    assert c2 in kept, (c, c2, gap, reach)
                if math.hypot(*(gap[k] for k in range(3) if nc[k] >= 3)) > reach * (1 + 1e-6):
                    assert c2 not in kept, (c, c2, gap, reach)
            assert set(kept) <= set(full) and len(set(kept)) == len(kept)
            dropped += len(full) - len(kept)
    assert dropped > 0


def test_layer_after_crossing_is_the_new_neighbourhood_part():
    nc = np.array([5, 5, 5])
    box = nc.astype(float)
    half = 0.5 * box
    grid = new_grid(1, box, nc)
    out = np.empty(27, np.int32)
    old, new = 62, 62 + 25  # +x neighbour
    full_old = set(out[: cell_block(grid, old, make_geo(box, half), out, -1, 0, 0.0, math.inf)].tolist())
    full_new = set(out[: cell_block(grid, new, make_geo(box, half), out, -1, 0, 0.0, math.inf)].tolist())
    layer = set(out[: cell_block(grid, new, make_geo(box, half), out, 0, 1, 0.0, math.inf)].tolist())
    assert layer == full_new - full_old
    assert len(layer) == 9


@pytest.mark.parametrize("nc, periodic", [((5, 4, 3), (1, 1, 1)), ((6, 5, 1), (1, 1, 0)), ((4, 3, 5), (0, 0, 1)), ((2, 3, 4), (0, 1, 0))])
def test_crossing_layers_in_the_order_of_the_full_block(nc, periodic):
    """Every cell, axis and direction of a crossing: the layer (one copy of its loops per axis in
    cell_block) lists the cells at offset ``step`` on the crossed axis in the order the full block
    lists them (x, then y, then z, offsets ascending; the order decides between exactly equal
    contact times, so a trajectory does not change with the code that lists the cells)."""
    box = np.array(nc, float)
    geo = make_geo(box, np.where(np.array(periodic, bool), 0.5 * box, np.inf))
    grid = new_grid(1, box, np.array(nc))
    out = np.empty(27, np.int32)
    for c in range(int(np.prod(nc))):
        cc = _coords(c, nc)
        for axis in range(3):
            for step in (-1, 1) if nc[axis] > 1 else ():
                want = []
                for off in itertools.product(*[(step,) if k == axis else (-1, 0, 1) if nc[k] > 1 else (0,) for k in range(3)]):
                    q = [cc[k] + off[k] for k in range(3)]
                    q = [x % nc[k] if periodic[k] else x for k, x in enumerate(q)]
                    if all(0 <= q[k] < nc[k] for k in range(3)):
                        want.append((q[0] * nc[1] + q[1]) * nc[2] + q[2])
                assert out[: cell_block(grid, c, geo, out, axis, step, 0.0, math.inf)].tolist() == want, (c, axis, step)


@pytest.mark.parametrize("reach", [1, 2, 3])
@pytest.mark.parametrize("nc, periodic", [((8, 9, 10), (1, 1, 1)), ((8, 8, 1), (1, 1, 0)), ((7, 3, 8), (0, 0, 1))])
def test_walk_block_covers_reach_cells_and_the_layer_after_a_crossing(nc, periodic, reach):
    # a big particle's block (cells.walk_block): every cell within reach once (periodic axes have
    # the 2 reach + 2 cells the engine asks for), and after a crossing exactly the cells it did not cover before
    box = np.array(nc, float)
    geo = make_geo(box, np.where(np.array(periodic, bool), 0.5 * box, np.inf))
    grid = new_grid(1, box, np.array(nc), np.array([0], np.int32), reach, 0.25)
    cbuf = np.empty(cells_buffer_size(nc, False, reach), np.int32)

    def cells(c, axis, step):
        n = walk_block(grid, c, geo, cbuf, axis, step, reach)[0]
        got = cbuf[:n].tolist()
        assert len(got) == len(set(got))
        return set(got)

    for c in range(int(np.prod(nc))):
        cc = _coords(c, nc)
        assert cells(c, -1, 0) == _block(cc, nc, periodic, reach)
        for axis, step in itertools.product(range(3), (-1, 1)):
            before = list(cc)
            before[axis] -= step  # (the crossing came from there)
            if nc[axis] == 1 or (not periodic[axis] and not 0 <= before[axis] < nc[axis]):
                continue
            before[axis] %= nc[axis]
            assert cells(c, axis, step) == _block(cc, nc, periodic, reach) - _block(before, nc, periodic, reach)


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


@pytest.mark.parametrize("periodic", [True, False])
def test_crossing_time_without_gravity_is_the_gap_root_of_the_face_ahead(periodic):
    """The select form (no gravity) against the two faces' roots of predict.gap_time, bit for
    bit: inside the cell, on a face, a round-off gap behind a face, at rest, and in the edge
    cells of an open axis (whose outer faces are not crossings)."""
    rng = np.random.default_rng(3)
    for _ in range(2000):
        c = int(rng.integers(0, 5))
        lo = -2.5 + c
        x = lo + float(rng.choice([rng.uniform(0.0, 1.0), 0.0, 1.0, -1e-17, 1.0 + 1e-16]))
        v = float(rng.choice([rng.normal(), 0.0, -0.0]))
        t_up = gap_time(lo + 1.0 - x, -v, -0.0) if periodic or c < 4 else np.inf
        t_lo = gap_time(x - lo, v, 0.0) if periodic or c > 0 else np.inf
        t, face = crossing_time(x, v, 0.0, c, 5, 5.0, 1.0, periodic)
        assert t == min(t_up, t_lo) and np.signbit(t) == np.signbit(min(t_up, t_lo))
        if t < np.inf:
            assert face == (1 if t_up <= t_lo else 0)


@pytest.mark.parametrize("rate", [0.3, -1.7])
def test_sliding_window_holds_every_cell_whose_images_pass_by(rate):
    # a cell on the sliding face, scanned at t with a horizon: every cell across whose image comes
    # within one cell of it at some offset in between, checked on a fine sweep of the offset, and
    # at most two columns more (the window's ends); an infinite horizon takes the whole row
    nc = np.array([12, 6, 4])
    box = np.array([12.0, 6.0, 4.0])
    geo = make_geo(box, 0.5 * box, shear=(rate, 2.3))
    grid = new_grid(1, box, nc)
    out = np.empty(cells_buffer_size(nc, True), np.int32)
    rng = np.random.default_rng(4)
    for _ in range(200):
        cx, cy, cz = rng.integers(12), rng.choice([0, 5]), rng.integers(4)
        c = (cx * 6 + cy) * 4 + cz
        t, horizon = rng.uniform(0.0, 10.0), rng.exponential(0.5)
        got = {_coords(k, nc) for k in out[: cell_block(grid, c, geo, out, -1, 0, t, horizon)]}
        across = {k for k in got if k[1] == 5 - cy}
        need = set()
        for tau in np.linspace(t, t + horizon, 400):
            d = image_offset(tau, geo) * (1 if cy == 5 else -1)  # the row across seen shifted by +-delta
            for x in range(12):
                if min(abs((x + d - cx + 6) % 12 - 6 + o) for o in (-1.0, 0.0, 1.0)) < 1.0 - 1e-6:  # within one cell
                    need |= {(x, 5 - cy, (cz + oz) % 4) for oz in (-1, 0, 1)}
        assert need <= across
        assert len({k[0] for k in across}) <= min(12, len({k[0] for k in need}) + 2)
        assert len(got - across) == 18  # both rows on the own side of the face
    for horizon in (math.inf, 1e19, 1e300):  # (a finite sweep past 2^63 cells: the whole row, review of session 13)
        full = out[: cell_block(grid, 0, geo, out, -1, 0, 0.0, horizon)]  # (row 0: the row across is 5)
        assert len({_coords(k, nc) for k in full if _coords(k, nc)[1] == 5}) == 12 * 3
