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
which a contact begins (:func:`_onset_impulse`: the dashpot force jumps at contact onset). Contact forces come from :func:`edmd._core.contact.contact_force`
(clipped at zero: the force-based end of a contact, physics.md §2.2). The list is rebuilt at a
step boundary when the coming drift would take a particle beyond ``skin / 2`` of where the
list was built; then the overlap flags are exactly the geometry's.

Running sums (``sums``): current kinetic energy, elastic energy, virial
:math:`\sum_{\rm pairs} r_{ij}F_{ij}`, dissipated power :math:`\sum (F - F_{\rm el})\dot\xi`, and the
trapezoidal time integrals of kinetic energy, virial and dissipated power.
"""

import math

from .cells import bin_all, walk_around, walk_next
from .contact import MODEL_HERTZ, contact_force
from .jit import jit, leaf
from .layout import C_COLL, C_EVENTS, C_REBUILD, ST_EVENTS, ST_LIST_FULL
from .predict import wrap3

S_KE, S_U, S_VIR, S_PDISS, S_KE_INT, S_VIR_INT, S_DISS = range(7)
N_SUMS = 8

#: status: a single drift would be longer than half the skin (time step too large)
ST_STEP_TOO_LARGE = 7


@jit
def build_list(pos, radius, geo, grid, skin, nbl, nbl_n, tch, cbuf):
    """Bin the particles and build the half neighbour list with overlap flags.

    Returns ``False`` if a row of ``nbl`` overflows (the caller grows it and retries).
    """
    n = pos.shape[0]
    bin_all(pos, geo, grid)
    cap = nbl.shape[1]
    for i in range(n):
        xi, yi, zi, ri = pos[i, 0], pos[i, 1], pos[i, 2], radius[i]
        m = 0
        nc, s, j = walk_around(grid, grid.cell[i], geo, cbuf)
        while j >= 0:
            if j > i:
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
            nc, s, j = walk_next(grid, cbuf, nc, s, j)
        nbl_n[i] = m
    return True


@leaf
def _onset_impulse(model, f, f_el, xi, xi_dot, h):
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
    Returns exact minus trapezoidal impulse.
    """
    if model == MODEL_HERTZ or xi_dot <= 0.0 or h <= 0.0:
        return 0.0
    tau = min(xi / xi_dot, h)
    return (tau - 0.5 * h) * (f - f_el)


@leaf
def _forces(pos, vel, vp, acc, mass, radius, nbl, nbl_n, tch, geo, model, ca, cb, h):
    """Add the contact accelerations at ``pos`` with velocities ``vp`` to ``acc`` (holding gravity).

    Returns ``(U, virial, P_diss, onsets)``. Contacts that began during the step of size ``h``
    just taken get the onset correction :func:`_onset_impulse`, applied to ``vel`` (``h = 0``: none).
    """
    n = pos.shape[0]
    u = 0.0
    vir = 0.0
    pd = 0.0
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
            f, f_el, u_el = contact_force(model, ca, cb, ri * rj / sig, sig - r, xi_dot)
            if tch[i, k] == 0:
                onsets += 1
                tch[i, k] = 1
                dj = _onset_impulse(model, f, f_el, sig - r, xi_dot, h)
                vel[i, 0] += dj * nx / mi
                vel[i, 1] += dj * ny / mi
                vel[i, 2] += dj * nz / mi
                vel[j, 0] -= dj * nx / mass[j]
                vel[j, 1] -= dj * ny / mass[j]
                vel[j, 2] -= dj * nz / mass[j]
            u += u_el
            vir += f * r
            pd += (f - f_el) * xi_dot
            fx, fy, fz = f * nx, f * ny, f * nz
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
    return u, vir, pd, onsets


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
def dem_setup(pos, vel, acc, vp, dsp, mass, radius, nbl, nbl_n, tch, grid, geo, model, ca, cb, skin, sums, cbuf):
    """Build the list and evaluate forces and sums at the current state; ``False`` on list overflow."""
    if not build_list(pos, radius, geo, grid, skin, nbl, nbl_n, tch, cbuf):
        return False
    n = pos.shape[0]
    ke = 0.0
    for i in range(n):
        for a in range(3):
            vp[i, a] = vel[i, a]
            dsp[i, a] = 0.0
            acc[i, a] = geo[6 + a]
            ke += mass[i] * vel[i, a] * vel[i, a]
    u, vir, pd, _on = _forces(pos, vel, vp, acc, mass, radius, nbl, nbl_n, tch, geo, model, ca, cb, 0.0)
    sums[S_KE] = 0.5 * ke
    sums[S_U] = u
    sums[S_VIR] = vir
    sums[S_PDISS] = pd
    return True


@jit
def dem_steps(pos, vel, acc, vp, dsp, image, mass, radius, nbl, nbl_n, tch, grid, geo, model, ca, cb, skin, h, nsteps, sums, cnt, cbuf):
    """Advance ``nsteps`` velocity-Verlet steps of size ``h``.

    Returns ``(status, steps_done)``: ``ST_EVENTS`` when done; on ``ST_LIST_FULL`` or
    ``ST_STEP_TOO_LARGE`` the state is that of the last complete step. Counters (the event
    engine's slots): ``C_EVENTS`` steps, ``C_COLL`` contact onsets, ``C_REBUILD`` list builds.
    Three passes over the particles per step: kick-drift, forces, kick (fused with the kinetic
    energy and the displacement check of the next drift).
    """
    n = pos.shape[0]
    lim = 0.25 * skin * skin  # (skin / 2)^2
    hh = 0.5 * h
    worst = _worst_drift(vel, acc, dsp, h)
    for step in range(nsteps):
        # rebuild the list now if the coming drift could carry a particle past skin / 2
        if worst > lim:
            if not build_list(pos, radius, geo, grid, skin, nbl, nbl_n, tch, cbuf):
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
        u, vir, pd, onsets = _forces(pos, vel, vp, acc, mass, radius, nbl, nbl_n, tch, geo, model, ca, cb, h)
        # kick, kinetic energy, and the displacement the next drift would reach
        ke = 0.0
        worst = 0.0
        for i in range(n):
            d2 = 0.0
            for a in range(3):
                v = vel[i, a] + hh * acc[i, a]
                vel[i, a] = v
                ke += mass[i] * v * v
                d = dsp[i, a] + h * (v + hh * acc[i, a])
                d2 += d * d
            worst = max(worst, d2)
        ke *= 0.5
        sums[S_KE_INT] += hh * (sums[S_KE] + ke)
        sums[S_VIR_INT] += hh * (sums[S_VIR] + vir)
        sums[S_DISS] += hh * (sums[S_PDISS] + pd)
        sums[S_KE] = ke
        sums[S_U] = u
        sums[S_VIR] = vir
        sums[S_PDISS] = pd
        cnt[C_EVENTS] += 1
        cnt[C_COLL] += onsets
    return ST_EVENTS, nsteps
