"""The event loop (Lubachevsky's scheme, physics.md §1.5) and whole-system set-up.

Each particle holds a pair event and a single-particle event (:mod:`.schedule`); the calendar
(:mod:`.queue`) orders particles by the earlier of the two, and global timers after them
(:mod:`.forcing`). Particles are streamed lazily: only those taking part in an event are
advanced. eMD*'s contact handling is in :mod:`.emdstar`, the bath's in :mod:`.bath`.

Array bundles are named tuples of :mod:`.bundles` (no objects): ``part`` (:class:`.Particles`),
``ev`` (:class:`.Events`), ``q`` (:class:`.Calendar`), ``grid`` (:class:`.Grid`), ``lists``
(:class:`.Lists`), ``emd`` (:class:`.EMDStarData`); ``geo`` is a tuple of floats
(:func:`.layout.make_geo`).
"""

from typing import Callable, NamedTuple

import numpy as np

from . import layout as L
from .bath import bath_event
from .cells import bin_all, next_or_big, walk_reach
from .collide import collide_pair, collide_wall
from .emdstar import emd_contact, emd_contact_frictional, execute_b, finish_contact, is_pending
from .forcing import white_noise_kick
from .jit import hot, jit, leaf
from .layout import CONTACT_DISCARDED, CONTACT_INSTANT, CONTACT_LIST_FULL, CONTACT_GROWN, CONTACT_SOFT, CONTACT_WELL, NB_CELLS, NB_LIST, NORMAL_SOFT, TANGENT_SMOOTH
from .nblist import build_lists, list_reach, rebuild_list
from .predict import advance, separation
from .stress import integrate_sheared
from .wallmotion import free_fall, has_wall, integrate_riding, release, take_off
from .queue import queue_top, queue_update
from .schedule import cross_cell, pending_arrays, predict_added, predict_aux, predict_pair, prefetch_neighbours, repredict, requeue, warm_next, wrap_into_box
from .growth import collide_growing
from .wells import capture_by_distance, well_event, well_reach


@hot
def _bad_contact(p, k, t, P, geo, tol, acc, cnt, exact, scale):
    """Record ``(p, k)`` if they overlap (or, with ``exact``, are not at ``scale`` times their
    contact distance) beyond ``tol``."""
    dx, dy, dz, gx, gy, gz = separation(P, p, k, t, geo)
    err = 1.0 - np.sqrt(dx * dx + dy * dy + dz * dz) / (scale * (P[p, L.R] + P[k, L.R]))
    if exact:
        err = abs(err)
    if err > tol:
        cnt[L.C_BAD_I], cnt[L.C_BAD_J], acc[L.A_BAD] = p, k, err
        return True
    return False


@jit
def _debug_check(i, j, t, P, grid, geo, fp, acc, cnt, cbuf, contact_only, scale, grown):
    """Debug mode: the colliding pair touches (|r_ij| = ``scale`` sigma: 1, a square well's edge,
    or grown radii) and neither partner overlaps a candidate (cores ``grown`` times the stored radii).

    ``contact_only`` (eMD*, where partners of soft contacts overlap by design) skips the second test.

    Records the offending pair in ``cnt[C_BAD_I/J]`` and the relative error in ``acc[A_BAD]``.
    """
    tol = fp[L.FP_DEBUG_TOL]
    if _bad_contact(i, j, t, P, geo, tol, acc, cnt, True, scale):
        return False
    if contact_only:
        return True
    for p in (np.int64(i), np.int64(j)):  # (lists: the grid of centres, a superset of the listed partners)
        nc, s, q = walk_reach(grid, grid.cell[p], geo, cbuf, P[p, L.R])  # (big particles, cells.py: a big's wider block, and every big)
        b = 0
        while True:
            k, nc, s, q, b = next_or_big(grid, cbuf, nc, s, q, b)
            if k < 0:
                break
            if k != p and _bad_contact(p, k, t, P, geo, tol, acc, cnt, False, grown):
                return False
    return True


@hot
def integrate_kinetic(acc, t, geo, total_mass):
    r"""Advance the time integral of the translational kinetic energy to ``t``.

    Between events the total momentum only feels gravity, :math:`\mathbf P(\tau) = \mathbf P_0 + M\mathbf G\tau`,
    so :math:`E(\tau) = E_0 + \mathbf G\cdot\mathbf P_0\,\tau + \tfrac12 M G^2\tau^2` is integrated exactly.
    Particles riding on the vibrating wall move with it instead (:func:`.wallmotion.integrate_riding`);
    in a sheared box the peculiar sums follow the flow (:func:`.stress.integrate_sheared`).
    """
    if integrate_riding(acc, t, geo, total_mass) or integrate_sheared(acc, t, geo):
        return
    free_fall(acc, t - acc[L.A_LAST_T], geo, total_mass, 0, 0.0)
    acc[L.A_LAST_T] = t


@hot
def _log_collision(clog, cnt, log_cap, t, i, j, vn, vt):
    if log_cap > 0:
        r = cnt[L.C_LOG]
        clog[r, 0] = t
        clog[r, 1] = i
        clog[r, 2] = j
        clog[r, 3] = vn
        clog[r, 4] = vt
        cnt[L.C_LOG] = r + 1


#: position of ``geo`` among the arguments of ``run_events`` (its type tells the signatures of a variant apart)
GEO_ARG = 5


class Loop(NamedTuple):
    """One compiled variant of the event loop and its set-up (see :func:`loop_variant`)."""

    run_events: Callable
    setup_events: Callable
    name: str  #: its feature set (:func:`variant_name`)
    neighbours: str  #: ``"lists"`` or ``"cells"``


def variant_name(key: tuple) -> str:
    """Readable name of a feature set (the key of :func:`loop_variant` but the neighbour
    structure: walls, emd_on, rough, normal, bath, noise, well, grow), e.g. ``"walls+rough+soft"``
    (``"plain"``: none; ``soft``: the central restitution of a contact law, e.g. viscoelastic spheres).

    Example:
        >>> from edmd._core import layout as L
        >>> variant_name((True, False, True, L.NORMAL_SOFT, False, False, False, False))
        'walls+rough+soft'
    """
    walls, emd_on, rough, normal, bath, noise, well, grow = key
    parts = [name for name, on in (("walls", walls), ("emdstar", emd_on), ("rough", rough)) if on]
    soft = normal == NORMAL_SOFT and not emd_on  # (eMD*'s instantaneous fallbacks always use the soft law)
    parts += [name for name, on in (("soft", soft), ("bath", bath), ("noise", noise), ("well", well), ("grow", grow)) if on]
    return "+".join(parts) or "plain"


_VARIANTS: dict[tuple, Loop] = {}
_SETUPS: dict[tuple, Callable] = {}


def loop_variant(
    walls: bool,
    emd_on: bool,
    rough: bool,
    normal: int,
    bath: bool = False,
    noise: bool = False,
    well: bool = False,
    grow: bool = False,
    lists: bool = False,
) -> Loop:
    """The event loop specialised to the physics of a run, compiled (and cached on disk) on first use.

    The features are compile-time constants of the loop (closure variables): Numba prunes the
    branches they decide before type inference, through the inlined helpers too, so a run
    compiles only the collision code of its own rules, and each feature set is a separate entry
    of the on-disk cache (closure values are part of the cache key). The neighbour structure is
    one of them too: a cells run never compiles shell exits, a lists run neither cell crossings
    nor their inlined scans, and a list rebuild tests only the neighbours it added
    (:func:`.schedule.predict_added`; its call site in a loop shared by both structures ran
    cell-mode gases 2-5 % slower). The lists, eMD* and rough variants pass their inlined helpers
    the structure as a constant; the other cells variants read it at run time (``ip[IP_MODE]``):
    paired runs measured each form the faster where it is used (the code layout decides:
    plain cells 1.10 for the run-time read, the heat bath 1.02, walls even; eMD* 1.06 and rough
    spheres 1.06 at eta = 0.05 and 1.01 at 0.3 for the constant; benchmarks/README.md).

    Debug mode (``ip[IP_DEBUG]``, one test per collision) is a run-time choice: its check is a
    called function, compiled once, and as a closure flag it gave every variant that a debug run
    used a twin to compile. The set-up (:class:`Loop`'s ``setup_events``) is specialised on the
    single-particle events only and shared by both neighbour structures.

    Args:
        walls: some axis is closed by walls (which ones: ``ip[IP_WALLS]``); without, no wall code.
        emd_on: eMD* soft contacts (physics.md §4.8) for particle pairs.
        rough: pair collisions have a tangential law (``ip[IP_TANGENT]``); without, the smooth
            rule only (no spin code).
        normal: the normal law of pair collisions (``NORMAL_*``).
        bath: the Andersen heat bath's events (:mod:`.bath`).
        noise: white-noise kicks, a global timer in the calendar (:mod:`.forcing`).
        well: square wells, pair events of several kinds with a capture map (:mod:`.wells`;
            neighbour lists only).
        grow: growing radii, Lubachevsky–Stillinger compression (:mod:`.growth`; neighbour lists,
            periodic boxes and smooth constant-restitution rules only).
        lists: neighbour lists (``ip[IP_MODE] == NB_LIST``); else cells.

    Example:
        >>> from edmd._core import layout as L
        >>> loop = loop_variant(False, False, False, L.NORMAL_CONST)
        >>> loop is loop_variant(False, False, False, L.NORMAL_CONST)
        True
    """
    key = (bool(walls), bool(emd_on), bool(rough), int(normal), bool(bath), bool(noise), bool(well), bool(grow), bool(lists))
    if key not in _VARIANTS:
        aux = (key[0], key[1], key[4], key[6], key[7])  # the set-up depends on the single-particle events, wells and growth only
        if aux not in _SETUPS:
            _SETUPS[aux] = _make_setup(*aux)
        _VARIANTS[key] = Loop(_make_loop(*key), _SETUPS[aux], variant_name(key[:-1]), "lists" if lists else "cells")
    return _VARIANTS[key]


@leaf
def _resting_on_wall(i, t_abs, now_abs, ev):
    """Whether the event of ``i`` is a wall collision a few ulps of the clock after the last event:
    a particle at rest on a wall under gravity (the Zeno limit) bounces by round-off, and each
    bounce moves the clock on by ~10 ulps, so the loop's stall count would never grow (the run
    would hang instead of stopping with a collapse)."""
    k = ev.aux_k[i]
    wall = ev.aux_t[i] <= ev.pair_t[i] and k >= L.AUX_WALL and k < L.AUX_WALL_END
    return wall and t_abs - now_abs <= L.STALL_RESOLUTION * t_abs


def _make_loop(walls, emd_on, rough, normal, bath_on, kick_on, well, grow, use_lists):
    @jit
    def run_events(part, ev, q, grid, lists, geo, fp, ip, acc, cnt, clog, cbuf, etab, emd, drive, pairs, t_stop, max_events):
        """Process events in time order until ``t_stop`` (exclusive) or ``max_events``.

        Returns a status code of :mod:`.layout` (``ST_*``); ``acc[A_NOW]`` holds the time of the
        last processed event. The state is consistent at every return. ``cbuf`` is an int32 scratch
        array of 27 cells (the loop allocates nothing); ``emd`` holds the pending eMD* contacts
        and the matrix-of-restitution table (:mod:`.emdstar`), ``pairs`` the square wells' event
        kinds and capture map (:mod:`.wells`).
        """
        P, mass, omega, inertia, image, count, tlast = part
        ptb, pending = emd.pending_until, pending_arrays(emd)
        bath_t = drive.bath_t
        n = P.shape[0]
        key = q.key
        if use_lists:  # (a constant in the lists, eMD* and rough variants, read at run time in the others: see loop_variant)
            mode = NB_LIST
        elif emd_on or rough:
            mode = NB_CELLS
        else:
            mode = ip[L.IP_MODE]
        log_cap = ip[L.IP_LOG_CAP]
        log_walls = log_cap > 0 and ip[L.IP_LOG_WALLS] != 0
        debug = ip[L.IP_DEBUG] != 0
        total_mass = fp[L.FP_MTOT]
        skin = fp[L.FP_SKIN]
        reach = well_reach(fp)
        lists_reach = list_reach(fp)
        rate = fp[L.FP_GROW_LOCAL]
        wall_axes = ip[L.IP_WALLS]
        origin = drive.origin[0]
        done = 0
        while True:
            i = queue_top(q)
            if i < 0:
                return L.ST_IDLE
            warm_next(q, P, count, ev, grid, lists, mode)
            t = key[i]
            if t >= t_stop:
                return L.ST_TIME
            if done >= max_events:
                return L.ST_EVENTS
            if origin + t > origin + acc[L.A_NOW] and not (walls and i < n and _resting_on_wall(i, origin + t, origin + acc[L.A_NOW], ev)):
                # the absolute clock advanced (a local advance below its resolution, left after a
                # resync re-based the clock, does not count)
                cnt[L.C_ZENO_RUN] = 0
            else:
                cnt[L.C_ZENO_RUN] += 1
                if cnt[L.C_ZENO_RUN] > ip[L.IP_MAXSTALL]:
                    return L.ST_STALL
            done += 1
            cnt[L.C_EVENTS] += 1
            acc[L.A_NOW] = t
            if kick_on and i >= n:  # a global timer (calendar entry n + TIMER_KICK): kick everyone
                integrate_kinetic(acc, t, geo, total_mass)
                white_noise_kick(t, P, mass, count, drive, fp, acc, cnt, geo)
                cnt[L.C_KICKS] += 1
                for p in range(n):  # called, not inlined: no predictor copy for a rare global event
                    repredict(np.int64(p), t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, ptb, pending, bath_t, pairs)
                queue_update(q, i, drive.timer_t[L.TIMER_KICK])
                continue
            # the rare events (stale pair events, shell exits, walls, B events) re-predict at the
            # shared site at the end of the loop body. Its shape (a pass over the particles to
            # re-predict, flags, an int64 j) is the one measured fastest: simpler equivalents,
            # which compile to other code layouts, ran cell-mode gases 5-10 % slower
            j = i
            nrep = 1
            pair = True  # re-predict the pair event
            aux = True  # re-predict the single-particle event
            if ev.aux_t[i] <= ev.pair_t[i]:
                kind = ev.aux_k[i]
                if walls and log_walls and cnt[L.C_LOG] >= log_cap and kind >= L.AUX_WALL and kind < L.AUX_WALL_END:
                    cnt[L.C_EVENTS] -= 1
                    return L.ST_LOG_FULL
                cnt[L.C_AUX] += 1
                if emd_on and kind == L.AUX_B:
                    execute_b(i, t, P, count, emd, geo)
                    if has_wall(geo):  # (a rider's contact times follow straight flights: re-predict)
                        count[i] += 1
                    else:  # (its pair predictions followed the jump, physics.md §4.8)
                        pair = False
                elif (walls and kind >= L.AUX_WALL and kind < L.AUX_WALL_END) or (bath_on and kind == L.AUX_BATH):
                    # a wall or the bath changes the particle's velocity: as a third body, it ends a
                    # pending soft contact first (the bath acts on the committed velocity)
                    if emd_on and is_pending(emd, i):
                        cnt[L.C_EMD_EXC_B] += 1
                        finish_contact(i, i, -1, t, part, acc, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd, bath_t, pairs)
                    advance(P, i, t, geo)
                    integrate_kinetic(acc, t, geo, total_mass)
                    release(P, i, mass, acc, geo)  # (a rider on the vibrating wall flies on with its new velocity)
                    if bath_on and kind == L.AUX_BATH:
                        bath_event(i, t, P, mass, omega, inertia, count, drive, fp, acc, rough or ip[L.IP_WALL_TANGENT] != TANGENT_SMOOTH)
                        cnt[L.C_BATH] += 1
                    elif walls:
                        wall = kind - L.AUX_WALL
                        vn, vt = collide_wall(t, P, mass, omega, inertia, tlast, i, wall >> 1, wall & 1, geo, fp, ip, etab, acc, P[i, L.R] * rate if grow else 0.0)
                        cnt[L.C_WALL] += 1
                        if log_walls and vn > 0.0:  # (an impact: the particle approached the wall)
                            _log_collision(clog, cnt, log_cap, t, i, -1 - wall, vn, vt)  # partner -1 - (2 axis + face)
                    count[i] += 1
                elif use_lists and kind == L.AUX_SHELL:  # the particle left the shell of its neighbour list
                    advance(P, i, t, geo)
                    wrap_into_box(P, image, i, t, geo)
                    cnt[L.C_REBUILD] += 1
                    added = rebuild_list(i, P, grid, lists, geo, skin, lists_reach, cbuf)
                    if added < 0:
                        return L.ST_LIST_FULL
                    if not (well or grow):  # (the new neighbours only)
                        predict_added(i, t, P, count, ev, grid, lists, geo, cbuf, skin, added, pending)
                        pair = False
                elif not use_lists and kind >= L.AUX_CELL and kind < L.AUX_WALL:  # a cell crossing (the most frequent
                    # event of dilute gases): a path of its own
                    cross_cell(i, t, kind, P, image, count, ev, grid, geo, cbuf, pending)
                    predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t, grow, rate)
                    requeue(q, ev, i)
                    continue
                elif walls and has_wall(geo) and kind == L.AUX_RIDE:  # a rider takes off the vibrating wall
                    advance(P, i, t, geo)
                    integrate_kinetic(acc, t, geo, total_mass)
                    take_off(P, i, t, mass, acc, geo)
                    count[i] += 1
                else:  # no kind of this variant: a bug, never handled as another kind
                    cnt[L.C_BAD_I], cnt[L.C_BAD_J] = i, kind
                    cnt[L.C_EVENTS] -= 1
                    return L.ST_BAD_EVENT
            else:
                j = np.int64(ev.pair_j[i])  # (one signature of the callees for both partners)
                if count[j] != ev.pair_c[i]:
                    cnt[L.C_STALE] += 1
                    j = i
                    aux = False
                else:
                    if log_cap > 0 and cnt[L.C_LOG] >= log_cap:
                        cnt[L.C_EVENTS] -= 1
                        return L.ST_LOG_FULL
                    edge = False  # a square well's capture, release or bounce
                    if well:
                        edge = pairs.kind[i] != L.PAIR_CORE
                    grown = 1.0 + rate * t if grow else 1.0  # growing radii: sigma(t) / sigma at the load
                    if debug and not _debug_check(i, j, t, P, grid, geo, fp, acc, cnt, cbuf, emd_on, reach if edge else grown, grown):
                        return L.ST_OVERLAP
                    advance(P, i, t, geo)
                    advance(P, j, t, geo)
                    integrate_kinetic(acc, t, geo, total_mass)
                    release(P, i, mass, acc, geo)  # (riders on the vibrating wall fly on from the collision)
                    release(P, j, mass, acc, geo)
                    outcome = CONTACT_INSTANT
                    vn = vt = 0.0
                    if well:
                        if edge:
                            well_event(i, j, pairs.kind[i], P, mass, omega, inertia, pairs, geo, fp, acc, cnt)
                            outcome = CONTACT_WELL
                    if emd_on:
                        if rough:  # (eMD* is rough only with friction: the frictional solver, compiled for these runs only)
                            outcome = emd_contact_frictional(t, i, j, part, ev, q, grid, lists, geo, mode, fp, ip, acc, cnt, cbuf, emd, bath_t, pairs)
                        else:
                            outcome = emd_contact(t, i, j, part, ev, q, grid, lists, geo, mode, fp, ip, acc, cnt, cbuf, emd, bath_t, pairs)
                        if outcome == CONTACT_LIST_FULL:  # (made: counted and logged; the resync predicts)
                            cnt[L.C_COLL] += 1
                            _log_collision(clog, cnt, log_cap, t, i, j, acc[L.A_EMD_VN], acc[L.A_EMD_VT])
                            return L.ST_LIST_FULL
                        if outcome == CONTACT_SOFT:
                            vn, vt = acc[L.A_EMD_VN], acc[L.A_EMD_VT]
                        elif outcome == CONTACT_INSTANT:
                            cnt[L.C_EMD_FALLBACK] += 1
                    if grow:
                        vn = collide_growing(P, mass, omega, inertia, i, j, geo, fp, acc, rate)
                        outcome = CONTACT_GROWN
                    if outcome == CONTACT_INSTANT and rough:
                        vn, vt = collide_pair(t, P, mass, omega, inertia, tlast, i, j, geo, fp, ip, etab, acc, cnt, ip[L.IP_TANGENT], normal)
                    elif outcome == CONTACT_INSTANT:
                        vn, vt = collide_pair(t, P, mass, omega, inertia, tlast, i, j, geo, fp, ip, etab, acc, cnt, TANGENT_SMOOTH, normal)
                    count[i] += 1
                    count[j] += 1
                    if outcome != CONTACT_DISCARDED and outcome != CONTACT_WELL:
                        cnt[L.C_COLL] += 1
                        _log_collision(clog, cnt, log_cap, t, i, j, vn, vt)
                    # a path of its own (as crossings have): a site shared by several event kinds
                    # mixes their branch histories, which cost cell-mode gases 20-30 % (measured).
                    # An eMD* A event in cells mode has predicted both partners' pair events in
                    # its relocation scans (emdstar.relocation_scan)
                    predicted = emd_on and outcome == CONTACT_SOFT and not use_lists
                    if use_lists:  # j's neighbours load while i's are tested
                        prefetch_neighbours(P, lists, j)
                    if not predicted:
                        predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf, pairs, well, reach, grow, rate, skin, pending)
                    predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t, grow, rate)
                    requeue(q, ev, i)
                    if not predicted:
                        predict_pair(j, t, P, count, ev, grid, lists, geo, mode, cbuf, pairs, well, reach, grow, rate, skin, pending)
                    predict_aux(j, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t, grow, rate)
                    requeue(q, ev, j)
                    continue
            # the shared site of the rare events (every inlined copy of the predictors is compile
            # time of every variant)
            for s in range(nrep):
                p = i if s == 0 else j
                if pair:
                    predict_pair(p, t, P, count, ev, grid, lists, geo, mode, cbuf, pairs, well, reach, grow, rate, skin, pending)
                if aux:
                    predict_aux(p, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t, grow, rate)
                requeue(q, ev, p)

    return run_events


def _make_setup(walls, emd_on, bath_on, well, grow):
    @jit
    def setup_events(part, ev, grid, lists, geo, fp, ip, cbuf, emd, drive, pairs, t, derive_captures):
        """Bin every particle (positions or list centres) and predict all events at time ``t``.

        With a square well and ``derive_captures`` (a state without a capture map), every pair
        inside its well's edge is captured first. Returns ``False`` if a neighbour list ran out of
        capacity.
        """
        P = part.rows
        count = part.count
        mode = ip[L.IP_MODE]
        n = P.shape[0]
        skin = fp[L.FP_SKIN]
        reach = well_reach(fp)
        rate = fp[L.FP_GROW_LOCAL]
        wall_axes = ip[L.IP_WALLS]
        ptb, pending = emd.pending_until, pending_arrays(emd)
        if mode == NB_LIST:
            if not build_lists(P, grid, lists, geo, skin, list_reach(fp), cbuf):
                return False
            if well and derive_captures:
                capture_by_distance(P, pairs, lists, geo, reach, t)
        else:
            bin_all(P, geo, grid)
        for i in range(n):
            predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf, pairs, well, reach, grow, rate, skin, pending)
            predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, drive.bath_t, grow, rate)
        return True

    return setup_events
