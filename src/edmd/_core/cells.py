"""Cell grid ("sectors", physics.md §1.4): binning, neighbour cells, face-crossing times.

The grid is :class:`.bundles.Grid` ``(head, link, cell, shape, size)``: ``head[c]`` is the
first particle of cell ``c`` and ``link`` links the rest (singly linked, cells are small);
``cell[i]`` is the cell a particle is registered in; ``shape = [ncx, ncy, ncz, scanned, tested,
bigs, reach]`` (``gi`` here): the cells per axis, then the cells scanned and the pairs tested by
the event loop's predictions (:func:`count_work`; in ``shape``, not a field of their own: one
more array in the bundle that the called cell functions take by value ran cell-mode gases at
0.65 of the speed, measured), then the big particles' count and reach (below); ``size = [lx, ly,
lz, 1/lx, 1/ly, 1/lz, r_max, r_min, r_small]`` (``gf``): the cell lengths, their inverses, (a grid
of list centres) the largest and smallest radius of the binned particles, set by
:func:`.nblist.build_lists`, and the largest radius that is not big.

**Big particles** (cells mode, physics.md §1.4 "Big particles"): a few particles much larger than
the rest would make every cell as wide as their contacts. Instead the cells are sized for the
others (radii up to ``r_small``), and the bigs (radius above it; their indices follow the cells'
heads in ``head``) are binned like every particle but scan ``reach`` cells to each side
(:func:`walk_block`), and every scan also tests every big (:func:`.schedule.scan_cells`).
The box spans ``[-L/2, L/2)`` on every axis. A periodic axis has at least three cells or
exactly one (then the neighbour search does not look along it); an open axis any number. The
event loop's cells mode needs four on a periodic axis: with three, two cells are adjacent
through two images, and a crossing would not reveal the partner's other image (the engine
ensures it, measured by the brute-force tests).
"""

import math

import numpy as np
from numba.extending import overload

from .jit import jit, leaf
from .bundles import Grid

from .images import image_offset, sheared, sheared_type
from .layout import G_LX, G_LY, G_SHEAR_RATE
from .predict import INF, gap_time
from .prefetch import prefetch


#: index in ``Grid.shape`` of the work counters (cells scanned, then pairs tested)
GI_WORK = 3
#: indices in ``Grid.shape`` of the number of big particles and of the cells a big scans to each side
GI_BIGS, GI_REACH = 5, 6
#: indices in ``Grid.size`` of the largest and the smallest radius of the particles whose list
#: centres are binned, and of the largest radius that is not big
GF_RMAX, GF_RMIN, GF_RSMALL = 6, 7, 8
#: no gaps: :func:`cell_block` keeps every neighbour cell
NO_GAPS = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
#: the number of particles from which a walk prefetches the rows of the cells' first particles
#: (:func:`prefetch_firsts`)
PREFETCH_ROWS_FROM = 1 << 16


def grid_shape(box, periodic, min_cell):
    """Cells per axis for cell edges of at least ``min_cell`` (1 on an axis too short for 3)."""
    nc = np.ones(3, np.int64)
    for k in range(3):
        if not np.isfinite(box[k]) or box[k] <= 0:
            continue
        n = int(math.floor(box[k] / min_cell))
        if periodic[k] and n < 3:
            n = 1
        nc[k] = max(n, 1)
    return nc


def new_grid(n, box, nc, bigs=(), reach=1, r_small=math.inf):
    """Allocate an empty grid for ``n`` particles with ``nc`` cells per axis; ``bigs``: the indices
    of the big particles (radius above ``r_small``), which scan ``reach`` cells to each side."""
    gi = np.zeros(GI_REACH + 1, np.int64)
    gi[:3] = nc
    gi[GI_BIGS] = len(bigs)
    gi[GI_REACH] = reach
    gf = np.zeros(GF_RSMALL + 1)
    for k in range(3):
        length = box[k] if np.isfinite(box[k]) else 1.0
        gf[k] = length / nc[k]
        gf[3 + k] = 1.0 / gf[k]
    gf[GF_RSMALL] = r_small
    head = np.full(int(np.prod(nc)) + len(bigs), -1, np.int32)
    head[head.size - len(bigs) :] = bigs
    return Grid(head, np.full(n, -1, np.int32), np.zeros(n, np.int32), gi, gf)


@leaf
def cell_count(grid):
    """The number of cells (``head`` holds the big particles after them)."""
    return grid.shape[0] * grid.shape[1] * grid.shape[2]


@leaf
def reach_of(grid, r):
    """Cells a particle of radius ``r`` scans to each side: the bigs' reach, or 1."""
    return grid.shape[GI_REACH] if r > grid.size[GF_RSMALL] else np.int64(1)


@leaf
def _axis_cell(x, length, inv, nc):
    if nc == 1:
        return 0
    c = int(math.floor((x + 0.5 * length) * inv))
    if c < 0:
        return 0
    if c >= nc:
        return nc - 1
    return c


@leaf
def cell_of_point(x, y, z, geo, grid):
    gi = grid.shape
    gf = grid.size
    cx = _axis_cell(x, geo[0], gf[3], gi[0])
    cy = _axis_cell(y, geo[1], gf[4], gi[1])
    cz = _axis_cell(z, geo[2], gf[5], gi[2])
    return (cx * gi[1] + cy) * gi[2] + cz


@leaf
def cell_insert(grid, i, c):
    head, nxt, cell = grid.head, grid.link, grid.cell
    nxt[i] = head[c]
    head[c] = i
    cell[i] = c


@jit
def bin_all(pos, geo, grid):
    """Empty ``grid`` and bin every particle by the first three columns of ``pos`` (x, y, z)."""
    grid.head[: cell_count(grid)] = -1
    for i in range(pos.shape[0]):
        cell_insert(grid, i, cell_of_point(pos[i, 0], pos[i, 1], pos[i, 2], geo, grid))


@leaf
def cell_remove(grid, i):
    head, nxt, cell = grid.head, grid.link, grid.cell
    c = cell[i]
    k = head[c]
    if k == i:
        head[c] = nxt[i]
        return
    while k >= 0:
        s = nxt[k]
        if s == i:
            nxt[k] = nxt[i]
            return
        k = s


@leaf
def _offsets(k, nc, axis, step, reach):
    """Offsets searched on axis ``k``: ``reach`` cells in the crossing direction only on ``axis``,
    else ``-reach..reach``."""
    if k == axis:
        return step * reach, step * reach
    if nc == 1:
        return 0, 0
    return -reach, reach


@leaf
def _shift(c, o, nc, periodic):
    """Neighbour coordinate ``c + o`` on one axis, or ``-1`` beyond an open edge."""
    c2 = c + o
    if c2 < 0:
        return c2 + nc if periodic else -1
    if c2 >= nc:
        return c2 - nc if periodic else -1
    return c2


@leaf
def cell_block(grid, c, geo, out, axis, step, t, horizon):
    """Write cells around ``c`` into ``out`` (each once) and return their number.

    ``axis = -1``: the full neighbourhood of ``c``, itself included. Otherwise the layer beyond
    ``c`` in direction ``step`` (+1/-1) along ``axis``: after a crossing into ``c`` these are the
    only cells whose particles were not candidates before (physics.md §1.4: the newly adjacent
    layer of :math:`3^{d-1}` cells). In a sheared box, the cells across a sliding face whose
    images pass by from local time ``t`` for ``horizon`` (:func:`sheared_block`).
    """
    n = sheared_block(grid, c, geo, out, axis, step, t, horizon)
    if n >= 0:
        return n
    if axis < 0:
        return _plain_block(geo, out, _block_frame(grid, c, axis, step, np.int64(1)), NO_GAPS, INF)
    gi = grid.shape
    nx, ny, nz = gi[0], gi[1], gi[2]
    cx, cy, cz = cell_coords(c, ny, nz)
    px, py, pz = geo[3] < INF, geo[4] < INF, geo[5] < INF
    # one copy of the layer's loops per axis: which axis a crossing crossed is a coin toss, and
    # in a loop shared by the three axes its trip counts followed it
    if axis == 0:
        return _layer(out, _shift(cx, step, nx, px) * ny * nz, cy, ny, py, nz, cz, nz, pz, 1)
    if axis == 1:
        return _layer(out, _shift(cy, step, ny, py) * nz, cx, nx, px, ny * nz, cz, nz, pz, 1)
    return _layer(out, _shift(cz, step, nz, pz), cx, nx, px, ny * nz, cy, ny, py, nz)


@leaf
def _layer(out, base, cu, nu, pu, su, cv, nv, pv, sv):
    """The cells ``base + u su + v sv`` around ``(cu, cv)`` on the two axes across a crossing (``nu``,
    ``nv`` cells, periodic ``pu``, ``pv``), ``u`` outer; none when ``base < 0`` (beyond an open edge)."""
    if base < 0:
        return 0
    n = 0
    reach_u = 1 if nu > 1 else 0
    reach_v = 1 if nv > 1 else 0
    for ou in range(-reach_u, reach_u + 1):
        u = _shift(cu, ou, nu, pu)
        if u < 0:
            continue
        for ov in range(-reach_v, reach_v + 1):
            v = _shift(cv, ov, nv, pv)
            if v >= 0:
                out[n] = base + u * su + v * sv
                n += 1
    return n


@leaf
def near_block(grid, c, geo, out, x, y, z, reach):
    """The full neighbourhood of cell ``c`` (:func:`cell_block`, ``axis = -1``) less the cells
    whose nearest point lies farther than ``reach`` from the point ``(x, y, z)`` in ``c``: a
    neighbour list's candidates (with list cells one reach wide, it drops about 7 of the 27 cells in 3D).

    The gap to the neighbour at offset :math:`o_k \\in \\{-1, 0, 1\\}` on axis :math:`k` is the
    distance of the point to the lower face of ``c``, 0, or to the upper face; a cell is kept when
    the squared gaps sum below :math:`\\mathrm{reach}^2 (1 + 10^{-9})` (the margin is far above
    rounding, so no listed pair is missed). Axes of fewer than 3 cells have no gaps (the
    neighbours on both sides may be one cell), nor do sheared face cells (:func:`sheared_block`).
    """
    n = sheared_block(grid, c, geo, out, np.int64(-1), np.int64(0), 0.0, NOT_ACROSS)
    if n >= 0:
        return n
    frame = _block_frame(grid, c, np.int64(-1), np.int64(0), np.int64(1))
    cx, cy, cz = frame[3], frame[4], frame[5]
    gaps = (*_face_gaps(grid, geo, 0, cx, x), *_face_gaps(grid, geo, 1, cy, y), *_face_gaps(grid, geo, 2, cz, z))
    return _plain_block(geo, out, frame, gaps, reach * reach * (1.0 + 1e-9))


@leaf
def _face_gaps(grid, geo, k, ck, x):
    """Squared distances from ``x`` to the lower and the upper face of cell ``ck`` on axis ``k``
    (0 on an axis of fewer than 3 cells; a point just outside its cell, by rounding, has gap 0)."""
    if grid.shape[k] < 3:
        return 0.0, 0.0
    lower = x - (ck * grid.size[k] - 0.5 * geo[k])
    upper = grid.size[k] - lower
    lower, upper = max(lower, 0.0), max(upper, 0.0)
    return lower * lower, upper * upper


@leaf
def _gap(lower, upper, o):
    return lower if o < 0 else upper if o > 0 else 0.0


@leaf
def _plain_block(geo, out, frame, gaps, room):
    """:func:`cell_block` in an unsheared box (``frame``: :func:`_block_frame`), keeping only the
    cells whose squared gaps (``gaps``: lower and upper per axis, :func:`near_block`) sum below ``room``."""
    nx, ny, nz, cx, cy, cz, lox, hix, loy, hiy, loz, hiz = frame
    px, py, pz = geo[3] < INF, geo[4] < INF, geo[5] < INF
    n = 0
    for ox in range(lox, hix + 1):
        x2 = _shift(cx, ox, nx, px)
        if x2 < 0:
            continue
        gx = _gap(gaps[0], gaps[1], ox)
        for oy in range(loy, hiy + 1):
            y2 = _shift(cy, oy, ny, py)
            if y2 < 0:
                continue
            n = _z_column(out, n, x2, y2, cz, loz, hiz, ny, nz, pz, room - gx - _gap(gaps[2], gaps[3], oy), gaps[4], gaps[5])
    return n


@leaf
def cell_coords(c, ny, nz):
    """Coordinates ``(cx, cy, cz)`` of cell ``c = (cx ny + cy) nz + cz`` (cell indices are int32):
    two unsigned divisions, where Python's floor division and modulo of signed integers would
    take four, each with its sign correction (a crossing finds its cell's coordinates three times)."""
    u = np.uint64(c)
    q = u // np.uint64(nz)
    cx = q // np.uint64(ny)
    return np.int64(cx), np.int64(q - cx * np.uint64(ny)), np.int64(u - q * np.uint64(nz))


@leaf
def _block_frame(grid, c, axis, step, reach):
    """Cells per axis, the coordinates of cell ``c`` and the offsets searched on each axis (:func:`_offsets`)."""
    gi = grid.shape
    nx, ny, nz = gi[0], gi[1], gi[2]
    cx, cy, cz = cell_coords(c, ny, nz)
    lox, hix = _offsets(0, nx, axis, step, reach)
    loy, hiy = _offsets(1, ny, axis, step, reach)
    loz, hiz = _offsets(2, nz, axis, step, reach)
    return nx, ny, nz, cx, cy, cz, lox, hix, loy, hiy, loz, hiz


@leaf
def _z_column(out, n, x2, y2, cz, loz, hiz, ny, nz, pz, room, lower, upper):
    """Append the cells ``(x2, y2, cz + oz)`` for ``oz`` in ``[loz, hiz]`` whose squared gap on z
    (``lower``, 0, ``upper``) is below ``room`` to ``out[n:]``; returns the new count."""
    for oz in range(loz, hiz + 1):
        z2 = _shift(cz, oz, nz, pz)
        if z2 >= 0 and _gap(lower, upper, oz) < room:
            out[n] = (x2 * ny + y2) * nz + z2
            n += 1
    return n


@leaf
def _sliding_window(nx, cx, above, t, horizon, geo):
    r"""First column and number of columns of the row across the sliding face whose images pass
    within one cell of column ``cx`` while the offset moves from :math:`\delta(t)` to
    :math:`\delta(t + \mathrm{horizon})` (``above``: the row is seen through the image above,
    shifted by :math:`+\delta`; else below, by :math:`-\delta`). The whole row when that is shorter;
    none for a negative horizon (:data:`NOT_ACROSS`)."""
    if horizon == INF:
        return 0, nx
    if horizon < 0.0:
        return 0, 0
    w = geo[G_LX] / nx
    d0 = image_offset(t, geo) / w
    d1 = d0 + geo[G_SHEAR_RATE] * geo[G_LY] * horizon / w
    da, db = min(d0, d1), max(d0, d1)
    if not db - da < nx:  # (also a horizon so long that the sweep overflows: a flight nearly at rest)
        return 0, nx
    # partners within one cell of column cx: their images in columns [cx - 1, cx + 2)
    lo, hi = (cx - 1.0 - db, cx + 2.0 - da) if above else (cx - 1.0 + da, cx + 2.0 + db)
    x0 = int(math.floor(lo - WINDOW_MARGIN))
    count = int(math.floor(hi + WINDOW_MARGIN)) - x0 + 1
    if count >= nx:
        return 0, nx
    return x0 % nx, count


#: round-off margin of :func:`_sliding_window`, in cells
WINDOW_MARGIN = 1e-6
#: the horizon of a walk that leaves out the cells across a sliding face (the neighbour lists')
NOT_ACROSS = -1.0


@leaf
def _sheared_block(grid, c, geo, out, axis, step, t, horizon):
    nx, ny, nz, cx, cy, cz, lox, hix, loy, hiy, loz, hiz = _block_frame(grid, c, axis, step, np.int64(1))
    pz = geo[5] < INF
    n = 0
    ylo, yhi = _offsets(1, ny, -1, 0, np.int64(1))
    for oy in range(ylo, yhi + 1):
        y2 = _shift(cy, oy, ny, True)
        if y2 != cy + oy or ny < 3:  # the row across the face (a single row is also the row across: whole)
            x0, count = _sliding_window(nx, cx, oy > 0, t, INF if ny < 3 else horizon, geo)
            zlo, zhi = _offsets(2, nz, -1, 0, np.int64(1))
            for ox in range(count):
                n = _z_column(out, n, (x0 + ox) % nx, y2, cz, zlo, zhi, ny, nz, pz, INF, 0.0, 0.0)
        elif loy <= oy and oy <= hiy:
            for ox in range(lox, hix + 1):
                n = _z_column(out, n, _shift(cx, ox, nx, True), y2, cz, loz, hiz, ny, nz, pz, INF, 0.0, 0.0)
    return n


def sheared_block(grid, c, geo, out, axis, step, t, horizon):
    """:func:`cell_block` in a sheared box (Lees-Edwards, :mod:`.images`), or -1 in another.

    The row of cells across a sheared y face slides with the images. A cell on the face has as
    neighbours across it the cells whose images pass within one cell of it from local time ``t``
    until ``t + horizon`` (:func:`_sliding_window`; ``horizon = inf``: the whole row, at all
    times; negative: none, but a single row is always whole), at every crossing as at a full
    scan, all three z layers: the event loop's horizon is the particle's next crossing, so the
    window scanned last expires exactly when the next one is scanned and no event is needed when
    the images move (physics.md §5.7). ``out`` holds :func:`cells_buffer_size` cells.
    """
    return _sheared_block(grid, c, geo, out, axis, step, t, horizon) if sheared(geo) else -1


@overload(sheared_block, inline="always")
def _sheared_block_hook(grid, c, geo, out, axis, step, t, horizon):
    if sheared_type(geo):
        return lambda grid, c, geo, out, axis, step, t, horizon: _sheared_block(grid, c, geo, out, axis, step, t, horizon)
    return lambda grid, c, geo, out, axis, step, t, horizon: -1


@leaf
def face_side(grid, c):
    """Which sliding y face cell ``c`` lies on: +1 the upper, -1 the lower, 0 neither (a grid of
    fewer than 3 rows: 0)."""
    ny = grid.shape[1]
    cy = (c // grid.shape[2]) % ny
    if ny < 3:
        return 0
    return 1 if cy == ny - 1 else -1 if cy == 0 else 0


def cells_buffer_size(nc, shear: bool, reach: int = 1) -> int:
    """Cells a walk may visit at once (:func:`cell_block`): 27, or with shear the two rows of 3 x 3
    beside a face and the whole row across it, or with big particles their block of
    :math:`(2\\,\\mathrm{reach} + 1)^3` (:func:`walk_block`).

    Example:
        >>> cells_buffer_size((10, 10, 10), False), cells_buffer_size((10, 10, 10), True), cells_buffer_size((10, 10, 10), False, 3)
        (27, 48, 343)
    """
    return max(27, 18 + 3 * int(nc[0])) if shear else max(27, (2 * reach + 1) ** 3)


@leaf
def count_work(grid, cells, pairs):
    """Add a prediction's work to the grid's counters: the regression measure of the neighbour search
    (it must not grow with N at a fixed density; ``tests/test_engine.py``)."""
    grid.shape[GI_WORK] += cells
    grid.shape[GI_WORK + 1] += pairs


@leaf
def _walk_from(head, cbuf, nc, s):
    """The cursor at the first particle of the cells ``cbuf[s:nc]`` (``j = -1``: none left)."""
    while s < nc:
        j = head[cbuf[s]]
        if j >= 0:
            return nc, s, j
        s += 1
    return nc, s, -1


@leaf
def walk_cells(grid, c, geo, cbuf, axis, step, t, horizon):
    """Start a walk over the particles of the cells :func:`cell_block` gives for ``c``.

    The one way the core visits cell neighbours: returns a cursor ``(nc, s, j)`` whose ``j`` is
    the first particle (``-1``: there is none), and :func:`walk_next` moves it on::

        nc, s, j = walk_around(grid, c, geo, cbuf)
        while j >= 0:
            ...  # visit j
            nc, s, j = walk_next(grid, cbuf, nc, s, j)

    ``cbuf`` (27 int32) holds the cells during the walk.
    """
    return _start_walk(grid, cbuf, cell_block(grid, c, geo, cbuf, axis, step, t, horizon))


@leaf
def walk_near(grid, c, geo, cbuf, x, y, z, reach):
    """:func:`walk_cells` over the cells of :func:`near_block`."""
    return _start_walk(grid, cbuf, near_block(grid, c, geo, cbuf, x, y, z, reach))


@leaf
def walk_block(grid, c, geo, cbuf, axis, step, reach):
    """:func:`walk_cells` over ``reach`` cells to each side of ``c`` (``axis = -1``), or over the
    layer ``reach`` cells beyond it in direction ``step`` along ``axis`` (the newly adjacent layer
    after a crossing): a big particle's neighbourhood (unsheared boxes only). ``cbuf`` holds
    :func:`cells_buffer_size` cells."""
    return _start_walk(grid, cbuf, _plain_block(geo, cbuf, _block_frame(grid, c, axis, step, reach), NO_GAPS, INF))


@leaf
def walk_reach(grid, c, geo, cbuf, r):
    """:func:`walk_around` ``c``, or in a grid with big particles the :func:`reach_of` cells around
    it that a particle of radius ``r`` scans (:func:`walk_block`; follow it with every big,
    :func:`next_or_big`)."""
    if grid.shape[GI_BIGS] == 0:
        return walk_around(grid, c, geo, cbuf)
    return walk_block(grid, c, geo, cbuf, np.int64(-1), np.int64(0), reach_of(grid, r))


@leaf
def _start_walk(grid, cbuf, nc):
    head = grid.head
    for s in range(nc):  # the cells' heads loading at once (large N: none is in a cache)
        prefetch(head, cbuf[s])
    return _walk_from(head, cbuf, nc, 0)


@leaf
def walk_around(grid, c, geo, cbuf):
    """:func:`walk_cells` over the full neighbourhood of ``c`` (itself included)."""
    return walk_cells(grid, c, geo, cbuf, np.int64(-1), np.int64(0), 0.0, INF)


@leaf
def prefetch_firsts(grid, cbuf, nc, s, rows):
    """Start loading ``rows[h]`` and the link of the first particle ``h`` of each cell of a walk
    (the cursor ``nc, s`` of :func:`walk_cells`), from :data:`PREFETCH_ROWS_FROM` particles on:
    a walk then finds the cells' chains arriving together (+14 % at N = 1e6, eta = 0.3, cells;
    small systems, whose rows are in the caches, lose 15 % to it)."""
    if grid.link.shape[0] >= PREFETCH_ROWS_FROM:
        for k in range(s, nc):
            h = grid.head[cbuf[k]]
            if h >= 0:
                prefetch(rows, h)
                prefetch(grid.link, h)


@leaf
def walk_next(grid, cbuf, nc, s, j):
    """The cursor after particle ``j`` (see :func:`walk_cells`)."""
    k = grid.link[j]
    if k >= 0:
        return nc, s, k
    return _walk_from(grid.head, cbuf, nc, s + 1)


@leaf
def next_or_big(grid, cbuf, nc, s, j, b):
    """The next particle of a walk (:func:`walk_cells`; cursor ``nc, s, j``) and, once it ends, of
    every big particle (``b``: the bigs visited so far). Returns ``(k, nc, s, j, b)``: the particle
    (``-1``: none left) and the moved cursor; ``k`` came from the walk when ``j >= 0`` before the call::

        b = 0
        while True:
            k, nc, s, j, b = next_or_big(grid, cbuf, nc, s, j, b)
            if k < 0:
                break
    """
    if j >= 0:
        nc2, s2, j2 = walk_next(grid, cbuf, nc, s, j)
        return np.int64(j), nc2, s2, j2, b
    if b < grid.shape[GI_BIGS]:
        return np.int64(grid.head[cell_count(grid) + b]), nc, s, j, b + 1
    return np.int64(-1), nc, s, j, b


@leaf
def crossing_time(x, v, g, c_axis, nc, length, cell_len, periodic):
    """Time and face (0 lower, 1 upper) of the next crossing out of cell ``c_axis`` on one axis.

    physics.md §1.4: both faces treated as planes of zero radius with the cancellation-free
    gap roots of §1.3. Faces on the box edge of an open axis are not crossings (walls are).
    Without gravity on the axis only the face ahead can be reached, at the gap over the speed
    (``0`` for a round-off gap behind it), chosen by selects: the branches of the two roots on
    the velocity's sign are a coin toss per crossing. The same numbers as :func:`.predict.gap_time`.
    """
    if nc == 1:
        return INF, 0
    lo = -0.5 * length + c_axis * cell_len
    if g == 0.0:  # (the same every call of a run: predicted)
        up = v > 0.0
        gap = lo + cell_len - x if up else x - lo
        face_is_crossed = periodic or (c_axis < nc - 1 if up else c_axis > 0)
        t = (gap if gap > 0.0 else 0.0) / abs(v) if face_is_crossed and v != 0.0 else INF
        return t, np.int64(up)
    t_up = INF
    t_lo = INF
    if periodic or c_axis < nc - 1:
        t_up = gap_time(lo + cell_len - x, -v, -g)
    if periodic or c_axis > 0:
        t_lo = gap_time(x - lo, v, g)
    if t_up <= t_lo:
        return t_up, 1
    return t_lo, 0
