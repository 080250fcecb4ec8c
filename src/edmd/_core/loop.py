"""The event loop (Lubachevsky's scheme, physics.md §1.5) and whole-system set-up.

Each particle holds two candidate events:

* a **pair event** ``(pair_t, pair_j, pair_c)``: earliest predicted contact, the partner and
  the partner's event counter at prediction time. It is valid iff ``count[pair_j] == pair_c``.
  A stale one is kept as a placeholder: no other pair of that particle can be earlier, so when
  it comes up the particle is simply re-predicted.
* an **aux event** ``(aux_t, aux_k)``: a single-particle event (shell exit or cell crossing;
  walls and eMD* B events use the same slot) that depends only on the particle's own flight.

The calendar key of the particle is ``min(pair_t, aux_t)`` (aux first at equal times).
Particles are streamed lazily: only those taking part in an event are advanced.

Array bundles are named tuples of :mod:`.bundles` (no objects): ``part`` (:class:`.Particles`),
``ev`` (:class:`.Events`), ``q`` (:class:`.Calendar`), ``grid`` (:class:`.Grid`), ``lists``
(:class:`.Lists`), ``emd`` (:class:`.EMDStarData`); ``geo`` is a tuple of floats
(:func:`.layout.make_geo`).
"""

from typing import Callable, NamedTuple

import numpy as np
from .jit import hot, jit

from . import layout as L
from .layout import CONTACT_DISCARDED, CONTACT_INSTANT, CONTACT_LIST_FULL, CONTACT_SOFT, NB_LIST, NORMAL_SOFT, NORMAL_VISCO, TANGENT_SMOOTH
from .bath import bath_event
from .cells import bin_all, cell_insert, cell_of_point, cell_remove, crossing_time, walk_around, walk_cells, walk_next
from .collide import collide_pair, collide_wall
from .forcing import white_noise_kick
from .emdstar import contact_map, execute_b, is_pending, relocation_blocked
from .nblist import SQRT3, build_lists, rebuild_list, shell_exit_time
from .predict import INF, advance, contact_time, flight, gap_time, relative_to, separation, wrap3
from .queue import queue_top, queue_update


@hot
def _set_pair(ev, count, i, t, j):
    ev.pair_t[i] = t
    ev.pair_j[i] = j
    ev.pair_c[i] = count[j]


@hot
def _closer(xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, best, bj):
    """The earlier of the current best ``(dt, partner)`` and a contact with ``j``."""
    dx, dy, dz, gx, gy, gz = relative_to(xi, yi, zi, vxi, vyi, vzi, P, j, t, geo)
    dt = contact_time(dx, dy, dz, gx, gy, gz, ri + P[j, L.R])
    if dt < best:
        return dt, j
    return best, bj


@jit
def _scan_cells(i, t, P, count, ev, grid, geo, cbuf, axis, step):
    """Improve the pair event of ``i`` with the particles of a block of cells (see ``cell_block``)."""
    xi, yi, zi, vxi, vyi, vzi = flight(P, i, t, geo)
    ri = P[i, L.R]
    best = ev.pair_t[i] - t
    bj = -1
    nc, s, j = walk_cells(grid, grid.cell[i], geo, cbuf, axis, step)
    while j >= 0:
        if j != i:
            best, bj = _closer(xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, best, bj)
        nc, s, j = walk_next(grid, cbuf, nc, s, j)
    if bj >= 0:
        _set_pair(ev, count, i, t + best, bj)


@hot
def predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf):
    """Full re-prediction of the earliest contact of ``i`` (neighbour list or 3^d cells)."""
    if mode == NB_LIST:
        nbl, nbl_n = lists.members, lists.size
        xi, yi, zi, vxi, vyi, vzi = flight(P, i, t, geo)
        ri = P[i, L.R]
        best = INF
        bj = -1
        for s in range(nbl_n[i]):
            best, bj = _closer(xi, yi, zi, vxi, vyi, vzi, ri, P, nbl[i, s], t, geo, best, bj)
        if bj >= 0:
            _set_pair(ev, count, i, t + best, bj)
            return
    ev.pair_t[i] = INF
    ev.pair_j[i] = -1
    if mode != NB_LIST:
        _scan_cells(i, t, P, count, ev, grid, geo, cbuf, np.int64(-1), np.int64(0))


@jit
def _crossing_event(i, t, P, ev, grid, geo):
    """Earliest cell-face crossing of ``i`` (physics.md §1.4)."""
    gi, gf = grid.shape, grid.size
    c = grid.cell[i]
    ncy, ncz = gi[1], gi[2]
    coords = (c // (ncy * ncz), (c // ncz) % ncy, c % ncz)
    xs = flight(P, i, t, geo)
    best = INF
    kind = L.AUX_NONE
    for k in range(3):
        tk, face = crossing_time(xs[k], xs[3 + k], geo[L.G_GX + k], coords[k], gi[k], geo[k], gf[k], geo[3 + k] < INF)
        if tk < best:
            best = tk
            kind = L.AUX_CELL + 2 * k + face
    ev.aux_t[i] = t + best
    ev.aux_k[i] = kind


@hot
def _wall_event(i, t, P, geo, walls, best, kind):
    """Improve ``(best, kind)`` with the earliest wall contact of ``i`` (physics.md §1.3)."""
    xs = flight(P, i, t, geo)
    r = P[i, L.R]
    for k in range(3):
        if walls & (1 << k):
            x, v, g, half = xs[k], xs[3 + k], geo[L.G_GX + k], 0.5 * geo[k]
            tk = gap_time(x + half - r, v, g)
            if tk < best:
                best, kind = tk, L.AUX_WALL + 2 * k
            tk = gap_time(half - x - r, -v, -g)
            if tk < best:
                best, kind = tk, L.AUX_WALL + 2 * k + 1
    return best, kind


@hot
def predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t):
    """Earliest single-particle event of ``i``: shell exit (lists) or cell crossing (cells), a wall
    (when ``walls``; ``wall_axes`` has bit ``k`` set for axis ``k``), its eMD* B event (``ptb``,
    when ``emd_on``) or its Andersen bath event (``bath_t``, when ``bath_on``)."""
    if mode == NB_LIST:
        ev.aux_t[i] = shell_exit_time(P, i, t, lists, geo, skin)
        ev.aux_k[i] = L.AUX_SHELL
    else:
        _crossing_event(i, t, P, ev, grid, geo)
    if walls:
        best, kind = _wall_event(i, t, P, geo, wall_axes, ev.aux_t[i] - t, ev.aux_k[i])
        ev.aux_t[i] = t + best
        ev.aux_k[i] = kind
    if emd_on and ptb[i] < ev.aux_t[i]:  # (hard spheres never touch ptb: no cache miss)
        ev.aux_t[i] = ptb[i]
        ev.aux_k[i] = L.AUX_B
    if bath_on and bath_t[i] < ev.aux_t[i]:
        ev.aux_t[i] = bath_t[i]
        ev.aux_k[i] = L.AUX_BATH


@hot
def _requeue(q, ev, i):
    a = ev.aux_t[i]
    p = ev.pair_t[i]
    queue_update(q, i, a if a <= p else p)


@hot
def _bad_contact(p, k, t, P, geo, tol, acc, cnt, exact):
    """Record ``(p, k)`` if they overlap (or, with ``exact``, do not touch) beyond ``tol``."""
    dx, dy, dz, gx, gy, gz = separation(P, p, k, t, geo)
    err = 1.0 - np.sqrt(dx * dx + dy * dy + dz * dz) / (P[p, L.R] + P[k, L.R])
    if exact:
        err = abs(err)
    if err > tol:
        cnt[L.C_BAD_I], cnt[L.C_BAD_J], acc[L.A_BAD] = p, k, err
        return True
    return False


@jit
def _debug_check(i, j, t, P, grid, lists, geo, mode, fp, acc, cnt, cbuf, contact_only):
    """Debug mode: the colliding pair touches (|r_ij| = sigma) and neither partner overlaps a candidate.

    ``contact_only`` (eMD*, where partners of soft contacts overlap by design) skips the second test.

    Records the offending pair in ``cnt[C_BAD_I/J]`` and the relative error in ``acc[A_BAD]``.
    """
    tol = fp[L.FP_DEBUG_TOL]
    if _bad_contact(i, j, t, P, geo, tol, acc, cnt, True):
        return False
    if contact_only:
        return True
    for p in (np.int64(i), np.int64(j)):
        if mode == NB_LIST:
            for s in range(lists.size[p]):
                if _bad_contact(p, lists.members[p, s], t, P, geo, tol, acc, cnt, False):
                    return False
        else:
            nc, s, k = walk_around(grid, grid.cell[p], geo, cbuf)
            while k >= 0:
                if k != p and _bad_contact(p, k, t, P, geo, tol, acc, cnt, False):
                    return False
                nc, s, k = walk_next(grid, cbuf, nc, s, k)
    return True


@jit
def _repredict(i, t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, ptb, bath_t):
    """Both candidate events of ``i`` after its flight changed, and its calendar key.

    Compiled once and called (eMD* exception b); the loop inlines the same steps.
    """
    predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf)
    predict_aux(i, t, P, ev, grid, lists, geo, mode, ip[L.IP_WALLS] != 0, ip[L.IP_WALLS], ip[L.IP_EMD] != 0, fp[L.FP_SKIN], ptb, ip[L.IP_BATH] != 0, bath_t)
    _requeue(q, ev, i)


@jit
def _cross_cell(i, t, kind, P, image, count, ev, grid, geo, cbuf):
    """Move ``i`` into the neighbouring cell (by direction, never by flooring) and scan the new layer."""
    gi = grid.shape
    k = (kind - L.AUX_CELL) >> 1
    step = 1 if (kind - L.AUX_CELL) & 1 else -1
    c = grid.cell[i]
    ny, nz = gi[1], gi[2]
    cx, cy, cz = c // (ny * nz), (c // nz) % ny, c % nz
    ck = (cx, cy, cz)[k] + step
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
    _scan_cells(i, t, P, count, ev, grid, geo, cbuf, k, step)


@hot
def _wrap_into_box(P, image, i, geo):
    for k in range(3):
        half = geo[3 + k]
        if half < INF:
            x = P[i, L.X + k]
            if x >= half:
                P[i, L.X + k] = x - geo[k]
                image[i, k] += 1
            elif x < -half:
                P[i, L.X + k] = x + geo[k]
                image[i, k] -= 1


@hot
def integrate_kinetic(acc, t, geo, total_mass):
    r"""Advance the time integral of the translational kinetic energy to ``t``.

    Between events the total momentum only feels gravity, :math:`\mathbf P(\tau) = \mathbf P_0 + M\mathbf G\tau`,
    so :math:`E(\tau) = E_0 + \mathbf G\cdot\mathbf P_0\,\tau + \tfrac12 M G^2\tau^2` is integrated exactly.
    """
    tau = t - acc[L.A_LAST_T]
    gp = geo[L.G_GX] * acc[L.A_PX] + geo[L.G_GY] * acc[L.A_PY] + geo[L.G_GZ] * acc[L.A_PZ]
    mg2 = total_mass * (geo[L.G_GX] ** 2 + geo[L.G_GY] ** 2 + geo[L.G_GZ] ** 2)
    acc[L.A_KE_INT] += acc[L.A_KE] * tau + 0.5 * gp * tau * tau + mg2 * tau * tau * tau / 6.0
    acc[L.A_KE] += gp * tau + 0.5 * mg2 * tau * tau
    for k in range(3):
        acc[L.A_PX + k] += total_mass * geo[L.G_GX + k] * tau
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


@jit
def _rebin(p, t, P, image, grid, lists, geo, mode, fp, cbuf):
    """Keep neighbour structures valid after ``p`` jumped (eMD* relocation, physics.md §1.4, §4.8).

    Cells: re-bin by position. Lists: rebuild the list if ``p`` left the cube inscribed in its
    shell. Returns ``False`` if a list ran out of capacity.
    """
    _wrap_into_box(P, image, p, geo)
    if mode != NB_LIST:
        c = cell_of_point(P[p, L.X], P[p, L.Y], P[p, L.Z], geo, grid)
        if c != grid.cell[p]:
            cell_remove(grid, p)
            cell_insert(grid, p, c)
        return True
    centre = lists.centre
    h = 0.5 * fp[L.FP_SKIN] / SQRT3
    dx, dy, dz = wrap3(P[p, L.X] - centre[p, 0], P[p, L.Y] - centre[p, 1], P[p, L.Z] - centre[p, 2], geo)
    if max(abs(dx), abs(dy), abs(dz)) <= h:
        return True
    return rebuild_list(p, P, grid, lists, geo, fp[L.FP_SKIN], cbuf)


@jit
def _finish_contact(p, i, j, t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd, bath_t):
    """Exception b) (physics.md §4.8): ``p``, still in a soft contact, meets a third body at ``t``.

    Its pending B event is executed now and, with post-collisional communication, that of its
    former partner too (re-predicted here unless it is ``i`` or ``j``, which the caller handles).
    """
    pj = emd.partner
    other = pj[p]
    execute_b(p, t, P, count, emd, geo)
    if ip[L.IP_EMD_COMM] and other != i and other != j and pj[other] == p:
        execute_b(other, t, P, count, emd, geo)
        _repredict(np.int64(other), t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd.pending_until, bath_t)


@jit
def _emd_contact(t, i, j, part, ev, q, grid, lists, geo, mode, fp, ip, acc, cnt, cbuf, emd, bath_t):
    """A pair ``(i, j)`` (streamed to ``t``) reaches contact under eMD* (physics.md §4.8).

    Exception b) first: pending B events of either partner are executed now (and, with
    post-collisional communication, those of their former partners); if the pair no longer
    approaches, the contact is discarded (``CONTACT_DISCARDED``). Then the A event: matrix of restitution,
    relocation unless it would overlap a third particle or a wall (exception a), pending
    increments and B events at ``t + t_c`` (``CONTACT_SOFT``). Exception a), overlapping pairs
    and failed solves fall back to the instantaneous rule with the contact law's central
    :math:`e_n(v_n)` (``CONTACT_INSTANT``). ``CONTACT_LIST_FULL`` if a neighbour list ran out of
    capacity.
    """
    P, mass, omega, inertia, image, count, tlast = part
    pdv, ptb, pj = emd.pending_dv, emd.pending_until, emd.partner
    exception_b = is_pending(emd, i) or is_pending(emd, j)
    if exception_b:
        cnt[L.C_EMD_EXC_B] += 1
        for p in (np.int64(i), np.int64(j)):
            if is_pending(emd, p):
                _finish_contact(p, i, j, t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd, bath_t)
    dx, dy, dz, gx, gy, gz = separation(P, i, j, t, geo)
    if exception_b and dx * gx + dy * gy + dz * gz >= 0.0:
        return CONTACT_DISCARDED
    sigma = P[i, L.R] + P[j, L.R]
    if dx * dx + dy * dy + dz * dz < (sigma * (1.0 - 1e-9)) ** 2:
        return CONTACT_INSTANT  # overlapping and approaching: no contact geometry to start from
    tc, lost, vn, vt = contact_map(i, j, P, mass, geo, fp, ip, emd)
    if not tc == tc:
        return CONTACT_INSTANT
    work = emd.work
    walls = ip[L.IP_WALLS]
    if relocation_blocked(i, work[4, 0], work[4, 1], work[4, 2], i, j, t, P, grid, geo, walls, cbuf) or relocation_blocked(
        j, work[5, 0], work[5, 1], work[5, 2], i, j, t, P, grid, geo, walls, cbuf
    ):
        cnt[L.C_EMD_EXC_A] += 1
        return CONTACT_INSTANT
    jn = 0.0  # virial r_ij . J with the impulse J on i over the whole contact
    for k in range(3):
        jk = mass[i] * (work[6, k] + work[7, k] - P[i, L.VX + k])
        jn += (work[0, k] - work[1, k]) * jk
        P[i, L.X + k] = work[4, k]
        P[j, L.X + k] += work[5, k] - work[1, k]  # (in j's own periodic frame)
        P[i, L.VX + k] = work[6, k]
        P[j, L.VX + k] = work[6, k]
        pdv[i, k] = work[7, k]
        pdv[j, k] = work[8, k]
    ptb[i] = t + tc
    ptb[j] = t + tc
    pj[i] = j
    pj[j] = i
    acc[L.A_VIRIAL] += jn
    acc[L.A_KE] -= lost
    acc[L.A_DISSIPATED] += lost
    cnt[L.C_EMD_A] += 1
    acc[L.A_EMD_VN] = vn
    acc[L.A_EMD_VT] = vt
    if not _rebin(i, t, P, image, grid, lists, geo, mode, fp, cbuf):
        return CONTACT_LIST_FULL
    if not _rebin(j, t, P, image, grid, lists, geo, mode, fp, cbuf):
        return CONTACT_LIST_FULL
    return CONTACT_SOFT


class Loop(NamedTuple):
    """One compiled variant of the event loop and its set-up (see :func:`loop_variant`)."""

    run_events: Callable
    setup_events: Callable
    name: str


def variant_name(walls: bool, emd_on: bool, rough: bool, normal: int, debug: bool = False, bath: bool = False, noise: bool = False) -> str:
    """Readable name of a feature set, e.g. ``"walls+rough+viscoelastic"`` (``"plain"``: none).

    Example:
        >>> from edmd._core import layout as L
        >>> variant_name(True, False, True, L.NORMAL_VISCO)
        'walls+rough+viscoelastic'
    """
    parts = [name for name, on in (("walls", walls), ("emdstar", emd_on), ("rough", rough)) if on]
    law = {NORMAL_VISCO: "viscoelastic", NORMAL_SOFT: "soft"}.get(int(normal))
    if law is not None and not emd_on:  # eMD*'s instantaneous fallbacks always use the soft law
        parts.append(law)
    if bath:
        parts.append("bath")
    if noise:
        parts.append("noise")
    if debug:
        parts.append("debug")
    return "+".join(parts) or "plain"


_VARIANTS: dict[tuple, Loop] = {}
_SETUPS: dict[tuple, Callable] = {}


def loop_variant(walls: bool, emd_on: bool, rough: bool, normal: int, debug: bool = False, bath: bool = False, noise: bool = False) -> Loop:
    """The event loop specialised to the physics of a run, compiled (and cached on disk) on first use.

    The features are compile-time constants of the loop (closure variables): Numba prunes the
    branches they decide before type inference, through the inlined helpers too, so a run
    compiles only the collision code of its own rules, and each feature set is a separate entry
    of the on-disk cache (closure values are part of the cache key). The neighbour structure stays
    a run-time choice: its code is in functions compiled once and called.

    Args:
        walls: some axis is closed by walls (which ones: ``ip[IP_WALLS]``); without, no wall code.
        emd_on: eMD* soft contacts (physics.md §4.8) for particle pairs.
        rough: pair collisions have a tangential law (``ip[IP_TANGENT]``); without, the smooth
            rule only (no spin code).
        normal: the normal law of pair collisions (``NORMAL_*``).
        debug: the per-collision checks of debug mode (``_debug_check``).
        bath: the Andersen heat bath's events (:mod:`.bath`).
        noise: white-noise kicks, a global timer in the calendar (:mod:`.forcing`).

    Example:
        >>> from edmd._core import layout as L
        >>> loop = loop_variant(False, False, False, L.NORMAL_CONST)
        >>> loop is loop_variant(False, False, False, L.NORMAL_CONST)
        True
    """
    key = (bool(walls), bool(emd_on), bool(rough), int(normal), bool(debug), bool(bath), bool(noise))
    if key not in _VARIANTS:
        aux = (key[0], key[1], key[5])  # the set-up depends on the single-particle events only
        if aux not in _SETUPS:
            _SETUPS[aux] = _make_setup(*aux)
        _VARIANTS[key] = Loop(_make_loop(*key), _SETUPS[aux], variant_name(*key))
    return _VARIANTS[key]


def _make_loop(walls, emd_on, rough, normal, debug, bath_on, kick_on):
    @jit
    def run_events(part, ev, q, grid, lists, geo, fp, ip, acc, cnt, clog, cbuf, etab, emd, drive, t_stop, max_events):
        """Process events in time order until ``t_stop`` (exclusive) or ``max_events``.

        Returns a status code of :mod:`.layout` (``ST_*``); ``acc[A_NOW]`` holds the time of the
        last processed event. The state is consistent at every return. ``cbuf`` is an int32 scratch
        array of 27 cells (the loop allocates nothing); ``emd`` holds the pending eMD* contacts
        and the matrix-of-restitution table (:mod:`.emdstar`).
        """
        P, mass, omega, inertia, image, count, tlast = part
        ptb = emd.pending_until
        bath_t = drive.bath_t
        n = P.shape[0]
        key = q.key
        mode = ip[L.IP_MODE]
        log_cap = ip[L.IP_LOG_CAP]
        total_mass = fp[L.FP_MTOT]
        skin = fp[L.FP_SKIN]
        wall_axes = ip[L.IP_WALLS]
        done = 0
        while True:
            i = queue_top(q)
            if i < 0:
                return L.ST_IDLE
            t = key[i]
            if t >= t_stop:
                return L.ST_TIME
            if done >= max_events:
                return L.ST_EVENTS
            if t > acc[L.A_NOW]:
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
                white_noise_kick(t, P, mass, count, drive, fp, acc, geo)
                cnt[L.C_KICKS] += 1
                for p in range(n):  # called, not inlined: no predictor copy for a rare global event
                    _repredict(np.int64(p), t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, ptb, bath_t)
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
                cnt[L.C_AUX] += 1
                if emd_on and kind == L.AUX_B:
                    execute_b(i, t, P, count, emd, geo)
                elif walls and kind >= L.AUX_WALL and kind < L.AUX_WALL_END:
                    if emd_on and is_pending(emd, i):  # a wall is a third body too: end the soft contact first
                        cnt[L.C_EMD_EXC_B] += 1
                        _finish_contact(i, i, -1, t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd, bath_t)
                    advance(P, i, t, geo)
                    integrate_kinetic(acc, t, geo, total_mass)
                    collide_wall(t, P, mass, omega, inertia, tlast, i, (kind - L.AUX_WALL) >> 1, (kind - L.AUX_WALL) & 1, fp, ip, etab, acc)
                    count[i] += 1
                    cnt[L.C_WALL] += 1
                elif bath_on and kind == L.AUX_BATH:
                    if emd_on and is_pending(emd, i):  # the bath acts on the committed velocity
                        cnt[L.C_EMD_EXC_B] += 1
                        _finish_contact(i, i, -1, t, P, count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd, bath_t)
                    advance(P, i, t, geo)
                    integrate_kinetic(acc, t, geo, total_mass)
                    bath_event(i, t, P, mass, omega, inertia, count, drive, fp, acc, rough)
                    count[i] += 1
                    cnt[L.C_BATH] += 1
                elif kind == L.AUX_SHELL:  # the particle left the shell of its neighbour list
                    advance(P, i, t, geo)
                    _wrap_into_box(P, image, i, geo)
                    cnt[L.C_REBUILD] += 1
                    if not rebuild_list(i, P, grid, lists, geo, skin, cbuf):
                        return L.ST_LIST_FULL
                elif kind >= L.AUX_CELL and kind < L.AUX_WALL:  # a cell crossing (the most frequent
                    # event of dilute gases): a path of its own
                    _cross_cell(i, t, kind, P, image, count, ev, grid, geo, cbuf)
                    predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t)
                    _requeue(q, ev, i)
                    continue
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
                    if debug and not _debug_check(i, j, t, P, grid, lists, geo, mode, fp, acc, cnt, cbuf, emd_on):
                        return L.ST_OVERLAP
                    advance(P, i, t, geo)
                    advance(P, j, t, geo)
                    integrate_kinetic(acc, t, geo, total_mass)
                    outcome = CONTACT_INSTANT
                    vn = vt = 0.0
                    if emd_on:
                        outcome = _emd_contact(t, i, j, part, ev, q, grid, lists, geo, mode, fp, ip, acc, cnt, cbuf, emd, bath_t)
                        if outcome == CONTACT_LIST_FULL:
                            return L.ST_LIST_FULL
                        if outcome == CONTACT_SOFT:
                            vn, vt = acc[L.A_EMD_VN], acc[L.A_EMD_VT]
                        elif outcome == CONTACT_INSTANT:
                            cnt[L.C_EMD_FALLBACK] += 1
                    if outcome == CONTACT_INSTANT and rough:
                        vn, vt = collide_pair(t, P, mass, omega, inertia, tlast, i, j, geo, fp, ip, etab, acc, cnt, ip[L.IP_TANGENT], normal)
                    elif outcome == CONTACT_INSTANT:
                        vn, vt = collide_pair(t, P, mass, omega, inertia, tlast, i, j, geo, fp, ip, etab, acc, cnt, TANGENT_SMOOTH, normal)
                    count[i] += 1
                    count[j] += 1
                    if outcome != CONTACT_DISCARDED:
                        cnt[L.C_COLL] += 1
                        _log_collision(clog, cnt, log_cap, t, i, j, vn, vt)
                    # a path of its own (as crossings have): a site shared by several event kinds
                    # mixes their branch histories, which cost cell-mode gases 20-30 % (measured)
                    predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf)
                    predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t)
                    _requeue(q, ev, i)
                    predict_pair(j, t, P, count, ev, grid, lists, geo, mode, cbuf)
                    predict_aux(j, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t)
                    _requeue(q, ev, j)
                    continue
            # the shared site of the rare events (every inlined copy of the predictors is compile
            # time of every variant)
            for s in range(nrep):
                p = i if s == 0 else j
                if pair:
                    predict_pair(p, t, P, count, ev, grid, lists, geo, mode, cbuf)
                if aux:
                    predict_aux(p, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, ptb, bath_on, bath_t)
                _requeue(q, ev, p)

    return run_events


def _make_setup(walls, emd_on, bath_on):
    @jit
    def setup_events(part, ev, grid, lists, geo, fp, ip, cbuf, emd, drive, t):
        """Bin every particle (positions or list centres) and predict all events at time ``t``.

        Returns ``False`` if a neighbour list ran out of capacity.
        """
        P = part.rows
        count = part.count
        mode = ip[L.IP_MODE]
        n = P.shape[0]
        skin = fp[L.FP_SKIN]
        wall_axes = ip[L.IP_WALLS]
        if mode == NB_LIST:
            if not build_lists(P, grid, lists, geo, skin, cbuf):
                return False
        else:
            bin_all(P, geo, grid)
        for i in range(n):
            predict_pair(i, t, P, count, ev, grid, lists, geo, mode, cbuf)
            predict_aux(i, t, P, ev, grid, lists, geo, mode, walls, wall_axes, emd_on, skin, emd.pending_until, bath_on, drive.bath_t)
        return True

    return setup_events
