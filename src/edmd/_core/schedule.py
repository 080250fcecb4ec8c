"""Event prediction and scheduling (physics.md §1.2-§1.5): each particle's two candidate events.

* a **pair event** ``(pair_t, pair_j, pair_c)``: earliest predicted contact, the partner and
  the partner's event counter at prediction time. It is valid iff ``count[pair_j] == pair_c``.
  A stale one is kept as a placeholder: no other pair of that particle can be earlier, so when
  it comes up the particle is simply re-predicted.
* an **aux event** ``(aux_t, aux_k)``: a single-particle event (shell exit or cell crossing;
  walls, eMD* B events and bath events use the same slot) that depends only on the particle's
  own flight.

The calendar key of the particle is ``min(pair_t, aux_t)`` (aux first at equal times). The
``@hot`` predictors are inlined by the loop on its frequent paths; :func:`repredict` is their
called form for rare whole-particle re-predictions (global events, eMD* exception b).
"""

import numpy as np
from numba import types
from numba.extending import overload

from . import layout as L
from .cells import GI_BIGS, cell_coords, cell_insert, cell_of_point, cell_remove, count_work, crossing_time, face_side, next_or_big, prefetch_firsts, reach_of, walk_block, walk_cells, walk_next
from .images import cross_y_face, fold_into_box, sheared, sheared_type
from .jit import hot, jit, leaf
from .layout import NB_LIST
from .nblist import SQRT3, shell_exit_time
from .prefetch import prefetch
from .predict import INF, advance, box_shift, flight, gap_time, pair_contact_time, pending_contact_time, wrap3
from .queue import QI_SIZE, queue_update, warm_bucket
from .wallmotion import vibrating_type, has_wall, is_moving, level_time, ride_axis, ride_end, wall_params
from .walls import moving_wall_time, ride_pair_dt
from .growth import closer_grow
from .wells import closer_well, well_reach


@hot
def set_pair(ev, count, i, t, j):
    ev.pair_t[i] = t
    ev.pair_j[i] = j
    ev.pair_c[i] = count[j]


def pending_arrays(emd):
    """The pending eMD* B events that pair predictions follow: ``(ptb, pdv)`` of the ``emd``
    bundle, or ``None`` in runs without eMD* (whose bundle holds ``pdv`` as a 1-D empty array).
    By its type, not its value: a hard-sphere run compiles predictors that never see them (passed
    as arrays, even unread, they moved the loop's code and cost dilute gases 12-25 %, paired)."""
    if emd.pending_dv.ndim == 1:
        return None
    return emd.pending_until, emd.pending_dv


@overload(pending_arrays, inline="always")
def _pending_arrays_hook(emd):
    if emd.types[emd.fields.index("pending_dv")].ndim == 1:
        return lambda emd: None
    return lambda emd: (emd.pending_until, emd.pending_dv)


def pending_of(i, t, pending):
    """The pending B event of ``i`` seen from ``t`` (:func:`pending_arrays`): its time from now and
    velocity increment (``inf`` and zeros: none)."""
    if pending is None:
        return INF, 0.0, 0.0, 0.0
    ptb, pdv = pending
    return ptb[i] - t, pdv[i, 0], pdv[i, 1], pdv[i, 2]


@overload(pending_of, inline="always")
def _pending_of_hook(i, t, pending):
    if isinstance(pending, types.NoneType):
        return lambda i, t, pending: (INF, 0.0, 0.0, 0.0)
    return lambda i, t, pending: (pending[0][i] - t, pending[1][i, 0], pending[1][i, 1], pending[1][i, 2])


@jit
def _across_b(dx, dy, dz, gx, gy, gz, sigma, t, geo, pend, pending, j):
    x, y, z = wrap3(dx, dy, dz, geo)
    ptb, pdv = pending
    return pending_contact_time(x, y, z, gx, gy, gz, sigma, pend[0], pend[1], pend[2], pend[3], ptb[j] - t, pdv[j, 0], pdv[j, 1], pdv[j, 2])


def contact_across_b(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon, pend, pending, j):
    """:func:`.predict.pair_contact_time` of ``i`` (its pending B event ``pend``, :func:`pending_of`)
    and ``j``; in eMD* runs a pair with a pending B event follows its velocity jumps
    (:func:`.predict.pending_contact_time`; rare: called)."""
    if pending is not None and (pend[0] < INF or pending[0][j] < INF):
        return _across_b(dx, dy, dz, gx, gy, gz, sigma, t, geo, pend, pending, j)
    return pair_contact_time(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon)


@overload(contact_across_b, inline="always")
def _contact_across_b_hook(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon, pend, pending, j):
    if isinstance(pending, types.NoneType):
        return lambda dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon, pend, pending, j: pair_contact_time(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon)

    def across(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon, pend, pending, j):
        if pend[0] < INF or pending[0][j] < INF:
            return _across_b(dx, dy, dz, gx, gy, gz, sigma, t, geo, pend, pending, j)
        return pair_contact_time(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon)

    return across


@hot
def _closer(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, best, bj, pend, pending):
    """The earlier of the current best ``(dt, partner)`` and a contact of ``i`` (at ``x_i`` with
    ``v_i``, radius ``ri``; its pending B event ``pend``, :func:`pending_of`) with ``j`` (with a
    vibrating wall, :func:`.walls.ride_pair_dt`). In eMD* runs a pair with a pending B event
    (``pending``: all particles', :func:`pending_arrays`) follows its velocity jumps (:func:`contact_across_b`)."""
    xj, yj, zj, vxj, vyj, vzj = flight(P, j, t, geo)
    contact = contact_across_b(xi - xj, yi - yj, zi - zj, vxi - vxj, vyi - vyj, vzi - vzj, ri + P[j, L.R], t, geo, best, pend, pending, j)
    dt = ride_pair_dt(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, contact)
    if dt < best:
        return dt, j
    return best, bj


@hot
def _closest_in_walk(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, geo, cbuf, nc, s, j, best, bj, pend, pending):
    """The earlier of ``(best, bj)`` and the contacts of ``i`` with the particles of a walk over
    cells (the cursor ``nc, s, j`` of :func:`.cells.walk_cells`), whose work it counts."""
    tested = 0
    while j >= 0:
        if j != i:
            best, bj = _closer(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, best, bj, pend, pending)
            tested += 1
        nc, s, j = walk_next(grid, cbuf, nc, s, j)
    count_work(grid, nc, tested)
    return best, bj


@leaf
def scan_cells(i, t, P, count, ev, grid, geo, cbuf, axis, step, pending):
    """Improve the pair event of ``i`` with the particles of a block of cells (see ``cell_block``).

    Inlined into the crossings (:func:`cross_cell`), the most frequent event of a dilute gas: a
    call passes the bundles' arrays field by field, which cost cell-mode gases 7 % (measured);
    full predictions call :func:`scan_neighbourhood`.
    """
    xi, yi, zi, vxi, vyi, vzi = flight(P, i, t, geo)
    if grid.shape[GI_BIGS] > 0:  # (a system with big particles: called)
        best, bj = scan_with_bigs(i, xi, yi, zi, vxi, vyi, vzi, P, t, grid, geo, cbuf, axis, step, ev.pair_t[i] - t, pending_of(i, t, pending), pending)
    else:
        nc, s, j = walk_cells(grid, grid.cell[i], geo, cbuf, axis, step, t, sliding_horizon(i, t, P, grid, geo))
        prefetch_firsts(grid, cbuf, nc, s, P)
        best, bj = _closest_in_walk(i, xi, yi, zi, vxi, vyi, vzi, P[i, L.R], P, t, grid, geo, cbuf, nc, s, j, ev.pair_t[i] - t, -1, pending_of(i, t, pending), pending)
    if bj >= 0:
        set_pair(ev, count, i, t + best, bj)


@jit
def scan_with_bigs(i, xi, yi, zi, vxi, vyi, vzi, P, t, grid, geo, cbuf, axis, step, best, pend, pending):
    """:func:`scan_cells` in a grid with big particles (:mod:`.cells`, physics.md §1.4 "Big particles"):
    a big particle walks :func:`.cells.reach_of` cells to each side (a crossing: the layer that far
    ahead), every particle tests every big. Returns the best ``(dt, partner)`` (partner -1: none
    better than ``best``)."""
    ri = P[i, L.R]
    nc, s, j = walk_block(grid, grid.cell[i], geo, cbuf, axis, step, reach_of(grid, ri))
    bj, b, tested = -1, 0, 0
    while True:  # the walk, then the bigs (one inlined copy of the pair test)
        k, nc, s, j, b = next_or_big(grid, cbuf, nc, s, j, b)
        if k < 0:
            break
        if k != i:
            best, bj = _closer(i, xi, yi, zi, vxi, vyi, vzi, ri, P, k, t, geo, best, bj, pend, pending)
            tested += 1
    count_work(grid, nc, tested)
    return best, bj


@jit
def scan_neighbourhood(i, t, P, count, ev, grid, geo, cbuf, pending):
    """:func:`scan_cells` over the full neighbourhood of ``i``'s cell (called: one compiled copy)."""
    scan_cells(i, t, P, count, ev, grid, geo, cbuf, np.int64(-1), np.int64(0), pending)


@leaf
def prefetch_neighbours(P, lists, i):
    """Start loading the rows of all listed neighbours of ``i`` (:mod:`.prefetch`): the pair tests
    then find them arriving together, not one after the other (large N: none is in a cache)."""
    nbl = lists.members
    for s in range(lists.size[i]):
        prefetch(P, nbl[i, s])


@hot
def predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf, pairs, well, reach, grow, rate, skin, pending):
    """Full re-prediction of the earliest contact of ``i`` (neighbour list or 3^d cells; with
    lists in a sheared box, also the partners across the sliding face, :func:`sliding_partners`).

    With a square ``well`` (list mode only; ``reach`` = :math:`\\lambda`), the earliest event of any
    kind with any listed partner, and its kind in ``pairs.kind`` (:func:`.wells.closer_well`). With
    ``grow`` (list mode only), the contacts of radii growing at the local ``rate`` (:func:`.growth.closer_grow`).
    """
    if mode == NB_LIST:
        nbl, nbl_n = lists.members, lists.size
        xi, yi, zi, vxi, vyi, vzi = flight(P, i, t, geo)
        ri = P[i, L.R]
        best = INF
        bj = -1
        bk = L.PAIR_CORE
        count_work(grid, 0, nbl_n[i])
        prefetch_neighbours(P, lists, i)
        pend = pending_of(i, t, pending)
        for s in range(nbl_n[i]):
            if grow:
                best, bj = closer_grow(xi, yi, zi, vxi, vyi, vzi, ri, P, nbl[i, s], t, geo, rate, best, bj)
            elif well:
                best, bj, bk = closer_well(xi, yi, zi, vxi, vyi, vzi, ri, P, pairs, i, nbl[i, s], t, geo, reach, best, bj, bk)
            else:
                best, bj = _closer(i, xi, yi, zi, vxi, vyi, vzi, ri, P, nbl[i, s], t, geo, best, bj, pend, pending)
        best, bj = sliding_partners(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending)
        if bj >= 0:
            set_pair(ev, count, i, t + best, bj)
            if well:
                pairs.kind[i] = bk
            return
    ev.pair_t[i] = INF
    ev.pair_j[i] = -1
    if mode != NB_LIST:
        scan_neighbourhood(i, t, P, count, ev, grid, geo, cbuf, pending)


@jit
def predict_added(i, t, P, count, ev, grid, lists, geo, cbuf, skin, added, pending):
    """Improve the pair event of ``i`` with the ``added`` neighbours its list rebuild gave it (the
    last entries of its list, :func:`.nblist.rebuild_list`) instead of a full :func:`predict_pair`.

    A rebuild leaves every flight as it was, so the contacts with the neighbours kept are still
    covered by the events predicted before (the Lubachevsky invariant, physics.md §1.5), and a new
    contact earlier than ``i``'s event only makes that event earlier. In a sheared box also the
    partners across the sliding face until the new shell's exit (:func:`sliding_partners`).
    Hard-sphere contacts only: square wells and growth set event kinds and re-predict in full.
    Called, not inlined: a shell exit is a rare event.
    """
    nbl, n = lists.members, lists.size[i]
    xi, yi, zi, vxi, vyi, vzi = flight(P, i, t, geo)
    ri = P[i, L.R]
    best, bj = ev.pair_t[i] - t, -1
    pend = pending_of(i, t, pending)
    count_work(grid, 0, added)
    for s in range(n - added, n):
        best, bj = _closer(i, xi, yi, zi, vxi, vyi, vzi, ri, P, nbl[i, s], t, geo, best, bj, pend, pending)
    best, bj = sliding_partners(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending)
    if bj >= 0:
        set_pair(ev, count, i, t + best, bj)


@leaf
def warm_next(q, P, count, ev, grid, lists, mode):
    """Start loading what the next event will read (:mod:`.prefetch`): the particle of the next
    event is one of the calendar heap's two entries below the top (unless the current event
    schedules an earlier one), and its rows are far in memory from the current particle's: its
    rows and event fields, its neighbour list (lists mode) or its cell and cell link (cells mode:
    a crossing first unlinks it), and one entry of the next bucket's list (:func:`.queue.warm_bucket`)."""
    heap = q.heap
    size = q.ints[QI_SIZE]
    n = P.shape[0]
    for c in range(1, 3):
        if c < size:
            k = heap[c]
            if k < n:  # (not a global timer)
                prefetch(P, k)
                prefetch(ev.pair_t, k)
                prefetch(ev.pair_j, k)
                prefetch(ev.pair_c, k)
                prefetch(ev.aux_t, k)
                prefetch(ev.aux_k, k)
                prefetch(count, k)
                prefetch(q.loc, k)
                if mode == NB_LIST:
                    prefetch(lists.members, k)
                    prefetch(lists.size, k)
                else:  # a crossing first finds the particle's cell and unlinks it from it
                    prefetch(grid.cell, k)
                    prefetch(grid.link, k)
    warm_bucket(q)


@hot
def next_crossing(i, t, P, grid, geo):
    """Time until the earliest cell-face crossing of ``i`` (physics.md §1.4) and its aux kind."""
    gi, gf = grid.shape, grid.size
    c = grid.cell[i]
    ncy, ncz = gi[1], gi[2]
    coords = cell_coords(c, ncy, ncz)
    xs = flight(P, i, t, geo)
    best = INF
    kind = L.AUX_NONE
    for k in range(3):
        tk, face = crossing_time(xs[k], xs[3 + k], geo[L.G_GX + k], coords[k], gi[k], geo[k], gf[k], geo[3 + k] < INF)
        if tk < best:
            best = tk
            kind = L.AUX_CELL + 2 * k + face
    return best, kind


@hot
def _crossing_event(i, t, P, ev, grid, geo):
    """Earliest cell-face crossing of ``i`` as its aux event."""
    best, kind = next_crossing(i, t, P, grid, geo)
    ev.aux_t[i] = t + best
    ev.aux_k[i] = kind


@jit
def _sliding_horizon(i, t, P, grid, geo):
    if face_side(grid, grid.cell[i]) == 0:
        return INF
    return next_crossing(i, t, P, grid, geo)[0]


def sliding_horizon(i, t, P, grid, geo):
    """How long the cells that a particle on a sliding face scans across it must cover
    (:func:`.cells.sheared_block`): until its next cell crossing, where it scans them again (a
    change of flight re-predicts it in full). Infinite off the face and in an unsheared box.

    Why it is enough: a pair across the face that meets at :math:`t_c` was scanned by whichever
    partner last crossed a cell or changed its flight before :math:`t_c`, with a horizon beyond
    :math:`t_c`, and the other partner stayed in its cell meanwhile.
    """
    return _sliding_horizon(i, t, P, grid, geo) if sheared(geo) else INF


@overload(sliding_horizon, inline="always")
def _sliding_horizon_hook(i, t, P, grid, geo):
    if sheared_type(geo):
        return lambda i, t, P, grid, geo: _sliding_horizon(i, t, P, grid, geo)
    return lambda i, t, P, grid, geo: INF


@jit
def _sliding_partners(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending):
    side = face_side(grid, grid.cell[i])
    if grid.shape[1] < 3:  # a single row is also the row across: all of it (listed partners again, harmlessly)
        nc, s, j = walk_cells(grid, grid.cell[i], geo, cbuf, np.int64(-1), np.int64(0), t, INF)
    elif side != 0:  # the row across only
        horizon = shell_exit_time(P, i, t, lists, geo, skin) - t
        nc, s, j = walk_cells(grid, grid.cell[i], geo, cbuf, np.int64(1), np.int64(side), t, horizon)
    else:
        return best, bj
    return _closest_in_walk(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, geo, cbuf, nc, s, j, best, bj, pend, pending)


def sliding_partners(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending):
    """Improve the earliest contact ``(best, bj)`` of ``i`` (at ``x_i`` with ``v_i``) in list mode
    with the partners across a sliding Lees-Edwards face, which the lists leave out
    (:func:`.images.listing_distance2`): the particles whose list centres lie in the cells of the
    centre grid across the face whose images pass by until ``i`` leaves its shell
    (:func:`.cells.sheared_block`). As for cells (:func:`sliding_horizon`): a pair across the
    face that meets at :math:`t_c` was predicted by whichever partner last rebuilt its list or
    changed its flight before :math:`t_c`, and the other stayed within its shell meanwhile. Nothing
    in an unsheared box, or when the centre is off the face. Hard-sphere contacts only (shear
    refuses square wells and growth, whose event kinds this does not set), with the free-flight
    shell of :func:`.nblist.shell_exit_time` (shear refuses gravity and the vibrating wall).
    """
    if sheared(geo):
        return _sliding_partners(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending)
    return best, bj


@overload(sliding_partners, inline="always")
def _sliding_partners_hook(i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending):
    if sheared_type(geo):
        return lambda i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending: _sliding_partners(
            i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending
        )
    return lambda i, xi, yi, zi, vxi, vyi, vzi, ri, P, t, grid, lists, geo, cbuf, skin, best, bj, pend, pending: (best, bj)


@hot
def _wall_event(i, t, P, geo, walls, best, kind, grow, rate):
    """Improve ``(best, kind)`` with the earliest wall contact of ``i`` (physics.md §1.3; the
    vibrating wall: §1.6, :mod:`.walls`; with ``grow``, a radius growing at the local ``rate``,
    §1.7, closes the gap :math:`R_0\\gamma` faster)."""
    xs = flight(P, i, t, geo)
    r0 = P[i, L.R]
    r = r0 * (1.0 + rate * t) if grow else r0
    for k in range(3):
        if walls & (1 << k):
            x, v, g, half = xs[k], xs[3 + k], geo[L.G_GX + k], 0.5 * geo[k]
            for face in range(2):
                sign = 1.0 if face == 0 else -1.0  # along the wall's inward normal
                h = half + sign * x - r
                if is_moving(k, face, geo):  # (called: the vibrating wall's search is not inlined)
                    tk = moving_wall_time(h, sign * v, sign * g, t, geo, best)
                elif grow:
                    tk = gap_time(h, sign * v - r0 * rate, sign * g)
                else:
                    tk = gap_time(h, sign * v, sign * g)
                if tk < best:
                    best, kind = tk, L.AUX_WALL + 2 * k + face
    return best, kind


@hot
def predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t, grow, rate):
    """Earliest single-particle event of ``i``: shell exit (lists) or cell crossing (cells), a wall
    (when ``walls``; ``wall_axes`` has bit ``k`` set for axis ``k``; with ``grow``, radii growing at
    the local ``rate``), its eMD* B event (``ptb``, when ``emd_on``) or its Andersen bath event
    (``bath_t``, when ``bath_on``)."""
    if ride_aux(i, t, P, ev, grid, lists, geo, mode, skin):
        wall_axes = wall_axes & ~(1 << int(wall_params(geo)[0]))  # (a rider cannot reach the opposite wall)
    elif mode == NB_LIST:
        ev.aux_t[i] = shell_exit_time(P, i, t, lists, geo, skin)
        ev.aux_k[i] = L.AUX_SHELL
    else:
        _crossing_event(i, t, P, ev, grid, geo)
    if walls:
        best, kind = _wall_event(i, t, P, geo, wall_axes, ev.aux_t[i] - t, ev.aux_k[i], grow, rate)
        ev.aux_t[i] = t + best
        ev.aux_k[i] = kind
    if emd_on and ptb[i] < ev.aux_t[i]:  # (hard spheres never touch ptb: no cache miss)
        ev.aux_t[i] = ptb[i]
        ev.aux_k[i] = L.AUX_B
    if bath_on and bath_t[i] < ev.aux_t[i]:
        ev.aux_t[i] = bath_t[i]
        ev.aux_k[i] = L.AUX_BATH


def ride_aux(i, t, P, ev, grid, lists, geo, mode, skin):
    """If ``i`` rides on the vibrating wall, its single-particle events but the walls
    (:func:`ride_events`), and ``True``; ``False`` otherwise."""
    if has_wall(geo) and P.shape[1] > L.ROW and P[i, L.RIDE] != 0.0:
        ride_events(i, t, P, ev, grid, lists, geo, mode, skin)
        return True
    return False


@overload(ride_aux, inline="always")
def _ride_aux_hook(i, t, P, ev, grid, lists, geo, mode, skin):
    if not vibrating_type(geo):
        return lambda i, t, P, ev, grid, lists, geo, mode, skin: False

    def impl(i, t, P, ev, grid, lists, geo, mode, skin):
        if P.shape[1] > L.ROW and P[i, L.RIDE] != 0.0:
            ride_events(i, t, P, ev, grid, lists, geo, mode, skin)
            return True
        return False

    return impl


@jit
def ride_events(i, t, P, ev, grid, lists, geo, mode, skin):
    """The earliest of the single-particle events of ``i`` riding on the vibrating wall but its
    walls: the take-off (:func:`.wallmotion.ride_end`) and its shell exit or cell crossing
    (physics.md §1.6.3). Along the wall's axis the rider moves with the wall, so it reaches a
    plane when the wall's displacement reaches a level (:func:`.wallmotion.level_time`); across
    it, in free flight (the shell: its inscribed cube, as with gravity)."""
    k, sign, _gn = ride_axis(geo)
    xs = flight(P, i, t, geo)
    base = -sign * 0.5 * geo[k] + sign * P[i, L.R]  # the rider's coordinate is base + sign * d
    best, kind = ride_end(t, geo) - t, L.AUX_RIDE
    if mode == NB_LIST:
        centre = lists.centre
        h = 0.5 * skin / SQRT3
        dd = wrap3(xs[0] - centre[i, 0], xs[1] - centre[i, 1], xs[2] - centre[i, 2], geo)
        for m in range(3):
            if abs(dd[m]) >= h:  # outside the cube (it stuck where a ball without gravity let it be): rebuild now
                tm = 0.0
            elif m == k:
                tm = min(level_time(sign * (centre[i, m] + h - base), t, geo), level_time(sign * (centre[i, m] - h - base), t, geo))
            else:
                tm = min(gap_time(h - dd[m], -xs[3 + m], -geo[L.G_GX + m]), gap_time(h + dd[m], xs[3 + m], geo[L.G_GX + m]))
            if tm < best:
                best, kind = tm, L.AUX_SHELL
    else:
        gi, gf = grid.shape, grid.size
        c = grid.cell[i]
        coords = cell_coords(c, gi[1], gi[2])
        for m in range(3):
            if m == k:
                lo = -0.5 * geo[m] + coords[m] * gf[m]
                for face in range(2):
                    inner = coords[m] < gi[m] - 1 if face == 1 else coords[m] > 0
                    if gi[m] > 1 and inner:
                        tm = level_time(sign * (lo + face * gf[m] - base), t, geo)
                        if tm < best:
                            best, kind = tm, L.AUX_CELL + 2 * m + face
            else:
                tm, face = crossing_time(xs[m], xs[3 + m], geo[L.G_GX + m], coords[m], gi[m], geo[m], gf[m], geo[3 + m] < INF)
                if tm < best:
                    best, kind = tm, L.AUX_CELL + 2 * m + face
    ev.aux_t[i] = t + best
    ev.aux_k[i] = kind


@hot
def requeue(q, ev, i):
    a = ev.aux_t[i]
    p = ev.pair_t[i]
    queue_update(q, i, a if a <= p else p)




@jit
def repredict(i, t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, ptb, pending, bath_t, pairs):
    """Both candidate events of ``i`` after its flight changed, and its calendar key.

    Compiled once and called (eMD* exception b, white-noise kicks); the loop inlines the same steps.
    """
    predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf, pairs, ip[L.IP_WELL] != 0, well_reach(fp), False, 0.0, fp[L.FP_SKIN], pending)
    predict_aux(i, t, P, ev, grid, lists, geo, mode, ip[L.IP_WALLS] != 0, ip[L.IP_WALLS], ip[L.IP_EMD] != 0, fp[L.FP_SKIN], ptb, ip[L.IP_BATH] != 0, bath_t, False, 0.0)
    requeue(q, ev, i)


@hot
def cross_cell(i, t, kind, P, image, count, ev, grid, geo, cbuf, pending):
    """Move ``i`` into the neighbouring cell (by direction, never by flooring) and scan the new layer."""
    gi = grid.shape
    k = (kind - L.AUX_CELL) >> 1
    step = 1 if (kind - L.AUX_CELL) & 1 else -1
    c = grid.cell[i]
    ny, nz = gi[1], gi[2]
    cx, cy, cz = cell_coords(c, ny, nz)
    ck = (cx, cy, cz)[k] + step
    if k == 1 and (ck == gi[1] or ck < 0) and cross_sheared_face(i, t, 1 if ck > 0 else -1, P, image, count, ev, grid, geo, cbuf, pending):
        return
    if ck == gi[k]:
        ck = 0
        P[i, L.X + k] -= geo[k]
        image[i, k] += 1
    elif ck < 0:
        ck = gi[k] - 1
        P[i, L.X + k] += geo[k]
        image[i, k] -= 1
    if k == 0:
        cx = ck
    elif k == 1:
        cy = ck
    else:
        cz = ck
    cell_remove(grid, i)
    cell_insert(grid, i, (cx * ny + cy) * nz + cz)
    scan_cells(i, t, P, count, ev, grid, geo, cbuf, k, step, pending)


@jit
def _cross_sheared_face(i, t, shift, P, image, count, ev, grid, geo, cbuf, pending):
    advance(P, i, t, geo)
    cross_y_face(P, image, i, shift, t, geo)
    ny, nz = grid.shape[1], grid.shape[2]
    c = grid.cell[i]
    cx = cell_of_point(P[i, L.X], 0.0, 0.0, geo, grid) // (ny * nz)
    cell_remove(grid, i)
    cell_insert(grid, i, (cx * ny + (0 if shift > 0 else ny - 1)) * nz + c % nz)
    scan_neighbourhood(i, t, P, count, ev, grid, geo, cbuf, pending)


def cross_sheared_face(i, t, shift, P, image, count, ev, grid, geo, cbuf, pending):
    """A cell crossing of ``i`` through the y face of a sheared box (``shift``: +1 upwards, -1
    downwards): it becomes its image (:func:`.images.cross_y_face`) in the cell of its new x on the
    opposite face and scans its whole new neighbourhood (its x jumped by the offset). Returns
    whether the box is sheared (otherwise nothing is done: a plain periodic crossing)."""
    if sheared(geo):
        _cross_sheared_face(i, t, shift, P, image, count, ev, grid, geo, cbuf, pending)
        return True
    return False


@overload(cross_sheared_face, inline="always")
def _cross_sheared_face_hook(i, t, shift, P, image, count, ev, grid, geo, cbuf, pending):
    if not sheared_type(geo):
        return lambda i, t, shift, P, image, count, ev, grid, geo, cbuf, pending: False

    def impl(i, t, shift, P, image, count, ev, grid, geo, cbuf, pending):
        _cross_sheared_face(i, t, shift, P, image, count, ev, grid, geo, cbuf, pending)
        return True

    return impl


@hot
def wrap_into_box(P, image, i, t, geo):
    """Bring ``i`` (streamed to local time ``t``) back into the box on its periodic axes (through
    a sliding y face as its image, :func:`.images.fold_into_box`)."""
    fold_into_box(P, image, i, t, geo)
    for k in range(3):
        x = P[i, L.X + k]
        shift = box_shift(x, geo[k], geo[3 + k])
        if shift != 0:
            P[i, L.X + k] = x - shift * geo[k]
            image[i, k] += shift
