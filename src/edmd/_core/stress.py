r"""Accumulators of the stress tensor (physics.md §5.3): its kinetic part and the collisions' virial.

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
"""

from .jit import leaf
from .layout import A_KT, A_KT_INT, A_PX, A_PY, A_PZ, A_VT, G_GX, G_GY, G_GZ, G_ON


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
def free_fall_tensor(acc, tau, geo, total_mass):
    r"""Advance the kinetic tensor and its integral over ``tau`` between events, with the total
    momentum :math:`\mathbf P` before it (:func:`.wallmotion.free_fall` then advances it): under
    gravity :math:`\mathsf K(\tau) = \mathsf K_0 + (\mathbf G\otimes\mathbf P + \mathbf P\otimes\mathbf G)\tau
    + M\,\mathbf G\otimes\mathbf G\,\tau^2`, integrated exactly."""
    for c in range(6):
        acc[A_KT_INT + c] += acc[A_KT + c] * tau
    if geo[G_ON] != 0.0:
        gx, gy, gz = geo[G_GX], geo[G_GY], geo[G_GZ]
        px, py, pz = acc[A_PX], acc[A_PY], acc[A_PZ]
        _add_symmetric(acc, A_KT_INT, gx, gy, gz, px, py, pz, 0.5 * tau * tau)
        _add_symmetric(acc, A_KT_INT, gx, gy, gz, gx, gy, gz, total_mass * tau * tau * tau / 6.0)
        _add_symmetric(acc, A_KT, gx, gy, gz, px, py, pz, tau)
        _add_symmetric(acc, A_KT, gx, gy, gz, gx, gy, gz, 0.5 * total_mass * tau * tau)
