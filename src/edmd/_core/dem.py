r"""Force-based MD (DEM) of soft spheres/disks: velocity Verlet over a half neighbour list.

Arrays (structure of arrays, ``N`` particles, 2D = 3D with ``z = v_z = 0``): positions ``pos``
(wrapped into the box), velocities ``vel``, accelerations ``acc``, periodic ``image`` counters,
displacements since the last list build ``dsp``, a velocity scratch ``vp``; ``mass``,
``radius``. The neighbour list is a half list: ``nbl[i, :nbl_n[i]]`` holds the ``j > i``
closer than ``R_i + R_j + skin`` at the last build, and ``tch[i, k]`` whether that pair
overlapped at the last force evaluation (to count contact onsets as collisions).

One step of size ``h`` (kick-drift-kick velocity Verlet, second order for smooth forces):

.. math::
    \mathbf v \leftarrow \mathbf v + \tfrac h2\mathbf a,\quad \mathbf r \leftarrow \mathbf r + h\mathbf v,\quad
    \mathbf a \leftarrow \mathbf a(\mathbf r, \mathbf v + \tfrac h2\mathbf a),\quad \mathbf v \leftarrow \mathbf v + \tfrac h2\mathbf a

(the dissipative force sees the velocity extrapolated to the end of the step, which keeps the
scheme second order), plus an impulse correction of the dissipative force in the step in
which a contact begins (:func:`_onset_weight`: the dashpot force jumps at contact onset). Contact forces come from :func:`edmd._core.contact.contact_force`
(clipped at zero: the force-based end of a contact, physics.md §2.2). The list is rebuilt at a
step boundary when the coming drift would take a particle beyond ``skin / 2`` of where the
list was built; then the overlap flags are exactly the geometry's.

Friction (``fric = (law, k_t, x_t, mu)`` with ``law > 0``, docs/physics.md §2.6) adds the
tangential force of :func:`edmd._core.contact.tangential_force`, its torques, and the spins
(bundle :class:`~edmd._core.bundles.Spins`) integrated like the velocities. Each half-list
entry carries its tangential spring, which a list rebuild hands on to the same pair.

Running sums (``sums``): current kinetic energy, elastic energy (with the springs'), virial
:math:`\sum_{\rm pairs} r_{ij}F_{ij}`, dissipated power :math:`\sum (F - F_{\rm el})\dot\xi`,
the power taken by the tangential forces :math:`-\sum\mathbf F_t\cdot\mathbf v_t`, the
springs' energy, and the trapezoidal time integrals of kinetic energy, virial and the two
powers (the tangential dissipation is that work minus the springs' energy).
"""

import math

from .cells import GF_RSMALL, bin_all, next_or_big, walk_around
from .contact import MODEL_HERTZ, contact_force, normal_damping, tangential_force
from .jit import jit, leaf
from .layout import C_COLL, C_EVENTS, C_REBUILD, ST_EVENTS, ST_LIST_FULL
from .predict import wrap3

S_KE, S_U, S_VIR, S_PDISS, S_KE_INT, S_VIR_INT, S_DISS, S_PT, S_WT, S_UT = range(10)
N_SUMS = 10

#: status: a single drift would be longer than half the skin (time step too large)
ST_STEP_TOO_LARGE = 7


@jit
def build_list(pos, radius, geo, grid, skin, nbl, nbl_n, tch, cbuf):
    """Bin the particles and build the half neighbour list with overlap flags.

    In a grid with big particles (:mod:`.cells`, physics.md §1.4 "Big particles"; cells sized
    for the others) a small particle's row also holds the bigs it meets, found by testing every
    big, and a big's row the later bigs: no row holds a big's hundreds of partners.
    Returns ``False`` if a row of ``nbl`` overflows (the caller grows it and retries).
    """
    n = pos.shape[0]
    bin_all(pos, geo, grid)
    cap = nbl.shape[1]
    r_small = grid.size[GF_RSMALL]
    for i in range(n):
        xi, yi, zi, ri = pos[i, 0], pos[i, 1], pos[i, 2], radius[i]
        big = ri > r_small
        m = 0
        nc, s, q = walk_around(grid, grid.cell[i], geo, cbuf)
        b = 0
        while True:
            in_walk = q >= 0
            j, nc, s, q, b = next_or_big(grid, cbuf, nc, s, q, b)
            if j < 0:
                break
            if j > i and not big and radius[j] <= r_small if in_walk else j != i and (j > i or not big):
                dx, dy, dz = wrap3(xi - pos[j, 0], yi - pos[j, 1], zi - pos[j, 2], geo)
                r2 = dx * dx + dy * dy + dz * dz
                sig = ri + radius[j]
                cut = sig + skin
                if r2 < cut * cut:
                    if m >= cap:
                        return False
                    nbl[i, m] = j
                    tch[i, m] = 1 if r2 < sig * sig else 0
                    m += 1
        nbl_n[i] = m
    return True


@leaf
def _onset_weight(model, xi, xi_dot, h):
    r"""Correction of the trapezoidal impulse of the dashpot's dissipative force in the step in which a contact began.

    The contact started :math:`\tau = \xi/\dot\xi` before the end of the step (the approach is
    free flight until then). Velocity Verlet integrates the force as if it rose linearly from
    zero over the whole step. That is right to second order for the elastic part, which
    starts continuously and whose onset error cancels against the mirror-image error where the
    overlap ends (time reversibility), but not for the dashpot's dissipative force, which jumps
    to :math:`F_{\rm d} = \gamma\dot\xi` at onset: its impulse over the step is
    :math:`\tau F_{\rm d}`, not :math:`\tfrac h2F_{\rm d}`, an error of first order in ``h``
    per collision without this correction. (The viscoelastic damping force starts as
    :math:`\sqrt s` and is continuous: no correction; its collisions converge with order ~1.5.)
    The same holds for the tangential force of a dashpot contact (its damping and its Coulomb
    limit jump too). Returns :math:`\tau - h/2`, the weight of the jump in exact minus
    trapezoidal impulse (0 for Hertz).
    """
    if model == MODEL_HERTZ or xi_dot <= 0.0 or h <= 0.0:
        return 0.0
    return min(xi / xi_dot, h) - 0.5 * h


@leaf
def _contact_velocity(vel, om, i, j, li, lj, nx, ny, nz):
    r"""Tangential sliding velocity :math:`\mathbf v_t` of the contact point (lever arms ``li``, ``lj``; docs/physics.md §2.6)."""
    wx = li * om[i, 0] + lj * om[j, 0]
    wy = li * om[i, 1] + lj * om[j, 1]
    wz = li * om[i, 2] + lj * om[j, 2]
    cx = vel[i, 0] - vel[j, 0] - (wy * nz - wz * ny)
    cy = vel[i, 1] - vel[j, 1] - (wz * nx - wx * nz)
    cz = vel[i, 2] - vel[j, 2] - (wx * ny - wy * nx)
    cn = cx * nx + cy * ny + cz * nz
    return cx - cn * nx, cy - cn * ny, cz - cn * nz


@leaf
def _advance_spring(hist, i, k, nx, ny, nz, tx, ty, tz, dt):
    """Rotate the spring ``hist[i, k]`` into the tangent plane of ``n`` (length kept) and extend it by ``t dt``."""
    zx, zy, zz = hist[i, k, 0], hist[i, k, 1], hist[i, k, 2]
    zn = zx * nx + zy * ny + zz * nz
    if zn != 0.0:
        old2 = zx * zx + zy * zy + zz * zz
        zx, zy, zz = zx - zn * nx, zy - zn * ny, zz - zn * nz
        new2 = zx * zx + zy * zy + zz * zz
        s = math.sqrt(old2 / new2) if new2 > 0.0 else 0.0
        zx, zy, zz = zx * s, zy * s, zz * s
    return zx + dt * tx, zy + dt * ty, zz + dt * tz


@leaf
def _torque(out, i, j, si, sj, fx, fy, fz, nx, ny, nz):
    r"""Add the angular accelerations (or increments) :math:`-(\ell/I)\,\hat{\mathbf n}\times\mathbf F` to rows ``i`` and ``j`` of ``out``."""
    cx, cy, cz = ny * fz - nz * fy, nz * fx - nx * fz, nx * fy - ny * fx
    out[i, 0] -= si * cx
    out[i, 1] -= si * cy
    out[i, 2] -= si * cz
    out[j, 0] -= sj * cx
    out[j, 1] -= sj * cy
    out[j, 2] -= sj * cz


@leaf
def _jump(out, i, j, px, py, pz, mi, mj):
    """Add the velocity jumps of the impulse ``p`` on ``i`` (``-p`` on ``j``) to rows ``i`` and ``j`` of ``out``."""
    out[i, 0] += px / mi
    out[i, 1] += py / mi
    out[i, 2] += pz / mi
    out[j, 0] -= px / mj
    out[j, 1] -= py / mj
    out[j, 2] -= pz / mj


@leaf
def _friction(rot, fric, model, ca, cb, vel, vp, mass, i, j, k, ri, rj, reff, xi, xi_dot, fn, nx, ny, nz, onset, h):
    r"""Tangential force of the contact ``(i, j)`` (half-list entry ``k``), its spring advanced over the step ``h``.

    The spring grows with the sliding velocity at the half step (``vel``, ``rot.omega``; from the
    onset, ``xi / xi_dot`` before the end of the step, in the step in which the contact began), the
    damping sees the extrapolated velocities (``vp``, ``rot.omega_p``), as the normal damping does.
    Adds the torques to ``rot.alpha`` and returns ``(Ftx, Fty, Ftz, U_t, P_t)``: the force on ``i``,
    the spring's energy and the power :math:`-\mathbf F_t\cdot\mathbf v_t` taken from the particles.
    """
    law, kt, xt, mu = fric
    li = ri - 0.5 * xi
    lj = rj - 0.5 * xi
    hist = rot.hist
    dt = h
    if onset:
        hist[i, k, 0] = 0.0
        hist[i, k, 1] = 0.0
        hist[i, k, 2] = 0.0
        dt = min(xi / xi_dot, h) if xi_dot > 0.0 else 0.0
    tx, ty, tz = _contact_velocity(vel, rot.omega, i, j, li, lj, nx, ny, nz)
    zx, zy, zz = _advance_spring(hist, i, k, nx, ny, nz, tx, ty, tz, dt)
    ux, uy, uz = _contact_velocity(vp, rot.omega_p, i, j, li, lj, nx, ny, nz)
    eta = normal_damping(model, ca, cb, reff, xi)
    fx, fy, fz, stiff, slides = tangential_force(law, kt, xt, mu, eta, fn, reff, xi, zx, zy, zz, ux, uy, uz)
    if slides and stiff > 0.0:
        e = xt * eta / stiff
        zx, zy, zz = -fx / stiff - e * ux, -fy / stiff - e * uy, -fz / stiff - e * uz
    hist[i, k, 0], hist[i, k, 1], hist[i, k, 2] = zx, zy, zz
    si, sj = li / rot.inertia[i], lj / rot.inertia[j]
    _torque(rot.alpha, i, j, si, sj, fx, fy, fz, nx, ny, nz)
    if onset:  # the jump of a dashpot contact's tangential force (see _onset_weight), applied after the loop
        w = _onset_weight(model, xi, xi_dot, h)
        if w != 0.0:
            _jump(rot.dv, i, j, w * fx, w * fy, w * fz, mass[i], mass[j])
            _torque(rot.dw, i, j, w * si, w * sj, fx, fy, fz, nx, ny, nz)
    return fx, fy, fz, 0.5 * stiff * (zx * zx + zy * zy + zz * zz), -(fx * ux + fy * uy + fz * uz)


@leaf
def _forces(pos, vel, vp, acc, mass, radius, nbl, nbl_n, tch, geo, model, ca, cb, rot, fric, h):
    r"""Add the contact accelerations at ``pos`` with velocities ``vp`` to ``acc`` (holding gravity).

    With friction (``fric[0] > 0``) also the tangential forces, their torques (into
    ``rot.alpha``, zeroed by the caller) and the springs' steps. Returns
    ``(U, virial, P_diss, onsets, P_t, U_t)``: the normal elastic energy, the virial, the normal
    dissipated power, the onsets, the power taken by the tangential forces
    :math:`-\sum\mathbf F_t\cdot\mathbf v_t` and the springs' energy. Contacts that
    began during the step of size ``h`` just taken get the onset correction
    :func:`_onset_weight` (``h = 0``: none, and the springs stay): a velocity jump, added to
    ``vel`` at once in smooth runs (nothing in the loop reads ``vel``), and with friction
    collected in ``rot.dv``, ``rot.dw`` and applied with the step's last kick (:func:`dem_steps`): the
    springs grow with ``vel``, which must then be the same for every pair, whatever its place
    in the loop (a run does not depend on the particles' labels).
    """
    n = pos.shape[0]
    frictional = fric[0] > 0
    u = 0.0
    vir = 0.0
    pd = 0.0
    pt = 0.0
    ut = 0.0
    onsets = 0
    for i in range(n):
        xi, yi, zi, ri, mi = pos[i, 0], pos[i, 1], pos[i, 2], radius[i], mass[i]
        ux, uy, uz = vp[i, 0], vp[i, 1], vp[i, 2]
        fxi = 0.0
        fyi = 0.0
        fzi = 0.0
        for k in range(nbl_n[i]):
            j = nbl[i, k]
            dx, dy, dz = wrap3(xi - pos[j, 0], yi - pos[j, 1], zi - pos[j, 2], geo)
            r2 = dx * dx + dy * dy + dz * dz
            rj = radius[j]
            sig = ri + rj
            if r2 >= sig * sig:
                tch[i, k] = 0
                continue
            r = math.sqrt(r2)
            nx, ny, nz = dx / r, dy / r, dz / r
            xi_dot = -((ux - vp[j, 0]) * nx + (uy - vp[j, 1]) * ny + (uz - vp[j, 2]) * nz)
            reff = ri * rj / sig
            f, f_el, u_el = contact_force(model, ca, cb, reff, sig - r, xi_dot)
            onset = tch[i, k] == 0
            if onset:
                onsets += 1
                tch[i, k] = 1
                dj = _onset_weight(model, sig - r, xi_dot, h) * (f - f_el)
                _jump(rot.dv if frictional else vel, i, j, dj * nx, dj * ny, dj * nz, mi, mass[j])
            u += u_el
            vir += f * r
            pd += (f - f_el) * xi_dot
            fx, fy, fz = f * nx, f * ny, f * nz
            if frictional:
                tx, ty, tz, u_t, p_t = _friction(rot, fric, model, ca, cb, vel, vp, mass, i, j, k, ri, rj, reff, sig - r, xi_dot, f, nx, ny, nz, onset, h)
                fx += tx
                fy += ty
                fz += tz
                ut += u_t
                pt += p_t
            fxi += fx
            fyi += fy
            fzi += fz
            mj = 1.0 / mass[j]
            acc[j, 0] -= fx * mj
            acc[j, 1] -= fy * mj
            acc[j, 2] -= fz * mj
        acc[i, 0] += fxi / mi
        acc[i, 1] += fyi / mi
        acc[i, 2] += fzi / mi
    return u, vir, pd, onsets, pt, ut


@leaf
def _worst_drift(vel, acc, dsp, h):
    """Largest squared displacement since the list build after a drift of ``h`` (``dsp`` not changed)."""
    hh = 0.5 * h
    worst = 0.0
    for i in range(vel.shape[0]):
        d2 = 0.0
        for a in range(3):
            d = dsp[i, a] + h * (vel[i, a] + hh * acc[i, a])
            d2 += d * d
        worst = max(worst, d2)
    return worst


@jit
def carry_springs(rot, nbl, nbl_n):
    """Give each entry of the new list ``nbl`` the spring its pair had in the old list (``rot.nbl_old``; zero if new)."""
    old, old_n, hold, hist = rot.nbl_old, rot.nbl_n_old, rot.hist_old, rot.hist
    for i in range(nbl.shape[0]):
        m = old_n[i]
        for k in range(nbl_n[i]):
            j = nbl[i, k]
            hist[i, k, 0] = 0.0
            hist[i, k, 1] = 0.0
            hist[i, k, 2] = 0.0
            for q in range(m):
                if old[i, q] == j:
                    hist[i, k, 0], hist[i, k, 1], hist[i, k, 2] = hold[i, q, 0], hold[i, q, 1], hold[i, q, 2]
                    break


@leaf
def _rebuild(pos, radius, geo, grid, skin, nbl, nbl_n, tch, rot, frictional, cbuf):
    """Rebuild the list; with friction every pair keeps its spring. ``False`` on overflow (the
    old list and springs are then in ``rot.nbl_old``, ``rot.hist_old`` for the caller's retry)."""
    if frictional:
        for i in range(nbl.shape[0]):
            rot.nbl_n_old[i] = nbl_n[i]
            for k in range(nbl_n[i]):
                rot.nbl_old[i, k] = nbl[i, k]
                for a in range(3):
                    rot.hist_old[i, k, a] = rot.hist[i, k, a]
    if not build_list(pos, radius, geo, grid, skin, nbl, nbl_n, tch, cbuf):
        return False
    if frictional:
        carry_springs(rot, nbl, nbl_n)
    return True


@leaf
def _kick_spins(rot, hh):
    """Half kick of the spins, the extrapolation to the end of the step, and zeroed torques."""
    om, op, al, n = rot.omega, rot.omega_p, rot.alpha, rot.omega.shape[0]
    for i in range(n):
        for a in range(3):
            w = om[i, a] + hh * al[i, a]
            om[i, a] = w
            op[i, a] = w + hh * al[i, a]
            al[i, a] = 0.0


@jit
def dem_setup(pos, vel, acc, vp, dsp, mass, radius, nbl, nbl_n, tch, grid, geo, model, ca, cb, rot, fric, skin, sums, cbuf):
    """Build the list (springs carried from ``rot.nbl_old``) and evaluate forces and sums at the current state; ``False`` on list overflow."""
    if not build_list(pos, radius, geo, grid, skin, nbl, nbl_n, tch, cbuf):
        return False
    frictional = fric[0] > 0
    n = pos.shape[0]
    if frictional:
        carry_springs(rot, nbl, nbl_n)
        for i in range(n):
            for a in range(3):
                rot.omega_p[i, a] = rot.omega[i, a]
                rot.alpha[i, a] = 0.0
    ke = 0.0
    for i in range(n):
        for a in range(3):
            vp[i, a] = vel[i, a]
            dsp[i, a] = 0.0
            acc[i, a] = geo[6 + a]
            ke += mass[i] * vel[i, a] * vel[i, a]
    u, vir, pd, _on, pt, ut = _forces(pos, vel, vp, acc, mass, radius, nbl, nbl_n, tch, geo, model, ca, cb, rot, fric, 0.0)
    sums[S_KE] = 0.5 * ke
    sums[S_U] = u + ut
    sums[S_UT] = ut
    sums[S_VIR] = vir
    sums[S_PDISS] = pd
    sums[S_PT] = pt
    return True


@jit
def dem_steps(pos, vel, acc, vp, dsp, image, mass, radius, nbl, nbl_n, tch, grid, geo, model, ca, cb, rot, fric, skin, h, nsteps, sums, cnt, cbuf):
    """Advance ``nsteps`` velocity-Verlet steps of size ``h``.

    Returns ``(status, steps_done)``: ``ST_EVENTS`` when done; on ``ST_LIST_FULL`` or
    ``ST_STEP_TOO_LARGE`` the state is that of the last complete step (with friction, the
    springs of the list before the failed rebuild are in ``rot.hist_old``/``rot.nbl_old``).
    Counters (the event engine's slots): ``C_EVENTS`` steps, ``C_COLL`` contact onsets,
    ``C_REBUILD`` list builds. Three passes over the particles per step: kick-drift, forces,
    kick (fused with the kinetic energy and the displacement check of the next drift); spins
    are kicked alike (velocity Verlet for the angular velocities).
    """
    n = pos.shape[0]
    frictional = fric[0] > 0
    lim = 0.25 * skin * skin  # (skin / 2)^2
    hh = 0.5 * h
    worst = _worst_drift(vel, acc, dsp, h)
    for step in range(nsteps):
        # rebuild the list now if the coming drift could carry a particle past skin / 2
        if worst > lim:
            if not _rebuild(pos, radius, geo, grid, skin, nbl, nbl_n, tch, rot, frictional, cbuf):
                return ST_LIST_FULL, step
            cnt[C_REBUILD] += 1
            dsp[:] = 0.0
            if _worst_drift(vel, acc, dsp, h) > lim:
                return ST_STEP_TOO_LARGE, step
        # kick, drift (wrapping into the box), extrapolated velocity for the force, gravity
        for i in range(n):
            for a in range(3):
                v = vel[i, a] + hh * acc[i, a]
                vel[i, a] = v
                dx = h * v
                dsp[i, a] += dx
                x = pos[i, a] + dx
                half = geo[3 + a]
                if x >= half:
                    x -= geo[a]
                    image[i, a] += 1
                elif x < -half:
                    x += geo[a]
                    image[i, a] -= 1
                pos[i, a] = x
                vp[i, a] = v + hh * acc[i, a]
                acc[i, a] = geo[6 + a]
        if frictional:
            _kick_spins(rot, hh)
        u, vir, pd, onsets, pt, ut = _forces(pos, vel, vp, acc, mass, radius, nbl, nbl_n, tch, geo, model, ca, cb, rot, fric, h)
        # kick (with friction also the onset jumps deferred by _forces), kinetic energy, and the displacement the next drift would reach
        ke = 0.0
        worst = 0.0
        dv = rot.dv
        for i in range(n):
            d2 = 0.0
            for a in range(3):
                v = vel[i, a] + hh * acc[i, a]
                if frictional:
                    v += dv[i, a]
                    dv[i, a] = 0.0
                vel[i, a] = v
                ke += mass[i] * v * v
                d = dsp[i, a] + h * (v + hh * acc[i, a])
                d2 += d * d
            worst = max(worst, d2)
        ke *= 0.5
        if frictional:
            om, al, dw = rot.omega, rot.alpha, rot.dw
            for i in range(n):
                for a in range(3):
                    om[i, a] += hh * al[i, a] + dw[i, a]
                    dw[i, a] = 0.0
        sums[S_KE_INT] += hh * (sums[S_KE] + ke)
        sums[S_VIR_INT] += hh * (sums[S_VIR] + vir)
        sums[S_DISS] += hh * (sums[S_PDISS] + pd)
        sums[S_WT] += hh * (sums[S_PT] + pt)
        sums[S_KE] = ke
        sums[S_U] = u + ut
        sums[S_UT] = ut
        sums[S_VIR] = vir
        sums[S_PDISS] = pd
        sums[S_PT] = pt
        cnt[C_EVENTS] += 1
        cnt[C_COLL] += onsets
    return ST_EVENTS, nsteps
