"""Neighbour lists with a shell, kept symmetric and rebuilt per particle.

Every particle ``i`` owns a list centre :math:`\\mathbf c_i` (its position at its last rebuild)
and may move at most :math:`\\delta = s/2` away from it (``s`` = skin); leaving that shell is an
event. Invariant: ``j`` is in ``i``'s list (and ``i`` in ``j``'s) whenever
:math:`|\\mathbf c_i - \\mathbf c_j| < \\lambda\\sigma_{ij} + s`, so two particles that can touch while
both are inside their shells are always listed (:math:`\\lambda = 1`, or a square well's edge).
Pairs across a sliding Lees-Edwards face are not listed (their images slide by,
:func:`.images.listing_distance2`): predictions find them through the centre grid
(:func:`.schedule.sliding_partners`); a particle is folded back through the face as its image
only at its rebuilds (:func:`.schedule.wrap_into_box`).
A rebuild moves only ``i``'s centre: ``i`` is
removed from its old neighbours' lists and added to its new ones, found through a cell grid over
the centres with cells of edge :math:`\\ge 2\\lambda R_{\\max} + s`.

``lists`` (:class:`.bundles.Lists`, unpacked as ``nbl, nbl_n, centre``): ``nbl[i, :nbl_n[i]]`` are the neighbours of ``i``.
"""

import math

import numpy as np

from .jit import jit, leaf

from .cells import NOT_ACROSS, cell_insert, cell_of_point, cell_remove, count_work, walk_cells, walk_next
from .images import listing_distance2
from .layout import FP_LIST_MARGIN, G_GX, G_GY, G_GZ, G_ON, R, X, Y, Z
from .predict import INF, flight, gap_time, sphere_exit_time, wrap3
from .wells import well_reach


@leaf
def _drop(nbl, nbl_n, owner, i):
    """Remove ``i`` from the list of ``owner`` (swap with the last entry)."""
    n = nbl_n[owner] - 1
    for s in range(n + 1):
        if nbl[owner, s] == i:
            nbl[owner, s] = nbl[owner, n]
            nbl_n[owner] = n
            return


@leaf
def _link_neighbours(i, P, grid, lists, geo, skin, reach, cbuf, only_higher):
    """Add every ``j`` whose centre is within ``reach * sigma_ij + skin`` of ``c_i`` to both lists
    (``reach``: 1, or a square well's :math:`\\lambda`: its edge is the interaction range).

    With ``only_higher`` only ``j > i`` is considered (initial build, each pair once).
    Returns ``False`` when a list is full.
    """
    nbl, nbl_n, centre = lists
    cap = nbl.shape[1]
    cx, cy, cz = centre[i, 0], centre[i, 1], centre[i, 2]
    ri = reach * P[i, R] + skin  # (reach 1.0: exactly the sums of hard spheres)
    nc, s, j = walk_cells(grid, grid.cell[i], geo, cbuf, np.int64(-1), np.int64(0), 0.0, NOT_ACROSS)
    tested = 0
    while j >= 0:
        if j != i and (j > i or not only_higher):
            tested += 1
            lim = ri + reach * P[j, R]
            if listing_distance2(cx - centre[j, 0], cy - centre[j, 1], cz - centre[j, 2], geo) < lim * lim:
                ni = nbl_n[i]
                nj = nbl_n[j]
                if ni >= cap or nj >= cap:
                    return False
                nbl[i, ni] = j
                nbl_n[i] = ni + 1
                nbl[j, nj] = i
                nbl_n[j] = nj + 1
        nc, s, j = walk_next(grid, cbuf, nc, s, j)
    count_work(grid, nc, tested)
    return True


@leaf
def list_reach(fp):
    """The lists' range in units of the contact distance: a square well's edge (:func:`.wells.well_reach`),
    enlarged by ``fp[FP_LIST_MARGIN]`` for growing particles (1.0 for hard spheres)."""
    return well_reach(fp) * (1.0 + fp[FP_LIST_MARGIN])


@leaf
def place_centre(i, P, grid, lists, geo):
    """Put ``i``'s list centre at its stored position and register it in the grid."""
    centre = lists.centre
    centre[i, 0] = P[i, X]
    centre[i, 1] = P[i, Y]
    centre[i, 2] = P[i, Z]
    cell_insert(grid, i, cell_of_point(P[i, X], P[i, Y], P[i, Z], geo, grid))


@jit
def rebuild_list(i, P, grid, lists, geo, skin, reach, cbuf):
    """Re-centre the neighbour list of ``i`` at its stored position (streamed and wrapped by the caller)."""
    nbl, nbl_n, centre = lists
    for s in range(nbl_n[i]):
        _drop(nbl, nbl_n, nbl[i, s], i)
    nbl_n[i] = 0
    cell_remove(grid, i)
    place_centre(i, P, grid, lists, geo)
    return _link_neighbours(i, P, grid, lists, geo, skin, reach, cbuf, False)


@jit
def build_lists(P, grid, lists, geo, skin, reach, cbuf):
    """Build all neighbour lists from scratch, centred at the stored positions."""
    head = grid.head
    head[:] = -1
    nbl_n = lists.size
    nbl_n[:] = 0
    n = P.shape[0]
    for i in range(n):
        place_centre(i, P, grid, lists, geo)
    for i in range(n):
        if not _link_neighbours(i, P, grid, lists, geo, skin, reach, cbuf, True):
            return False
    return True


@leaf
def shell_exit_time(P, i, t, lists, geo, skin):
    r"""Time at which ``i`` leaves its shell: the ball of radius ``skin/2`` around its centre.

    Without gravity the exact exit from the ball (quadratic); with gravity the exit from the
    inscribed cube of half-edge :math:`s/(2\sqrt3)`, whose faces are the parabolic gap roots of
    physics.md §1.3 (the ball test would be a quartic).
    """
    centre = lists.centre
    x, y, z, vx, vy, vz = flight(P, i, t, geo)
    dx, dy, dz = wrap3(x - centre[i, 0], y - centre[i, 1], z - centre[i, 2], geo)
    if geo[G_ON] == 0.0:
        return t + sphere_exit_time(dx, dy, dz, vx, vy, vz, 0.5 * skin)
    h = 0.5 * skin / SQRT3
    best = INF
    for d, v, g in ((dx, vx, geo[G_GX]), (dy, vy, geo[G_GY]), (dz, vz, geo[G_GZ])):
        best = min(best, gap_time(h - d, -v, -g), gap_time(h + d, v, g))
    return t + best


SQRT3 = math.sqrt(3.0)
