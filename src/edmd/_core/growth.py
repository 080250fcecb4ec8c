r"""Growing particles, Lubachevsky–Stillinger compression (docs/physics.md §1.7): pair times and collisions.

Every radius grows linearly in time, :math:`R_i(t) = R_i(t_0)(1 + g(t - t_0))`, so size ratios are
kept. Within a load of the engine (local time :math:`\tau` from 0) the stored radii are those of
the load and grow at the local rate :math:`\gamma = g/(1 + g(t_{\rm load} - t_0))`
(``fp[FP_GROW_LOCAL]``): :math:`\sigma_{ij}(\tau) = \sigma_{ij}(1 + \gamma\tau)`.
"""

import math

from . import layout as L
from .collide import contact_normal, pair_impulse
from .jit import hot, leaf
from .predict import DISC_RESOLVED, INF, relative_to


@leaf
def growing_contact_time(dx, dy, dz, gx, gy, gz, s, ds):
    r"""Time until the separation ``d`` moving with ``g`` meets the contact distance ``s`` growing at ``ds``.

    The root of :math:`|\mathbf d + \mathbf g t|^2 = (s + \dot s t)^2` at which the gap closes:
    with :math:`a = g^2 - \dot s^2`, :math:`b = \mathbf d\cdot\mathbf g - s\dot s`, :math:`c = d^2 - s^2`,
    a closing gap (:math:`b < 0`) meets at :math:`c/(-b + \sqrt{b^2 - ac})` (0 if already touching;
    never if the discriminant is below ``DISC_RESOLVED``, where it has underflowed, as in
    :func:`.predict.contact_time`); an opening one only when the growth outruns the flight
    (:math:`a < 0`), at :math:`(b + \sqrt{b^2 - ac})/(-a)`.

    Example:
        >>> round(growing_contact_time(3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.5), 12)   # at rest: 1 + t/2 = 3
        4.0
    """
    a = gx * gx + gy * gy + gz * gz - ds * ds
    b = dx * gx + dy * gy + dz * gz - s * ds
    c = dx * dx + dy * dy + dz * dz - s * s
    disc = b * b - a * c
    if b < 0.0:
        if c <= 0.0:
            return 0.0
        if disc <= DISC_RESOLVED:
            return INF
        return c / (math.sqrt(disc) - b)
    if a >= 0.0:
        return INF
    if disc <= 0.0:  # overlapping by round-off, and staying so: collide now
        return 0.0
    return (b + math.sqrt(disc)) / (-a)


@hot
def closer_grow(xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, rate, best, bj):
    """The earlier of the current best ``(dt, partner)`` and the contact of growing ``i`` and ``j`` (local rate ``rate``)."""
    dx, dy, dz, gx, gy, gz = relative_to(xi, yi, zi, vxi, vyi, vzi, P, j, t, geo)
    s0 = ri + P[j, L.R]
    dt = growing_contact_time(dx, dy, dz, gx, gy, gz, s0 * (1.0 + rate * t), s0 * rate)
    if dt < best:
        return dt, j
    return best, bj


@hot
def collide_growing(P, mass, omega, inertia, i, j, geo, fp, acc, rate):
    r"""Collide growing smooth ``i`` and ``j`` (streamed to contact): restitution of the gap's rate.

    The surfaces separate at :math:`u = g_n - \dot\sigma` (:math:`\dot\sigma = \sigma_{ij}\gamma`); the
    collision reverses it, :math:`u' = -e_nu`, so :math:`g_n' = \dot\sigma - e_n(g_n - \dot\sigma)` and the
    pair separates after contact. The impulse :math:`J = \mu(g_n' - g_n)` enters the virial; the
    kinetic energy changes by :math:`\tfrac12\mu(g_n'^2 - g_n^2)`, of which
    :math:`\tfrac12\mu(1 - e_n^2)u^2` is dissipated and the rest is the work of the growth (energy input).
    Returns the normal impact speed of the surfaces, :math:`-u`.
    """
    nx, ny, nz, r, _uj = contact_normal(P, i, j, geo)  # (never sheared)
    gn = (P[i, L.VX] - P[j, L.VX]) * nx + (P[i, L.VY] - P[j, L.VY]) * ny + (P[i, L.VZ] - P[j, L.VZ]) * nz
    ds = (P[i, L.R] + P[j, L.R]) * rate
    u = gn - ds
    if u >= 0.0:
        return 0.0
    mi, mj = mass[i], mass[j]
    mu = mi * mj / (mi + mj)
    e = fp[L.FP_EN]
    new = ds - e * u
    jn = mu * (new - gn)
    pair_impulse(P, mass, omega, inertia, i, j, jn, nx, ny, nz, r, acc)
    dk = 0.5 * mu * (new * new - gn * gn)
    lost = 0.5 * mu * (1.0 - e * e) * u * u
    acc[L.A_KE] += dk
    acc[L.A_DISSIPATED] += lost
    acc[L.A_ENERGY_INPUT] += dk + lost
    return -u
