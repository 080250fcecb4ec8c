"""Event-time predictors: pair contact (physics.md §1.2), planar face/wall (§1.3, §1.4), shell exit.

All functions are plain ``@njit`` functions over scalars and the particle row array ``P``
(see :mod:`edmd._core.layout`). They never divide by a zero relative velocity.
"""

import math

import numpy as np
from numba import njit

from .layout import R, T, VX, VY, VZ, X, Y, Z

INF = np.inf


@njit(cache=True, inline="always")
def contact_time(dx, dy, dz, gx, gy, gz, sigma):
    r"""Time until the separation ``(dx, dy, dz)`` moving with ``(gx, gy, gz)`` shrinks to ``sigma``.

    Implements the decision procedure of physics.md §1.2:

    .. math::
        a = \mathbf g\cdot\mathbf g,\quad b = \mathbf r\cdot\mathbf g,\quad c = r^2 - \sigma^2,\qquad
        \Delta t = \frac{c}{-b + \sqrt{b^2 - ac}}

    ``b >= 0`` (receding) gives no event even when overlapping, ``c <= 0`` with ``b < 0``
    (overlapping and approaching) gives ``0``, a non-positive discriminant gives no event.

    Example:
        >>> round(contact_time(3.0, 1.0, 0.0, -1.0, 0.0, 0.0, 2.0), 12)
        1.267949192431
    """
    b = dx * gx + dy * gy + dz * gz
    if b >= 0.0:
        return INF
    c = dx * dx + dy * dy + dz * dz - sigma * sigma
    if c <= 0.0:
        return 0.0
    a = gx * gx + gy * gy + gz * gz
    disc = b * b - a * c
    if disc <= 0.0:
        return INF
    return c / (-b + math.sqrt(disc))


@njit(cache=True, inline="always")
def wrap_delta(d, length, half):
    """Minimum-image shift of one separation component (``half = inf`` on open axes)."""
    if d > half:
        return d - length
    if d < -half:
        return d + length
    return d


@njit(cache=True, inline="always")
def flight(P, i, t, grav):
    """Position and velocity of particle ``i`` at time ``t`` (physics.md §1.1, free flight)."""
    dt = t - P[i, T]
    x = P[i, X] + P[i, VX] * dt
    y = P[i, Y] + P[i, VY] * dt
    z = P[i, Z] + P[i, VZ] * dt
    vx, vy, vz = P[i, VX], P[i, VY], P[i, VZ]
    if grav[3] != 0.0:
        h = 0.5 * dt * dt
        x += grav[0] * h
        y += grav[1] * h
        z += grav[2] * h
        vx += grav[0] * dt
        vy += grav[1] * dt
        vz += grav[2] * dt
    return x, y, z, vx, vy, vz


@njit(cache=True, inline="always")
def advance(P, i, t, grav):
    """Stream the stored row of ``i`` to time ``t`` (lazy update, physics.md §1.1)."""
    x, y, z, vx, vy, vz = flight(P, i, t, grav)
    P[i, X] = x
    P[i, Y] = y
    P[i, Z] = z
    P[i, VX] = vx
    P[i, VY] = vy
    P[i, VZ] = vz
    P[i, T] = t


@njit(cache=True, inline="always")
def separation(P, i, j, t, box, half, grav):
    """Minimum-image separation ``r_i(t) - r_j(t)`` and relative velocity ``v_i(t) - v_j(t)``.

    Particles are stored lazily at their own times ``P[:, T]`` (physics.md §1.1); gravity
    ``grav`` (with ``grav[3] != 0`` as the flag that it is on) is included exactly.
    """
    ti = t - P[i, T]
    tj = t - P[j, T]
    dx = P[i, X] + P[i, VX] * ti - P[j, X] - P[j, VX] * tj
    dy = P[i, Y] + P[i, VY] * ti - P[j, Y] - P[j, VY] * tj
    dz = P[i, Z] + P[i, VZ] * ti - P[j, Z] - P[j, VZ] * tj
    gx = P[i, VX] - P[j, VX]
    gy = P[i, VY] - P[j, VY]
    gz = P[i, VZ] - P[j, VZ]
    if grav[3] != 0.0:
        hq = 0.5 * (ti * ti - tj * tj)
        dt = ti - tj
        dx += grav[0] * hq
        dy += grav[1] * hq
        dz += grav[2] * hq
        gx += grav[0] * dt
        gy += grav[1] * dt
        gz += grav[2] * dt
    dx = wrap_delta(dx, box[0], half[0])
    dy = wrap_delta(dy, box[1], half[1])
    dz = wrap_delta(dz, box[2], half[2])
    return dx, dy, dz, gx, gy, gz


@njit(cache=True, inline="always")
def pair_time(P, i, j, t, box, half, grav):
    """Absolute time of the next contact of ``i`` and ``j`` seen from time ``t`` (``inf``: none)."""
    dx, dy, dz, gx, gy, gz = separation(P, i, j, t, box, half, grav)
    return t + contact_time(dx, dy, dz, gx, gy, gz, P[i, R] + P[j, R])


@njit(cache=True, inline="always")
def gap_time(h0, u, a):
    r"""First time ``> 0`` at which the gap :math:`h(t) = h_0 + u t + a t^2/2` closes with :math:`\dot h < 0`.

    physics.md §1.3: the gap to a plane (a wall, or a cell face for §1.4) with gap velocity ``u``
    and gap acceleration ``a`` (the component of gravity along the plane's inward normal).
    Cancellation-free roots; a round-off overlap that is closing (``h0 <= 0``, ``u < 0``), or a
    particle that can never get back in front of the plane, gives ``0``.

    Example:
        >>> gap_time(1.0, 0.0, -2.0)   # dropped from h0 = 1 with |G| = 2: sqrt(2 h0 / |G|)
        1.0
    """
    if h0 <= 0.0 and u < 0.0:
        return 0.0
    if a == 0.0:
        if u < 0.0:
            return h0 / (-u)
        return INF
    if a < 0.0:
        disc = u * u - 2.0 * a * h0
        if disc <= 0.0:
            return 0.0
        s = math.sqrt(disc)
        if u >= 0.0:
            return (u + s) / (-a)
        return 2.0 * h0 / (s - u)
    if u >= 0.0:
        return INF
    disc = u * u - 2.0 * a * h0
    if disc < 0.0:
        return INF
    return 2.0 * h0 / (-u + math.sqrt(disc))


@njit(cache=True, inline="always")
def sphere_exit_time(dx, dy, dz, vx, vy, vz, radius):
    r"""Time until a ballistic point at offset ``d`` from a centre leaves the ball of ``radius``.

    Larger root of :math:`|\mathbf d + \mathbf v t|^2 = \delta^2`, written without cancellation.
    """
    a = vx * vx + vy * vy + vz * vz
    if a == 0.0:
        return INF
    b = dx * vx + dy * vy + dz * vz
    c = dx * dx + dy * dy + dz * dz - radius * radius
    if c >= 0.0:
        return 0.0
    disc = math.sqrt(b * b - a * c)
    if b > 0.0:
        return -c / (b + disc)
    return (disc - b) / a
