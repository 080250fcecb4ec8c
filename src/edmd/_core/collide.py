"""Instantaneous collision rules (physics.md §2, §3): one impulse law for pairs and walls.

A collision is a normal law (constant :math:`e_n`, or :math:`e_n(v_n)` of viscoelastic
spheres, §2.2.2) and a tangential law (smooth, constant tangential restitution :math:`\\beta`,
or Coulomb-limited (Walton), §2.3), optionally switched to elastic by the TC model (§3).
The impulse on particle ``i`` (physics.md §2.3) is

.. math::
    \\mathbf J = -(1+e_n)\\,\\mu\\,\\mathbf g_n - (1+\\beta)\\,m_t\\,\\mathbf g_t,\\qquad
    \\frac{1}{\\mu} = \\frac{1}{m_i}+\\frac{1}{m_j},\\quad
    \\frac{1}{m_t} = \\frac{1}{\\mu} + \\frac{R_i^2}{I_i} + \\frac{R_j^2}{I_j},

with :math:`\\mathbf g_c = \\mathbf v_i - \\mathbf v_j - (R_i\\boldsymbol\\omega_i + R_j\\boldsymbol\\omega_j)\\times\\hat{\\mathbf n}`.
A flat wall is the limit :math:`m_j, I_j \\to \\infty` (§1.3). Two-dimensional disks are spheres in
the plane with spin along :math:`z`; the 3D formulas then reduce exactly to the 2D ones of §2.3.

The energy lost is booked as the exact before/after difference of the particles' kinetic
(translational + rotational) energies for rough rules and walls, and by the closed form
:math:`-\\tfrac12\\mu(1-e_n^2)g_n^2` for smooth particle pairs, so kinetic + potential +
dissipated energy is conserved to round-off whatever the rule. ``last_collision`` (the TC
memory) is only kept when the TC model is on.
"""

import math

from . import layout as L
from .layout import NORMAL_CONST, TANGENT_COULOMB, TANGENT_SMOOTH
from .contact import MODEL_HERTZ, contact_scales
from .jit import hot, leaf
from .images import flow_speed, shear_image
from .stress import impulse_shear_work, impulse_tensor, pair_energy_current, particle_current, particle_energy, virial_tensor
from .twobody import dashpot_central
from .wallmotion import start_ride, sticks, wall_velocity


@leaf
def contact_normal(P, i, j, geo):
    """Unit normal from ``j`` to ``i``, the centre distance (minimum image; rows streamed to the
    same time) and the x velocity of ``j``'s image besides ``v_j`` (shear, :func:`.images.shear_image`)."""
    dx, dy, dz, uj = shear_image(P[i, L.X] - P[j, L.X], P[i, L.Y] - P[j, L.Y], P[i, L.Z] - P[j, L.Z], P[i, L.T], geo)
    r = math.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / r
    return dx * inv, dy * inv, dz * inv, r, uj


@leaf
def eps_viscoelastic(delta, etab, inv_ds):
    """Restitution :math:`\\varepsilon(\\delta)` of viscoelastic spheres from the spline table in :math:`s=\\sqrt\\delta`.

    physics.md §2.2.2 ("use in code", option 1); beyond the table's end (:math:`\\delta > 100`)
    the last value is kept (far outside the model's validity, :math:`\\delta \\lesssim 1`).
    """
    x = math.sqrt(delta) * inv_ds
    k = int(x)
    n = etab.shape[0]
    if k >= n:
        k = n - 1
        x = float(n)
    h = (x - k) / inv_ds
    return ((etab[k, 0] * h + etab[k, 1]) * h + etab[k, 2]) * h + etab[k, 3]


@leaf
def normal_restitution(law, e_const, vn, mu_red, r_eff, fp, ip, etab):
    r"""Normal restitution of an impact at normal speed ``vn``.

    ``NORMAL_CONST``: ``e_const``. ``NORMAL_SOFT``: the central :math:`e_n(v_n)` of the contact law
    ``ip[IP_EMD_MODEL]`` with constants ``fp[FP_SOFT_A/B]`` (the one material of a run, physics.md
    §2.2): viscoelastic Hertz spheres, :math:`\rho = \frac{2Y\sqrt{R_{\rm eff}}}{3(1-\nu^2)}`,
    :math:`e_n = \varepsilon(\delta)` with :math:`\delta = \tfrac32 A(\rho/\mu)^{2/5}v_n^{1/5}` (§2.2.2), or the
    dashpot's :math:`e^{-\zeta_d\omega_0t_c}` (§2.2.1). It is also the instantaneous rule of eMD*
    fallbacks and walls (physics.md §4.8).
    """
    if law == NORMAL_CONST:
        return e_const
    model = ip[L.IP_EMD_MODEL]
    c, _lam, _ts, _ls = contact_scales(model, fp[L.FP_SOFT_A], fp[L.FP_SOFT_B], mu_red, r_eff, 1.0, vn)
    if model == MODEL_HERTZ:
        return eps_viscoelastic(c, etab, fp[L.FP_ETAB_INV])
    return dashpot_central(0.5 * c)[1]


@leaf
def impulse(nx, ny, nz, gx, gy, gz, wx, wy, wz, inv_mu, inv_mt, e, beta, mu_c, tangent):
    """Impulse on ``i`` for relative centre velocity ``g`` and summed spins ``w = R_i w_i + R_j w_j``.

    Returns ``(Jx, Jy, Jz, v_n, v_t)`` with the normal impact speed ``v_n = -g.n`` and the
    tangential speed of the contact point ``v_t`` (physics.md §2.3, Coulomb variant included).
    """
    gn = gx * nx + gy * ny + gz * nz
    jn = -(1.0 + e) * gn / inv_mu
    if tangent == TANGENT_SMOOTH:
        tx, ty, tz = gx - gn * nx, gy - gn * ny, gz - gn * nz
        return jn * nx, jn * ny, jn * nz, -gn, math.sqrt(tx * tx + ty * ty + tz * tz)
    cx = gx - (wy * nz - wz * ny)
    cy = gy - (wz * nx - wx * nz)
    cz = gz - (wx * ny - wy * nx)
    tx, ty, tz = cx - gn * nx, cy - gn * ny, cz - gn * nz
    vt = math.sqrt(tx * tx + ty * ty + tz * tz)
    b = beta
    if tangent == TANGENT_COULOMB and vt > 0.0:
        b = min(beta, -1.0 + mu_c * (1.0 + e) * (inv_mt / inv_mu) * (-gn) / vt)
    k = -(1.0 + b) / inv_mt
    return jn * nx + k * tx, jn * ny + k * ty, jn * nz + k * tz, -gn, vt


@leaf
def pair_impulse(P, mass, omega, inertia, i, j, jn, nx, ny, nz, r, acc):
    r"""Apply the normal impulse :math:`J_n\hat{\mathbf n}` to ``i`` and its opposite to ``j`` (smooth
    particles at distance ``r``) and add it to the virial and the stress tensor (:mod:`.stress`)."""
    mi, mj = mass[i], mass[j]
    gx, gy, gz = P[i, L.VX] - P[j, L.VX], P[i, L.VY] - P[j, L.VY], P[i, L.VZ] - P[j, L.VZ]
    impulse_tensor(acc, 1.0 / mi + 1.0 / mj, gx, gy, gz, jn * nx, jn * ny, jn * nz)
    virial_tensor(acc, r * nx, r * ny, r * nz, jn * nx, jn * ny, jn * nz)
    acc[L.A_VIRIAL] += r * jn
    turns = omega.shape[0] != 0
    ei0 = particle_energy(P, mass, omega, inertia, i, turns)
    ej0 = particle_energy(P, mass, omega, inertia, j, turns)
    for k, nk in ((0, nx), (1, ny), (2, nz)):
        P[i, L.VX + k] += jn / mi * nk
        P[j, L.VX + k] -= jn / mj * nk
    ei1 = particle_energy(P, mass, omega, inertia, i, turns)
    ej1 = particle_energy(P, mass, omega, inertia, j, turns)
    pair_energy_current(acc, P, i, j, ei0, ej0, ei1, ej1, jn / mi * nx, jn / mi * ny, jn / mi * nz, -jn / mj * nx, -jn / mj * ny, -jn / mj * nz, r * nx, r * ny, r * nz)


@leaf
def _kick(P, omega, inertia, i, jx, jy, jz, nx, ny, nz, dv, ri, spin):
    """Velocity change ``dv * J`` and spin change ``-(R/I) n x J`` (the same for both partners:
    ``i`` takes ``J`` at ``-R_i n``, ``j`` takes ``-J`` at ``+R_j n``). Without ``spin`` the spins
    and moments of inertia are not read (their arrays have size 0 in smooth runs)."""
    P[i, L.VX] += jx * dv
    P[i, L.VY] += jy * dv
    P[i, L.VZ] += jz * dv
    if spin:
        r_over_i = ri / inertia[i]
        omega[i, 0] -= r_over_i * (ny * jz - nz * jy)
        omega[i, 1] -= r_over_i * (nz * jx - nx * jz)
        omega[i, 2] -= r_over_i * (nx * jy - ny * jx)


@leaf
def _tc_elastic(t, tlast, i, j, fp, ip):
    """TC model (physics.md §3): elastic if either partner collided less than ``t_TC`` ago (``j < 0``: a wall)."""
    if ip[L.IP_TC] == 0:
        return False
    tc = fp[L.FP_TC]
    return t - tlast[i] < tc or (j >= 0 and t - tlast[j] < tc)


@hot
def collide_pair(t, P, mass, omega, inertia, tlast, i, j, geo, fp, ip, etab, acc, cnt, tangent, normal):
    """Collide ``i`` and ``j`` (streamed to the contact time ``t``). Returns ``(v_n, v_t)``.

    ``tangent`` and ``normal`` are the pair laws (``ip[IP_TANGENT]``, ``ip[IP_NORMAL]``), passed
    apart so that a loop variant giving them as compile-time constants compiles only its laws.

    Adds :math:`\\mathbf r_{ij}\\cdot\\mathbf J` to the virial, the kinetic-energy change to
    ``acc[A_KE]`` (translational) and the energy lost to ``acc[A_DISSIPATED]``.
    """
    nx, ny, nz, r, uj = contact_normal(P, i, j, geo)
    spin = tangent != TANGENT_SMOOTH
    gx = P[i, L.VX] - P[j, L.VX] - uj
    gy = P[i, L.VY] - P[j, L.VY]
    gz = P[i, L.VZ] - P[j, L.VZ]
    gn = gx * nx + gy * ny + gz * nz
    if gn >= 0.0:
        return 0.0, 0.0
    mi, mj = mass[i], mass[j]
    ri, rj = P[i, L.R], P[j, L.R]
    inv_mu = 1.0 / mi + 1.0 / mj
    inv_mt = inv_mu
    wx = wy = wz = 0.0
    if spin:
        inv_mt += ri * ri / inertia[i] + rj * rj / inertia[j]
        wx = ri * omega[i, 0] + rj * omega[j, 0]
        wy = ri * omega[i, 1] + rj * omega[j, 1]
        wz = ri * omega[i, 2] + rj * omega[j, 2]
    beta = fp[L.FP_BETA]
    if _tc_elastic(t, tlast, i, j, fp, ip):
        e = 1.0
        beta = -1.0
        cnt[L.C_TC_ELASTIC] += 1
    else:
        e = normal_restitution(normal, fp[L.FP_EN], -gn, 1.0 / inv_mu, ri * rj / (ri + rj), fp, ip, etab)
    jx, jy, jz, vn, vt = impulse(nx, ny, nz, gx, gy, gz, wx, wy, wz, inv_mu, inv_mt, e, beta, fp[L.FP_MU], tangent)
    if spin:
        k0 = particle_energy(P, mass, omega, inertia, i, False) + particle_energy(P, mass, omega, inertia, j, False)
    turns = spin or omega.shape[0] != 0  # (e_i holds the spin's energy whenever spins are kept)
    ei0 = particle_energy(P, mass, omega, inertia, i, turns)
    ej0 = particle_energy(P, mass, omega, inertia, j, turns)
    _kick(P, omega, inertia, i, jx, jy, jz, nx, ny, nz, 1.0 / mi, ri, spin)
    _kick(P, omega, inertia, j, jx, jy, jz, nx, ny, nz, -1.0 / mj, rj, spin)
    ei1 = particle_energy(P, mass, omega, inertia, i, turns)
    ej1 = particle_energy(P, mass, omega, inertia, j, turns)
    pair_energy_current(acc, P, i, j, ei0, ej0, ei1, ej1, jx / mi, jy / mi, jz / mi, -jx / mj, -jy / mj, -jz / mj, r * nx, r * ny, r * nz)
    if spin:  # (the rows' energies: across a sheared face, j's image moves with v_j + u_j)
        dk = particle_energy(P, mass, omega, inertia, i, False) + particle_energy(P, mass, omega, inertia, j, False) - k0 - uj * jx
        lost = ei0 + ej0 - ei1 - ej1 + uj * jx  # (spin: turns)
    else:  # smooth: physics.md §2.1, Delta E = -mu (1 - e^2) g_n^2 / 2, spins untouched
        dk = -0.5 * (1.0 - e * e) * gn * gn / inv_mu
        lost = -dk
    acc[L.A_VIRIAL] += r * (jx * nx + jy * ny + jz * nz)
    virial_tensor(acc, r * nx, r * ny, r * nz, jx, jy, jz)
    impulse_tensor(acc, inv_mu, gx - flow_speed(r * ny, geo), gy, gz, jx, jy, jz)  # (peculiar under shear)
    impulse_shear_work(acc, r * ny, jx, geo)
    acc[L.A_KE] += dk
    acc[L.A_DISSIPATED] += lost
    if ip[L.IP_TC]:
        tlast[i] = t
        tlast[j] = t
    return vn, vt


@hot
def collide_wall(t, P, mass, omega, inertia, tlast, i, axis, face, geo, fp, ip, etab, acc, grow_speed):
    """Bounce ``i`` (streamed to the contact time ``t``) off the wall ``face`` (0 lower, 1 upper) of ``axis``.

    The wall is a particle of infinite mass and moment of inertia (physics.md §1.3); its own
    normal/tangential laws and TC rule apply to the velocity relative to the wall, which moves
    along its normal with :func:`.walls.wall_velocity` :math:`u` (0 unless it is the vibrating
    wall, §1.6) plus ``grow_speed``, the rate :math:`R_0\\gamma` at which a growing radius (§1.7)
    closes the gap as if the wall moved in. The normal momentum it takes is added to ``acc[A_WALL + 2 * axis + face]``
    (wall pressure), the momentum change to ``acc[A_P*]``, the energy lost in the wall's frame
    to ``acc[A_DISSIPATED]`` and the work :math:`u J` the wall did to ``acc[A_ENERGY_INPUT]``.
    Returns the normal and tangential impact speeds relative to the wall (zeros: no impact).
    """
    nx = ny = nz = 0.0
    sign = 1.0 if face == 0 else -1.0
    if axis == 0:
        nx = sign
    elif axis == 1:
        ny = sign
    else:
        nz = sign
    uw = wall_velocity(axis, face, t, geo) + sign * grow_speed
    gx, gy, gz = P[i, L.VX], P[i, L.VY], P[i, L.VZ]
    vx, vy, vz = gx, gy, gz  # (lab frame)
    gn = gx * nx + gy * ny + gz * nz - uw * sign
    if gn >= 0.0:
        if sticks(P, axis, face, t, gn, geo):  # resting on the pressing wall (a ride ended without a kick along
            # its axis): it rides again, its slow leaving speed taken away in the wall's frame
            mi = mass[i]
            jk = mi * (uw - P[i, L.VX + axis])
            acc[L.A_KE] += 0.5 * mi * (uw * uw - P[i, L.VX + axis] ** 2)
            acc[L.A_DISSIPATED] += 0.5 * mi * gn * gn
            acc[L.A_ENERGY_INPUT] += uw * jk
            acc[L.A_PX + axis] += jk
            acc[L.A_WALL + 2 * axis + face] += jk * sign
            start_ride(P, i, axis, uw, mass, acc)
        return 0.0, 0.0
    tangent = ip[L.IP_WALL_TANGENT]
    spin = tangent != TANGENT_SMOOTH
    mi, ri = mass[i], P[i, L.R]
    inv_mu = 1.0 / mi
    inv_mt = inv_mu + ri * ri / inertia[i] if spin else inv_mu
    beta = fp[L.FP_WALL_BETA]
    if _tc_elastic(t, tlast, i, -1, fp, ip):
        e = 1.0
        beta = -1.0
    else:
        e = normal_restitution(ip[L.IP_WALL_NORMAL], fp[L.FP_WALL_EN], -gn, mi, ri, fp, ip, etab)
    stick = sticks(P, axis, face, t, -e * gn, geo)  # the sticking solution (physics.md §1.6.3)
    if stick:
        e = 0.0
    k0 = particle_energy(P, mass, omega, inertia, i, False)
    turns = omega.shape[0] != 0  # (e_i holds the spin's energy whenever spins are kept, see collide_pair)
    particle_current(acc, P, mass, omega, inertia, i, turns, -1.0)  # (lab frame)
    if uw != 0.0:  # into the wall's frame
        P[i, L.VX + axis] -= uw
        gx, gy, gz = P[i, L.VX], P[i, L.VY], P[i, L.VZ]
    wx = wy = wz = 0.0
    if spin:
        wx, wy, wz = ri * omega[i, 0], ri * omega[i, 1], ri * omega[i, 2]
    jx, jy, jz, vn, vt = impulse(nx, ny, nz, gx, gy, gz, wx, wy, wz, inv_mu, inv_mt, e, beta, fp[L.FP_WALL_MU], tangent)
    e0 = particle_energy(P, mass, omega, inertia, i, spin)
    _kick(P, omega, inertia, i, jx, jy, jz, nx, ny, nz, 1.0 / mi, ri, spin)
    e1 = particle_energy(P, mass, omega, inertia, i, spin)
    if uw != 0.0:
        P[i, L.VX + axis] += uw
        acc[L.A_ENERGY_INPUT] += uw * (jx * nx + jy * ny + jz * nz) * sign
    if stick:
        start_ride(P, i, axis, uw, mass, acc)
    particle_current(acc, P, mass, omega, inertia, i, turns, 1.0)
    acc[L.A_KE] += particle_energy(P, mass, omega, inertia, i, False) - k0
    impulse_tensor(acc, inv_mu, vx - flow_speed(P[i, L.Y], geo), vy, vz, jx, jy, jz)  # (a new rider's is not reported; peculiar under shear)
    impulse_shear_work(acc, P[i, L.Y], jx, geo)
    acc[L.A_DISSIPATED] += e0 - e1
    acc[L.A_PX] += jx
    acc[L.A_PY] += jy
    acc[L.A_PZ] += jz
    acc[L.A_WALL + 2 * axis + face] += jx * nx + jy * ny + jz * nz
    if ip[L.IP_TC]:
        tlast[i] = t
    return vn, vt
