r"""Accumulators of the stress tensor and the energy current (physics.md §5.3, §5.6): kinetic parts and the collisions'.

The pressure tensor over an interval :math:`t_{\rm obs}` of a system of volume :math:`V` is

.. math::
    \mathsf P = \frac{1}{V}\Big[\frac{1}{t_{\rm obs}}\int \sum_i m_i\,\mathbf v_i\otimes\mathbf v_i\,dt
        - \frac{\mathbf P_{\rm tot}\otimes\mathbf P_{\rm tot}}{M}
        + \frac{1}{t_{\rm obs}}\sum_{\rm coll}\tfrac12(\mathbf r_{ij}\otimes\mathbf J + \mathbf J\otimes\mathbf r_{ij})\Big],

whose trace over :math:`d` is the scalar pressure. The core keeps the six symmetric components
(:data:`.layout.TENSOR`) of three sums in ``acc``: the running kinetic tensor
:math:`\mathsf K = \sum_i m_i\mathbf v_i\otimes\mathbf v_i` (``A_KT``), its time integral
(``A_KT_INT``, carried with the kinetic-energy integral) and the virial (``A_VT``). An impulse
:math:`\mathbf J` on a particle of velocity :math:`\mathbf v` changes :math:`\mathsf K` by
:math:`\mathbf J\otimes\mathbf v + \mathbf v\otimes\mathbf J + \mathbf J\otimes\mathbf J/m`; on a pair
(:math:`+\mathbf J` on ``i``, :math:`-\mathbf J` on ``j``) by the same with the relative velocity
:math:`\mathbf g = \mathbf v_i - \mathbf v_j` and :math:`1/\mu = 1/m_i + 1/m_j`, so each update is exact
and free of cancellation.

The energy current (for the thermal conductivity, §5.6) is kept the same way: the running
:math:`\mathbf J_E = \sum_i e_i\mathbf v_i` with :math:`e_i = \tfrac12 m_iv_i^2 + \tfrac12 I_i\omega_i^2` (``A_JE``,
updated from each changed particle's value before and after), its time integral (``A_JE_INT``)
and the collisional transfer :math:`\sum_{\rm coll}\tfrac12\mathbf r_{ij}(\Delta e_i - \Delta e_j)`
(``A_QV``; the energy an inelastic collision loses is taken out at the contact point).

**Under shear** (Lees-Edwards, :mod:`.images`) the kinetic sums are peculiar:
:math:`\mathsf K = \sum_i m_i\mathbf c_i\otimes\mathbf c_i` with :math:`\mathbf c = \mathbf v - \dot\gamma y\,\hat{\mathbf x}`
(and so are ``A_KE`` and the momentum ``A_P*``). Between events :math:`\dot c_x = -\dot\gamma c_y`, so

.. math::
    K_{xx}(\tau) = K_{xx} - 2\dot\gamma K_{xy}\tau + \dot\gamma^2K_{yy}\tau^2,\quad
    K_{xy}(\tau) = K_{xy} - \dot\gamma K_{yy}\tau,\quad K_{xz}(\tau) = K_{xz} - \dot\gamma K_{yz}\tau,

the others constant (:func:`integrate_sheared`), and the boundaries work on the peculiar motion
at the rate :math:`-\dot\gamma K_{xy}`. An impulse :math:`\mathbf J` on ``i`` of a pair across the
separation :math:`\mathbf r_{ij}` changes the peculiar energy by the work it does in the pair's frame
plus :math:`-\dot\gamma\,y_{ij}J_x` (:func:`impulse_shear_work`). Summed, ``acc[A_SHEAR_WORK]`` is
:math:`-\dot\gamma V\int P_{xy}\,dt` (the viscous heating) and closes the energy balance
:math:`\Delta E_{\rm peculiar} = W_{\rm shear} - E_{\rm dissipated}`. The energy current is not kept under shear.
"""

from numba.extending import overload

from .images import sheared, sheared_type
from .jit import leaf
from .layout import (
    A_JE, A_JE_INT, A_KE, A_KE_INT, A_KT, A_KT_INT, A_LAST_T, A_PX, A_PY, A_PZ, A_QV, A_SHEAR_WORK, A_VIRIAL, A_VT,
    G_GX, G_GY, G_GZ, G_ON, G_SHEAR_RATE, VX, VY, VZ,
)  # fmt: skip


@leaf
def _add_symmetric(acc, base, ax, ay, az, bx, by, bz, f):
    """``acc[base + c] += f (a_a b_b + b_a a_b)`` for the components ``c = (a, b)`` of :data:`.layout.TENSOR`."""
    acc[base] += 2.0 * f * ax * bx
    acc[base + 1] += 2.0 * f * ay * by
    acc[base + 2] += 2.0 * f * az * bz
    acc[base + 3] += f * (ax * by + bx * ay)
    acc[base + 4] += f * (ax * bz + bx * az)
    acc[base + 5] += f * (ay * bz + by * az)


@leaf
def impulse_tensor(acc, inv_m, vx, vy, vz, jx, jy, jz):
    r"""The running kinetic tensor after the impulse :math:`\mathbf J` on a particle of velocity
    :math:`\mathbf v` and inverse mass ``inv_m`` (before the kick), or on a pair with the relative
    velocity :math:`\mathbf g` and ``inv_m`` :math:`= 1/\mu`:
    :math:`\Delta\mathsf K = \mathbf J\otimes\mathbf v + \mathbf v\otimes\mathbf J + \mathbf J\otimes\mathbf J/m`."""
    _add_symmetric(acc, A_KT, jx, jy, jz, vx, vy, vz, 1.0)
    _add_symmetric(acc, A_KT, jx, jy, jz, jx, jy, jz, 0.5 * inv_m)


@leaf
def book_velocity_change(acc, m, vx, vy, vz, ux, uy, uz):
    """The running kinetic tensor after a particle of mass ``m`` changed its velocity from ``v`` to ``u``."""
    impulse_tensor(acc, 1.0 / m, vx, vy, vz, m * (ux - vx), m * (uy - vy), m * (uz - vz))


@leaf
def virial_tensor(acc, rx, ry, rz, jx, jy, jz):
    r"""Add a collision's :math:`\tfrac12(\mathbf r_{ij}\otimes\mathbf J + \mathbf J\otimes\mathbf r_{ij})` to the virial tensor."""
    _add_symmetric(acc, A_VT, rx, ry, rz, jx, jy, jz, 0.5)


@leaf
def free_fall_fluxes(acc, tau, geo, total_mass):
    r"""Advance the kinetic tensor and its integral over ``tau`` between events, with the total
    momentum :math:`\mathbf P` before it (:func:`.wallmotion.free_fall` then advances it): under
    gravity :math:`\mathsf K(\tau) = \mathsf K_0 + (\mathbf G\otimes\mathbf P + \mathbf P\otimes\mathbf G)\tau
    + M\,\mathbf G\otimes\mathbf G\,\tau^2`, integrated exactly; and the integral of the energy current,
    constant between events without gravity (it is not reported under gravity)."""
    for c in range(6):
        acc[A_KT_INT + c] += acc[A_KT + c] * tau
    for k in range(3):
        acc[A_JE_INT + k] += acc[A_JE + k] * tau
    if geo[G_ON] != 0.0:
        gx, gy, gz = geo[G_GX], geo[G_GY], geo[G_GZ]
        px, py, pz = acc[A_PX], acc[A_PY], acc[A_PZ]
        _add_symmetric(acc, A_KT_INT, gx, gy, gz, px, py, pz, 0.5 * tau * tau)
        _add_symmetric(acc, A_KT_INT, gx, gy, gz, gx, gy, gz, total_mass * tau * tau * tau / 6.0)
        _add_symmetric(acc, A_KT, gx, gy, gz, px, py, pz, tau)
        _add_symmetric(acc, A_KT, gx, gy, gz, gx, gy, gz, 0.5 * total_mass * tau * tau)


@leaf
def _energy(mass, omega, inertia, i, vx, vy, vz, spin):
    """Kinetic energy of particle ``i`` moving with ``v``, with its rotational energy if ``spin``
    (otherwise the spins and moments of inertia are not read: their arrays have size 0 in smooth runs)."""
    e = mass[i] * (vx * vx + vy * vy + vz * vz)
    if spin:
        e += inertia[i] * (omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2)
    return 0.5 * e


@leaf
def particle_energy(P, mass, omega, inertia, i, spin):
    """Kinetic energy of particle ``i`` (its row's velocity), with its rotational energy if ``spin``."""
    return _energy(mass, omega, inertia, i, P[i, VX], P[i, VY], P[i, VZ], spin)


@leaf
def energy_current(acc, sign, e, vx, vy, vz):
    r"""Add ``sign`` times :math:`e\,\mathbf v` to the running energy current."""
    acc[A_JE] += sign * e * vx
    acc[A_JE + 1] += sign * e * vy
    acc[A_JE + 2] += sign * e * vz


@leaf
def particle_current(acc, P, mass, omega, inertia, i, spin, sign):
    r"""Add ``sign`` times particle ``i``'s :math:`e_i\mathbf v_i` to the running energy current
    (-1 before it changes, +1 after); returns :math:`e_i` (see :func:`particle_energy`)."""
    e = particle_energy(P, mass, omega, inertia, i, spin)
    energy_current(acc, sign, e, P[i, VX], P[i, VY], P[i, VZ])
    return e


@leaf
def energy_virial(acc, rx, ry, rz, de_i, de_j):
    r"""Add a collision's :math:`\tfrac12\mathbf r_{ij}(\Delta e_i - \Delta e_j)` to the collisional energy transfer."""
    h = 0.5 * (de_i - de_j)
    acc[A_QV] += rx * h
    acc[A_QV + 1] += ry * h
    acc[A_QV + 2] += rz * h


@leaf
def committed_current(acc, mass, omega, inertia, p, v, dv, spin):
    r"""Add the :math:`e_p\mathbf v_p` of particle ``p`` with the committed velocity ``v + dv`` (an
    eMD* pair moving with ``v`` until its B event) to the running energy current; returns :math:`e_p`."""
    vx, vy, vz = v[0] + dv[0], v[1] + dv[1], v[2] + dv[2]
    e = _energy(mass, omega, inertia, p, vx, vy, vz, spin)
    energy_current(acc, 1.0, e, vx, vy, vz)
    return e


@leaf
def drift_flux(acc, m, e, ax, ay, az, cx, cy, cz):
    r"""Book a displacement :math:`\mathbf a` of a particle of mass ``m``, energy ``e`` and committed
    velocity :math:`\mathbf c` that its committed flight does not account for (eMD*'s relocation,
    :func:`.emdstar.book_relocation`): :math:`\tfrac m2(\mathbf a\otimes\mathbf c + \mathbf c\otimes\mathbf a)` to the
    virial tensor, :math:`m\,\mathbf a\cdot\mathbf c` to the scalar virial, :math:`e\,\mathbf a` to the energy transfer."""
    _add_symmetric(acc, A_VT, ax, ay, az, cx, cy, cz, 0.5 * m)
    acc[A_VIRIAL] += m * (ax * cx + ay * cy + az * cz)
    acc[A_QV] += e * ax
    acc[A_QV + 1] += e * ay
    acc[A_QV + 2] += e * az


@leaf
def pair_energy_current(acc, P, i, j, ei0, ej0, ei1, ej1, dix, diy, diz, djx, djy, djz, rx, ry, rz):
    r"""The energy current after a collision of ``i`` and ``j`` (rows already kicked by the velocity
    changes :math:`\Delta\mathbf v_{i,j}`; energies before and after): the running
    :math:`\sum e\mathbf v` and the transfer :math:`\tfrac12\mathbf r_{ij}(\Delta e_i - \Delta e_j)`, each
    accumulator written once."""
    h = 0.5 * ((ei1 - ei0) - (ej1 - ej0))
    for k, dvi, dvj, rk in ((0, dix, djx, rx), (1, diy, djy, ry), (2, diz, djz, rz)):
        vi, vj = P[i, VX + k], P[j, VX + k]
        acc[A_JE + k] += ei1 * vi - ei0 * (vi - dvi) + ej1 * vj - ej0 * (vj - dvj)
        acc[A_QV + k] += rk * h


@leaf
def _book_shear_work(acc, w):
    acc[A_KE] += w
    acc[A_SHEAR_WORK] += w


def impulse_shear_work(acc, ry, jx, geo):
    r"""Book the boundaries' work :math:`-\dot\gamma\,r_yJ_x` on the peculiar energy of an impulse
    :math:`\mathbf J` on a particle (or on ``i`` of a pair) at height (or height difference) ``r_y``
    (nothing in an unsheared box)."""
    if sheared(geo):
        _book_shear_work(acc, -geo[G_SHEAR_RATE] * ry * jx)


@overload(impulse_shear_work, inline="always")
def _impulse_shear_work_hook(acc, ry, jx, geo):
    if sheared_type(geo):
        return lambda acc, ry, jx, geo: _book_shear_work(acc, -geo[G_SHEAR_RATE] * ry * jx)
    return lambda acc, ry, jx, geo: None


@leaf
def _integrate_sheared(acc, t, geo):
    a = geo[G_SHEAR_RATE]
    tau = t - acc[A_LAST_T]
    kxx, kyy, kzz, kxy, kxz, kyz = acc[A_KT], acc[A_KT + 1], acc[A_KT + 2], acc[A_KT + 3], acc[A_KT + 4], acc[A_KT + 5]
    int_xx = kxx * tau - a * kxy * tau * tau + a * a * kyy * tau * tau * tau / 3.0
    int_xy = kxy * tau - 0.5 * a * kyy * tau * tau
    acc[A_KT_INT] += int_xx
    acc[A_KT_INT + 1] += kyy * tau
    acc[A_KT_INT + 2] += kzz * tau
    acc[A_KT_INT + 3] += int_xy
    acc[A_KT_INT + 4] += kxz * tau - 0.5 * a * kyz * tau * tau
    acc[A_KT_INT + 5] += kyz * tau
    acc[A_KE_INT] += 0.5 * (int_xx + (kyy + kzz) * tau)
    dxx = -2.0 * a * kxy * tau + a * a * kyy * tau * tau
    acc[A_KT] += dxx
    acc[A_KT + 3] -= a * kyy * tau
    acc[A_KT + 4] -= a * kyz * tau
    acc[A_KE] += 0.5 * dxx
    acc[A_SHEAR_WORK] -= a * int_xy
    acc[A_PX] -= a * acc[A_PY] * tau
    acc[A_LAST_T] = t


def integrate_sheared(acc, t, geo):
    r"""Advance the peculiar kinetic energy, tensor and momentum and their integrals to local time
    ``t`` in a sheared box (the closed forms of the module doc; :math:`P_x(\tau) = P_x - \dot\gamma P_y\tau`),
    with the boundaries' work, and say whether it did (not in an unsheared box)."""
    if sheared(geo):
        _integrate_sheared(acc, t, geo)
        return True
    return False


@overload(integrate_sheared, inline="always")
def _integrate_sheared_hook(acc, t, geo):
    if sheared_type(geo):

        def impl(acc, t, geo):
            _integrate_sheared(acc, t, geo)
            return True

        return impl
    return lambda acc, t, geo: False
