"""Instantaneous binary collision rules (physics.md §2).

A rule acts on two particles already streamed to the common contact time. It changes their
velocities (and spins), adds the collision virial :math:`\\mathbf r_{ij}\\cdot\\mathbf J` and the
kinetic-energy change to the accumulators, and returns the normal and tangential impact speeds.
"""

import math

from .jit import hot

from .layout import A_DISSIPATED, A_KE, A_VIRIAL, VX, VY, VZ, X, Y, Z
from .predict import wrap3

RULE_SMOOTH = 0


@hot
def contact_normal(P, i, j, geo):
    """Unit normal from ``j`` to ``i`` and the centre distance (minimum image)."""
    dx, dy, dz = wrap3(P[i, X] - P[j, X], P[i, Y] - P[j, Y], P[i, Z] - P[j, Z], geo)
    r = math.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / r
    return dx * inv, dy * inv, dz * inv, r


@hot
def collide_smooth(P, mass, i, j, e_n, geo, acc):
    r"""Smooth spheres with constant normal restitution, arbitrary masses (physics.md §2.1).

    .. math::
        \mathbf J = -(1+e_n)\,\mu\,(\mathbf g\cdot\hat{\mathbf n})\,\hat{\mathbf n},\qquad
        \mathbf v_i' = \mathbf v_i + \mathbf J/m_i,\quad \mathbf v_j' = \mathbf v_j - \mathbf J/m_j,\qquad
        \Delta E = -\tfrac12\mu(1-e_n^2)(\mathbf g\cdot\hat{\mathbf n})^2

    Returns the normal impact speed :math:`v_n = -\mathbf g\cdot\hat{\mathbf n}` and the
    tangential speed :math:`v_t`. A pair that is not approaching is left untouched.
    """
    nx, ny, nz, r = contact_normal(P, i, j, geo)
    gx = P[i, VX] - P[j, VX]
    gy = P[i, VY] - P[j, VY]
    gz = P[i, VZ] - P[j, VZ]
    gn = gx * nx + gy * ny + gz * nz
    g2 = gx * gx + gy * gy + gz * gz
    vt = math.sqrt(max(g2 - gn * gn, 0.0))
    if gn >= 0.0:
        return 0.0, vt
    mi = mass[i]
    mj = mass[j]
    mu = mi * mj / (mi + mj)
    jn = -(1.0 + e_n) * mu * gn
    ai = jn / mi
    aj = jn / mj
    P[i, VX] += ai * nx
    P[i, VY] += ai * ny
    P[i, VZ] += ai * nz
    P[j, VX] -= aj * nx
    P[j, VY] -= aj * ny
    P[j, VZ] -= aj * nz
    acc[A_VIRIAL] += r * jn
    de = -0.5 * mu * (1.0 - e_n * e_n) * gn * gn
    acc[A_KE] += de
    acc[A_DISSIPATED] -= de
    return -gn, vt
