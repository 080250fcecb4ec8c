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

from .jit import jit, leaf

from .cells import GF_RMAX, GF_RMIN, cell_insert, cell_of_point, cell_remove, count_work, prefetch_firsts, walk_near, walk_next
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
def _found_again(nbl, i, kept, j):
    """Whether ``j`` is one of the first ``kept`` entries of ``i``'s list, the old neighbours
    stored as ``~k`` during a rebuild (:func:`rebuild_list`); if so it is restored as ``j``."""
    for s in range(kept):
        if nbl[i, s] == ~j:
            nbl[i, s] = j
            return True
    return False


@leaf
def _forget_departed(nbl, nbl_n, i):
    """Drop ``i`` from the lists of its old neighbours not found again (the entries ``~k`` of its
    list) and close the gaps in its own list, keeping the order of the rest: the neighbours a
    rebuild adds stay the last entries (:func:`rebuild_list`)."""
    kept = 0
    for s in range(nbl_n[i]):
        k = nbl[i, s]
        if k < 0:
            _drop(nbl, nbl_n, ~k, i)
        else:
            nbl[i, kept] = k
            kept += 1
    nbl_n[i] = kept


@leaf
def _link_neighbours(i, P, grid, lists, geo, skin, reach, cbuf, only_higher, kept):
    """Add every ``j`` whose centre is within ``reach * sigma_ij + skin`` of ``c_i`` to both lists
    (``reach``: 1, or a square well's :math:`\\lambda`: its edge is the interaction range).

    With ``only_higher`` only ``j > i`` is considered (initial build, each pair once); lists of
    no columns are only counted (both sizes grow, nothing is stored). The first
    ``kept`` entries of ``i``'s list are its old neighbours as ``~k`` (a rebuild): one found again
    is restored in place, and its own list, which still holds ``i``, is not touched.
    Returns the number of neighbours appended to ``i``'s list (not found again), ``-1`` when a
    list is full.
    """
    nbl, nbl_n, centre = lists.members, lists.size, lists.centre
    cap = nbl.shape[1]
    cx, cy, cz = centre[i, 0], centre[i, 1], centre[i, 2]
    ri = reach * P[i, R] + skin  # (reach 1.0: exactly the sums of hard spheres)
    # a candidate's radius (its row: far in memory at large N) is read only between the bounds
    # of the radii: beyond the largest no partner is listed, within the smallest every one
    near, far = ri + reach * grid.size[GF_RMIN], ri + reach * grid.size[GF_RMAX]
    nc, s, j = walk_near(grid, grid.cell[i], geo, cbuf, cx, cy, cz, far)
    prefetch_firsts(grid, cbuf, nc, s, centre)
    tested = added = 0
    while j >= 0:
        if j != i and (j > i or not only_higher):
            tested += 1
            d2 = listing_distance2(cx - centre[j, 0], cy - centre[j, 1], cz - centre[j, 2], geo)
            if d2 < far * far and (d2 < near * near or d2 < (ri + reach * P[j, R]) ** 2):
                if cap == 0:  # (the counting pass of an initial build: sizes only)
                    nbl_n[i] += 1
                    nbl_n[j] += 1
                elif not _found_again(nbl, i, kept, j):
                    if nbl_n[i] >= cap and kept > 0:  # (the departed still hold slots: free them)
                        _forget_departed(nbl, nbl_n, i)
                        kept = 0
                    ni = nbl_n[i]
                    nj = nbl_n[j]
                    if ni >= cap or nj >= cap:
                        return -1
                    nbl[i, ni] = j
                    nbl_n[i] = ni + 1
                    nbl[j, nj] = i
                    nbl_n[j] = nj + 1
                    added += 1
        nc, s, j = walk_next(grid, cbuf, nc, s, j)
    count_work(grid, nc, tested)
    if kept > 0:  # (a rebuild whose departed still hold slots; an initial build has none)
        _forget_departed(nbl, nbl_n, i)
    return added


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
    """Re-centre the neighbour list of ``i`` at its stored position (streamed and wrapped by the
    caller). Returns how many entries it appended, the last ones of ``i``'s list (``-1``: a list
    is full): every neighbour not listed before (and, if a full row freed its departed mid-walk,
    the old ones found after that)."""
    nbl, nbl_n = lists.members, lists.size
    kept = nbl_n[i]
    for s in range(kept):  # (most stay neighbours: their lists, far in memory, are touched only if not)
        nbl[i, s] = ~nbl[i, s]
    cell_remove(grid, i)
    place_centre(i, P, grid, lists, geo)
    return _link_neighbours(i, P, grid, lists, geo, skin, reach, cbuf, False, kept)


@jit
def build_lists(P, grid, lists, geo, skin, reach, cbuf):
    """Build all neighbour lists from scratch, centred at the stored positions, and record the
    largest and smallest radius in the grid (``Grid.size[GF_RMAX]``, ``[GF_RMIN]``: the radii
    change only at loads, each of which builds the lists). ``False`` when a list is full; lists of
    no columns are counted instead (``lists.size``, then ``False``): the caller sizes them by the
    fullest without a transient of spare columns."""
    head = grid.head
    head[:] = -1
    nbl_n = lists.size
    nbl_n[:] = 0
    n = P.shape[0]
    rmax, rmin = 0.0, INF
    for i in range(n):
        rmax = max(rmax, P[i, R])
        rmin = min(rmin, P[i, R])
    grid.size[GF_RMAX] = rmax
    grid.size[GF_RMIN] = rmin
    for i in range(n):
        place_centre(i, P, grid, lists, geo)
    for i in range(n):
        if _link_neighbours(i, P, grid, lists, geo, skin, reach, cbuf, True, 0) < 0:
            return False
    return lists.members.shape[1] > 0


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
