r"""eMD* events of type A and B (physics.md §4.8): the compiled pieces the event loop calls.

A soft contact of particles ``i`` and ``j`` reaching :math:`|\mathbf r_{ij}| = \sigma_{ij}` at
:math:`t_0` becomes one **A event** (relocate the pair about its centre of mass, give both the
centre-of-mass velocity :math:`\mathbf V`, store the post-collisional increments
:math:`\boldsymbol\Delta_{i,j}`) and two **B events** at :math:`t_0 + t_c` (each particle takes
:math:`\mathbf v + \boldsymbol\Delta`). After both B events positions and velocities equal those
of Newton's equations for the soft contact (physics.md §4.6).

Pending contacts live in the bundle ``emd`` (:class:`.bundles.EMDStarData`; short names here):

* ``pdv (N, 3)``: pending increment :math:`\boldsymbol\Delta` (zero when nothing is pending);
* ``ptb (N,)``: local time of the pending B event (``inf``: none);
* ``pj (N,)`` int32: the partner of the pending contact (``-1``: none);
* ``values, tg, ctab, cgeo``: the lookup table of the matrix of restitution (:mod:`.lookup`);
* ``W, K``: scratch of the table lookup and of the direct solver; ``work (11, 3)``: scratch of
  the lab-frame update (rows: ``r1, r2, v1, v2``, then ``r1A, r2A, V, Delta1, Delta2`` and the
  spins after a frictional contact); ``friction``: scratch of the frictional solver;
* ``friction_table, friction_grid``: the hard-limit table of frictional contacts
  (:mod:`.friction_lookup`; no nodes: every frictional contact is solved).

**Frictional contacts** (``ip[IP_EMD_FRICTION]``, docs/physics.md §4.8, §4.11): the A event
takes the relocation, velocities and increments from the frictional two-body solver, and the
spins take their values after the contact at once. Nothing reads a spin between A and B: any
other event of either particle first completes the contact (exception b), so committing the
spins at A is the same dynamics as at B, and the State needs no pending spin.
"""

import math

import numpy as np

from . import layout as L
from .cells import cell_insert, cell_of_point, cell_remove, count_work, next_or_big, walk_reach
from .jit import hot, jit, leaf
from .layout import CONTACT_DISCARDED, CONTACT_INSTANT, CONTACT_LIST_FULL, CONTACT_SOFT, NB_LIST
from .friction_lookup import G_NC, tabled_update
from .lookup import species_restitution
from .nblist import SQRT3, rebuild_list
from .predict import INF, advance, box_shift, flight, pending_contact_time, separation, wrap3
from .schedule import pending_arrays, repredict, set_pair, wrap_into_box
from .stress import committed_current, drift_flux, energy_virial, impulse_tensor, particle_current, particle_energy, virial_tensor
from .twobody import collision_frame, lab_frame_update
from .twobody_friction import frictional_update
from .wallmotion import wall_planes
from .walls import ride_pair_dt


@hot
def is_pending(emd, p):
    """Whether particle ``p`` has a pending B event."""
    return emd.pending_until[p] < INF


@hot
def execute_b(p, t, P, count, emd, geo):
    r"""Event B of ``p`` at time ``t`` (on schedule, or early in exception b): :math:`\mathbf v \leftarrow \mathbf v(t) + \boldsymbol\Delta`.

    The event counter is left alone: predictions made while the contact was pending followed the
    jump (:func:`.predict.pending_contact_time`), so on schedule they stay valid; an early B event
    (:func:`_early_b`) and, in the event loop, the vibrating wall's runs bump it.
    """
    pdv, ptb, pj = emd.pending_dv, emd.pending_until, emd.partner
    advance(P, p, t, geo)
    P[p, L.VX] += pdv[p, 0]
    P[p, L.VY] += pdv[p, 1]
    P[p, L.VZ] += pdv[p, 2]
    pdv[p, 0] = 0.0
    pdv[p, 1] = 0.0
    pdv[p, 2] = 0.0
    ptb[p] = INF
    pj[p] = -1


@leaf
def book_relocation(acc, m, e, at_a, before, delta, v, tc):
    r"""Book in the stress accumulators what an A event's committed velocities do not account for.

    The Helfand moments :math:`\sum_p m_p\mathbf x_p\otimes\mathbf c_p` and :math:`\sum_p\mathbf x_pe_p` of the
    committed velocities :math:`\mathbf c_p = \mathbf V + \boldsymbol\Delta_p` (physics.md §5.6) also grow by the
    relocation :math:`\mathbf x^A_p - \mathbf x_p` at the A event and by the flight with :math:`\mathbf V` instead
    of :math:`\mathbf c_p` until the B event: the displacement :math:`\mathbf x^A_p - \mathbf x_p - \boldsymbol\Delta_pt_c`
    (an early B event gives back its share, :func:`_early_b`). The pair's positions and velocities
    after the contact are those of the two-body solution, so the moments then equal the soft
    system's.
    """
    ax = at_a[0] - before[0] - delta[0] * tc
    ay = at_a[1] - before[1] - delta[1] * tc
    az = at_a[2] - before[2] - delta[2] * tc
    drift_flux(acc, m, e, ax, ay, az, v[0] + delta[0], v[1] + delta[1], v[2] + delta[2])


@jit
def relocation_scan(p, x, y, z, v, i, j, t, P, grid, geo, walls, cbuf, predict, tc, dv, ptb, pdv):
    """Exception a) test: would particle ``p`` moved to ``(x, y, z)`` (as it will be stored) overlap
    a wall or a third particle? And (``predict``), in the same pass, the earliest contact of ``p``
    moving on with velocity ``v`` until its B event after ``tc`` and with ``v + dv`` after it
    (third particles with their own pending B events, ``ptb``, ``pdv``:
    :func:`.predict.pending_contact_time`).

    Candidates are the particles binned in the 3^d cells around the point: cells are at least
    as wide as the largest contact distance plus the list skin (list mode bins list centres,
    which lie within half a skin of the particles), so no overlapping particle is missed; with
    big particles (cells mode, physics.md §1.4) a big's block of :func:`.cells.reach_of` cells
    and every big, as :func:`.schedule.scan_with_bigs` scans.
    ``i`` and ``j`` (the pair itself) are skipped; third particles are taken at time ``t``. A
    third particle that ``p`` already overlaps (its former partner right after exception b,
    still at the residual overlap of their contact) blocks only if the move deepens the overlap.

    Returns ``(blocked, dt, k)``: with ``predict`` (cells mode) ``(dt, k)`` is the pair prediction
    of ``p`` after the A event: the point is wrapped as :func:`rebin` wraps the stored position,
    so the 3^d cells around it are those ``p`` is binned in after the event, and the partner,
    moving with the same ``v``, never meets it. It saves the full re-prediction of both partners
    (list mode predicts over the lists). ``dt`` is meaningless when ``blocked``.
    """
    r = P[p, L.R]
    new = (x, y, z)
    best, bk = INF, -1
    for k in range(3):
        if walls & (1 << k):
            lo, hi = wall_planes(k, t, geo)
            if new[k] - r < lo or new[k] + r > hi:
                return True, best, bk
    x -= box_shift(x, geo[0], geo[3]) * geo[0]  # into the box as wrap_into_box puts the stored position
    y -= box_shift(y, geo[1], geo[4]) * geo[1]
    z -= box_shift(z, geo[2], geo[5]) * geo[2]
    nc, s, q = walk_reach(grid, cell_of_point(x, y, z, geo, grid), geo, cbuf, r)
    tested, b = 0, 0
    while True:
        k, nc, s, q, b = next_or_big(grid, cbuf, nc, s, q, b)
        if k < 0:
            break
        if k != i and k != j:
            kx, ky, kz, kvx, kvy, kvz = flight(P, k, t, geo)
            dx, dy, dz = wrap3(x - kx, y - ky, z - kz, geo)
            sig = r + P[k, L.R]
            d2 = dx * dx + dy * dy + dz * dz
            if d2 < sig * sig:
                ox, oy, oz = wrap3(P[p, L.X] - kx, P[p, L.Y] - ky, P[p, L.Z] - kz, geo)
                if d2 < ox * ox + oy * oy + oz * oz:
                    return True, best, bk
            if predict:
                contact = pending_contact_time(dx, dy, dz, v[0] - kvx, v[1] - kvy, v[2] - kvz, sig, tc, dv[0], dv[1], dv[2], ptb[k] - t, pdv[k, 0], pdv[k, 1], pdv[k, 2])
                dt = ride_pair_dt(p, x, y, z, v[0], v[1], v[2], r, P, k, t, geo, contact)
                if dt < best:
                    best, bk = dt, k
            tested += 1
    count_work(grid, nc, tested)
    return False, best, bk


@leaf
def _set_prediction(ev, count, p, t, dt, k):
    """The pair event of ``p``: a contact with ``k`` after ``dt`` (none: ``k = -1``), as :func:`.schedule.predict_pair` sets it."""
    if k >= 0:
        set_pair(ev, count, p, t + dt, k)
    else:
        ev.pair_t[p] = INF
        ev.pair_j[p] = -1


@leaf
def _dist2(a, b):
    r""":math:`|\mathbf a - \mathbf b|^2` of two rows of three numbers."""
    x, y, z = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return x * x + y * y + z * z


@leaf
def _spin_energy(inertia, w):
    return 0.5 * inertia * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2])


@leaf
def _load_pair(i, j, P, geo, work):
    """Rows 0-3 of ``work``: ``r_i, r_j, v_i, v_j`` (``r_j`` the image closest to ``i``); returns ``(v_n, v_t)``."""
    dx, dy, dz = wrap3(P[j, L.X] - P[i, L.X], P[j, L.Y] - P[i, L.Y], P[j, L.Z] - P[i, L.Z], geo)
    for k in range(3):
        work[0, k] = P[i, L.X + k]
        work[2, k] = P[i, L.VX + k]
        work[3, k] = P[j, L.VX + k]
    work[1, 0] = P[i, L.X] + dx
    work[1, 1] = P[i, L.Y] + dy
    work[1, 2] = P[i, L.Z] + dz
    _ex, _ey, _ez, _fx, _fy, _fz, vn, vt = collision_frame(work[0], work[1], work[2], work[3])
    return vn, vt


@leaf
def _smooth_tables(ip, emd):
    """The tables of the smooth map (:func:`.lookup.species_restitution`): whether to use the table, the table, the pair table."""
    return ip[L.IP_EMD_TABLE] != 0, emd.values, emd.table_grid, emd.central, emd.central_grid, emd.pair_values, emd.pair_grid


@leaf
def smooth_map(i, j, P, mass, geo, fp, ip, emd):
    r"""The A event of the smooth contact ``(i, j)`` (both streamed to it): relocation, velocities, increments.

    Fills ``work[4:9]`` with ``r_iA, r_jA, V, Delta_i, Delta_j`` (``r_jA`` in the periodic image
    closest to ``i``) from the matrix of restitution of physics.md §4.5–§4.7 (the pair tables of
    up to three species, :func:`.lookup.pair_restitution`; else the table, or the direct solver
    outside the table's box or when no table is used) and the update of §4.6.
    Returns ``(t_c, lost, lost, v_n, v_t)``: the contact duration (NaN if the solver failed) and
    the kinetic energy the pair loses (twice: all of it is translational).
    """
    work = emd.work
    vn, vt = _load_pair(i, j, P, geo, work)
    mi, mj = mass[i], mass[j]
    ri, rj = P[i, L.R], P[j, L.R]
    sigma = ri + rj
    mu = mi * mj / (mi + mj)
    phi, d, tc, eps = species_restitution(
        ip[L.IP_EMD_MODEL], fp[L.FP_SOFT_A], fp[L.FP_SOFT_B], mi, mj, ri, rj, vn, vt, *_smooth_tables(ip, emd), fp[L.FP_EMD_RTOL], emd.weights, emd.solver,
    )  # fmt: skip
    if not tc == tc:
        return math.nan, 0.0, 0.0, vn, vt
    vn, vt = lab_frame_update(work[0], work[1], work[2], work[3], mi, mj, sigma, phi, d, eps, work[4:9])
    lost = 0.5 * mu * ((1.0 - eps * eps) * vn * vn + (1.0 - 1.0 / (d * d)) * vt * vt)
    return tc, lost, lost, vn, vt


@jit
def frictional_map(i, j, P, mass, omega, inertia, geo, fp, ip, emd):
    r"""The A event of the frictional contact ``(i, j)`` (both streamed to it), docs/physics.md §4.8, §4.11.

    As :func:`smooth_map`, from the frictional two-body solver
    (:func:`.twobody_friction.frictional_update`), which also fills ``work[9:11]`` with the spins
    after the contact, or, with a hard-limit table in the bundle, from the smooth map and the
    table (:func:`.friction_lookup.tabled_update`; contacts it does not cover are solved).
    Returns ``(t_c, lost, lost_kinetic, v_n, v_t)``: the energy the pair loses (translation and
    rotation) and its translational part.
    """
    work = emd.work
    vn, vt = _load_pair(i, j, P, geo, work)
    mi, mj = mass[i], mass[j]
    model, ca, cb = ip[L.IP_EMD_MODEL], fp[L.FP_SOFT_A], fp[L.FP_SOFT_B]
    law, kt, xt, muf = ip[L.IP_EMD_FRICTION], fp[L.FP_FRICTION_KT], fp[L.FP_FRICTION_XT], fp[L.FP_FRICTION_MU]
    tc = math.nan
    if emd.friction_grid[G_NC] > 0.0:
        smooth = _smooth_tables(ip, emd)
        tc = tabled_update(
            model, ca, cb, law, kt, xt, muf, mi, mj, P[i, L.R], P[j, L.R], inertia[i], inertia[j], work[0], work[1], work[2], work[3],
            omega[i], omega[j], smooth, emd.friction_table, emd.friction_grid, fp[L.FP_EMD_RTOL], emd.weights, emd.solver, work[4:11],
        )  # fmt: skip
    if not tc == tc:
        tc = frictional_update(
            model, ca, cb, law, kt, xt, muf, mi, mj, P[i, L.R], P[j, L.R], inertia[i], inertia[j], work[0], work[1], work[2], work[3],
            omega[i], omega[j], fp[L.FP_EMD_RTOL], emd.friction, work[4:11],
        )  # fmt: skip
    if not tc == tc:
        return math.nan, 0.0, 0.0, vn, vt
    # V is unchanged, so the kinetic energy lost is the relative motion's, mu/2 (|g|^2 - |g'|^2)
    lost_kinetic = 0.5 * mi * mj / (mi + mj) * (_dist2(work[2], work[3]) - _dist2(work[7], work[8]))
    spins = _spin_energy(inertia[i], omega[i]) + _spin_energy(inertia[j], omega[j])
    spins -= _spin_energy(inertia[i], work[9]) + _spin_energy(inertia[j], work[10])
    return tc, lost_kinetic + spins, lost_kinetic, vn, vt


@leaf
def rebin(p, t, P, image, grid, lists, geo, mode, fp, cbuf):
    """Keep neighbour structures valid after ``p`` jumped (eMD* relocation, physics.md §1.4, §4.8).

    Cells: re-bin by position. Lists: rebuild the list if ``p`` left the cube inscribed in its
    shell. Returns ``False`` if a list ran out of capacity.
    """
    wrap_into_box(P, image, p, t, geo)
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
    return rebuild_list(p, P, grid, lists, geo, fp[L.FP_SKIN], 1.0, cbuf) >= 0  # (no square wells with eMD*)


@jit
def finish_contact(p, i, j, t, part, acc, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd, bath_t, pairs):
    """Exception b) (physics.md §4.8): ``p``, still in a soft contact, meets a third body at ``t``.

    Its pending B event is executed now and, with post-collisional communication, that of its
    former partner too (re-predicted here unless it is ``i`` or ``j``, which the caller handles).
    """
    pj = emd.partner
    other = pj[p]
    _early_b(p, t, part, acc, emd, geo)
    if ip[L.IP_EMD_COMM] and other != i and other != j and pj[other] == p:
        _early_b(other, t, part, acc, emd, geo)
        repredict(np.int64(other), t, part.rows, part.count, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd.pending_until, pending_arrays(emd), bath_t, pairs)


@jit
def _early_b(p, t, part, acc, emd, geo):
    r"""The B event of ``p`` early, at ``t`` (exception b). By :math:`\tau = t_B - t` the particle flew
    with the pair's velocity for less than its A event booked in the stress accumulators:
    :func:`.stress.drift_flux` gives back :math:`\boldsymbol\Delta\tau` (see :func:`book_relocation`)."""
    P, mass, omega, inertia, _image, count, _tlast = part
    pdv = emd.pending_dv
    early = emd.pending_until[p] - t
    dx, dy, dz = pdv[p, 0] * early, pdv[p, 1] * early, pdv[p, 2] * early
    execute_b(p, t, P, count, emd, geo)
    count[p] += 1  # (the predictions that followed the jump at t_B are wrong now)
    e = particle_energy(P, mass, omega, inertia, p, omega.shape[0] != 0)
    drift_flux(acc, mass[p], e, dx, dy, dz, P[p, L.VX], P[p, L.VY], P[p, L.VZ])


def _make_emd_contact(frictional):
    """``emd_contact`` for smooth or frictional contacts (a closure constant: a smooth run never compiles the frictional solver)."""

    @leaf
    def emd_contact(t, i, j, part, ev, q, grid, lists, geo, mode, fp, ip, acc, cnt, cbuf, emd, bath_t, pairs):
        """A pair ``(i, j)`` (streamed to ``t``) reaches contact under eMD* (physics.md §4.8).

        Exception b) first: pending B events of either partner are executed now (and, with
        post-collisional communication, those of their former partners); if the pair no longer
        approaches (after those, or after a B event whose time its contact's rounded onto), the
        contact is discarded (``CONTACT_DISCARDED``). Then the A event: the matrix of
        restitution (:func:`smooth_map`) or the frictional solver (:func:`frictional_map`), relocation unless it would overlap a third particle or a wall (exception a), pending
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
                    finish_contact(p, i, j, t, part, acc, ev, q, grid, lists, geo, mode, fp, ip, cbuf, emd, bath_t, pairs)
        dx, dy, dz, gx, gy, gz = separation(P, i, j, t, geo)
        if dx * gx + dy * gy + dz * gz >= 0.0:  # (also a contact predicted just before a kept B event
            return CONTACT_DISCARDED  # whose time rounded onto it: the B event came first)
        sigma = P[i, L.R] + P[j, L.R]
        if dx * dx + dy * dy + dz * dz < (sigma * (1.0 - 1e-9)) ** 2:
            return CONTACT_INSTANT  # overlapping and approaching: no contact geometry to start from
        if frictional:
            tc, lost, lost_kinetic, vn, vt = frictional_map(i, j, P, mass, omega, inertia, geo, fp, ip, emd)
        else:
            tc, lost, lost_kinetic, vn, vt = smooth_map(i, j, P, mass, geo, fp, ip, emd)
        if not tc == tc:
            return CONTACT_INSTANT
        work = emd.work
        walls = ip[L.IP_WALLS]
        cells = mode != NB_LIST
        blocked, dt_i, k_i = relocation_scan(i, work[4, 0], work[4, 1], work[4, 2], work[6], i, j, t, P, grid, geo, walls, cbuf, cells, tc, work[7], ptb, pdv)
        if not blocked:  # (j as it will be stored: in its own periodic frame, see below)
            jx, jy, jz = P[j, L.X] + (work[5, 0] - work[1, 0]), P[j, L.Y] + (work[5, 1] - work[1, 1]), P[j, L.Z] + (work[5, 2] - work[1, 2])
            blocked, dt_j, k_j = relocation_scan(j, jx, jy, jz, work[6], i, j, t, P, grid, geo, walls, cbuf, cells, tc, work[8], ptb, pdv)
        if blocked:
            cnt[L.C_EMD_EXC_A] += 1
            return CONTACT_INSTANT
        jn = 0.0  # virial r_ij . J with the impulse J on i over the whole contact
        ji = (mass[i] * (work[6, 0] + work[7, 0] - P[i, L.VX]), mass[i] * (work[6, 1] + work[7, 1] - P[i, L.VY]), mass[i] * (work[6, 2] + work[7, 2] - P[i, L.VZ]))
        virial_tensor(acc, work[0, 0] - work[1, 0], work[0, 1] - work[1, 1], work[0, 2] - work[1, 2], ji[0], ji[1], ji[2])
        impulse_tensor(acc, 1.0 / mass[i] + 1.0 / mass[j], gx, gy, gz, ji[0], ji[1], ji[2])  # (committed velocities)
        turns = omega.shape[0] != 0  # (e_i holds the spin's energy whenever spins are kept)
        ei0 = particle_current(acc, P, mass, omega, inertia, i, turns, -1.0)
        ej0 = particle_current(acc, P, mass, omega, inertia, j, turns, -1.0)
        for k in range(3):
            jk = ji[k]
            jn += (work[0, k] - work[1, k]) * jk
            P[i, L.X + k] = work[4, k]
            P[j, L.X + k] += work[5, k] - work[1, k]  # (in j's own periodic frame)
            P[i, L.VX + k] = work[6, k]
            P[j, L.VX + k] = work[6, k]
            pdv[i, k] = work[7, k]
            pdv[j, k] = work[8, k]
        if frictional:  # the spins take their values after the contact now (see the module docs)
            for k in range(3):
                omega[i, k] = work[9, k]
                omega[j, k] = work[10, k]
        ei1 = committed_current(acc, mass, omega, inertia, i, work[6], work[7], turns)
        ej1 = committed_current(acc, mass, omega, inertia, j, work[6], work[8], turns)
        energy_virial(acc, work[0, 0] - work[1, 0], work[0, 1] - work[1, 1], work[0, 2] - work[1, 2], ei1 - ei0, ej1 - ej0)
        book_relocation(acc, mass[i], ei1, work[4], work[0], work[7], work[6], tc)
        book_relocation(acc, mass[j], ej1, work[5], work[1], work[8], work[6], tc)
        ptb[i] = t + tc
        ptb[j] = t + tc
        pj[i] = j
        pj[j] = i
        acc[L.A_VIRIAL] += jn
        acc[L.A_KE] -= lost_kinetic
        acc[L.A_DISSIPATED] += lost
        cnt[L.C_EMD_A] += 1
        acc[L.A_EMD_VN] = vn
        acc[L.A_EMD_VT] = vt
        if not rebin(i, t, P, image, grid, lists, geo, mode, fp, cbuf):
            return CONTACT_LIST_FULL
        if not rebin(j, t, P, image, grid, lists, geo, mode, fp, cbuf):
            return CONTACT_LIST_FULL
        if cells:  # the pair predictions of the relocation scans (the loop skips its own)
            _set_prediction(ev, count, i, t, dt_i, k_i)
            _set_prediction(ev, count, j, t, dt_j, k_j)
        return CONTACT_SOFT

    return emd_contact


emd_contact = _make_emd_contact(False)
emd_contact_frictional = _make_emd_contact(True)
