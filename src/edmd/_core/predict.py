"""Event-time predictors: pair contact (physics.md §1.2), planar face/wall (§1.3, §1.4), shell exit.

All functions are plain ``@njit`` functions over scalars and the particle row array ``P``
(see :mod:`edmd._core.layout`). They never divide by a zero relative velocity.
"""

import math

import numpy as np
from numba.extending import overload

from .jit import jit, leaf

from .layout import G_GX, G_GY, G_GZ, G_LX, G_ON, R, T, VX, VY, VZ, X, Y, Z
from .images import _sheared_image, box_shift, shear_image, sheared, sheared_type, wrap3, wrap_delta  # noqa: F401 (the core imports them from here)
from .wallmotion import ride_flight

INF = np.inf
DISC_RESOLVED = 1e-290  # a discriminant below this has lost its digits to underflow (see contact_time)


@leaf
def contact_time(dx, dy, dz, gx, gy, gz, sigma):
    r"""Time until the separation ``(dx, dy, dz)`` moving with ``(gx, gy, gz)`` shrinks to ``sigma``.

    Implements the decision procedure of physics.md §1.2:

    .. math::
        a = \mathbf g\cdot\mathbf g,\quad b = \mathbf r\cdot\mathbf g,\quad c = r^2 - \sigma^2,\qquad
        \Delta t = \frac{c}{-b + \sqrt{b^2 - ac}}

    ``b >= 0`` (receding) gives no event even when overlapping, ``c <= 0`` with ``b < 0``
    (overlapping and approaching) gives ``0``, a non-positive discriminant gives no event, and so
    does one below ``DISC_RESOLVED`` = 1e-290: there :math:`a` or :math:`b^2` has underflowed
    (:math:`|\mathbf g| \lesssim 10^{-145}`, a contact some :math:`10^{145}` time units away) and the
    time would be finite but wrong. At ordinary speeds a discriminant
    :math:`a(\sigma^2 - d_\min^2)` that small is a graze to within :math:`10^{-290}/a` of
    :math:`\sigma^2` (:math:`d_\min` the closest approach), a miss like a zero one.
    Written without branches (every pair pays the square root, the selects become conditional
    moves): the receding/approaching test is a coin flip the branch predictor cannot learn,
    and branchless code is 1.6x faster over a neighbour list. The square root's guard and the
    no-event select share one predicate: with two (``disc > 0`` and ``disc > DISC_RESOLVED``)
    the dense list loop ran at 0.75 of its speed (paired, N = 10976, η = 0.5).

    Example:
        >>> round(contact_time(3.0, 1.0, 0.0, -1.0, 0.0, 0.0, 2.0), 12)
        1.267949192431
    """
    b = dx * gx + dy * gy + dz * gz
    c = dx * dx + dy * dy + dz * dz - sigma * sigma
    a = gx * gx + gy * gy + gz * gz
    disc = b * b - a * c
    resolved = disc > DISC_RESOLVED
    t = c / (math.sqrt(disc if resolved else 0.0) - b)
    t = t if resolved else INF
    t = 0.0 if c <= 0.0 else t
    return t if b < 0.0 else INF


@jit
def pending_contact_time(dx, dy, dz, gx, gy, gz, sigma, ti, ax, ay, az, tj, bx, by, bz):
    r"""Time until contact of a pair whose relative velocity jumps at the partners' pending eMD* B
    events (physics.md §4.8, "Predictions across B events").

    The separation :math:`\mathbf r` moves with :math:`\mathbf g` until the first B event, with
    :math:`\mathbf g + \boldsymbol\Delta_i` after ``ti`` and with :math:`\mathbf g - \boldsymbol\Delta_j` after ``tj``
    (times from now, ``inf``: none pending; ``(ax, ay, az)`` :math:`=\boldsymbol\Delta_i`, ``(bx, by, bz)``
    :math:`=\boldsymbol\Delta_j`). Each straight piece gets :func:`contact_time` from its start; the first
    contact within its piece is the answer (a contact at a B event's time belongs to the piece after
    it: B events come first at equal times).

    Example:
        >>> # at rest 3 apart until 0.5, then approaching at unit speed: contact at 0.5 + 1
        >>> pending_contact_time(3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.5, -1.0, 0.0, 0.0, math.inf, 0.0, 0.0, 0.0)
        1.5
    """
    if tj < ti:  # (the earlier jump first: j's, by -Delta_j, then i's)
        ti, tj = tj, ti
        ax, ay, az, bx, by, bz = -bx, -by, -bz, ax, ay, az
    else:
        bx, by, bz = -bx, -by, -bz
    dt = contact_time(dx, dy, dz, gx, gy, gz, sigma)
    if dt < ti or ti == INF:
        return dt
    dx, dy, dz = dx + gx * ti, dy + gy * ti, dz + gz * ti
    gx, gy, gz = gx + ax, gy + ay, gz + az
    dt = contact_time(dx, dy, dz, gx, gy, gz, sigma)
    h = tj - ti
    if dt < h or tj == INF:
        return ti + dt
    dx, dy, dz = dx + gx * h, dy + gy * h, dz + gz * h
    return tj + contact_time(dx, dy, dz, gx + bx, gy + by, gz + bz, sigma)


@jit
def sliding_contact_time(dx, dy, dz, gx, gy, gz, sigma, lx, horizon):
    r"""Earliest contact of a pair across a sliding Lees-Edwards face with any of the partner's x
    images: the separation to image :math:`k` is :math:`(d_x - kL_x, d_y, d_z) + \mathbf g\tau` (physics.md §5.7).

    The images slide past each other (:math:`g_x` holds the images' :math:`\dot\gamma L_y`), so the
    nearest image now need not be the one met: the tubes of radius :math:`\sigma` around the images
    are visited in the order the motion along x reaches them, while the :math:`(y, z)` separation is
    within :math:`\sigma`; the first contact found is the earliest (the tubes are disjoint, :math:`2\sigma < L_x`).
    Tubes entered after ``horizon`` (the earliest event known so far) are not visited, nor those
    passed before the :math:`(y, z)` separation enters the disc (a slow approach across the shear
    would otherwise visit ~:math:`|g_x| t_{\rm in}/L_x` images one by one). Called, not
    inlined: only pairs across the face take it (inlining it measured the same speed).

    Example:
        >>> # receding from the nearest image at x = 0, meeting the next one, 10 ahead
        >>> round(sliding_contact_time(0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 10.0, math.inf), 12)
        8.5
    """
    a = gy * gy + gz * gz
    b = dy * gy + dz * gz
    c = dy * dy + dz * dz - sigma * sigma
    t_in = 0.0
    t_out = horizon
    if a == 0.0:
        if c >= 0.0:
            return INF
    else:
        disc = b * b - a * c
        if disc <= 0.0:
            return INF
        root = math.sqrt(disc)
        t_out = min(t_out, (root - b) / a)
        if t_out <= 0.0:
            return INF
        if c > 0.0:  # (then b < 0) the (y, z) track enters the disc at t_in: tubes passed before are missed
            t_in = c / (root - b)
    if gx == 0.0:
        return contact_time(dx, dy, dz, gx, gy, gz, sigma)
    step = 1.0 if gx > 0.0 else -1.0
    x = dx + gx * t_in
    k = float(math.ceil((x - sigma) / lx) if gx > 0.0 else math.floor((x + sigma) / lx))
    if t_in > 0.0:
        k -= step  # (a margin for the round-off of t_in)
    if abs(k) > 2.0**50:
        return INF  # (images ~1e15 boxes away: neither they nor the time are resolved)
    missed = 0
    while (step * (k * lx - dx) - sigma) / abs(gx) < t_out:  # (the time the motion enters image k's tube)
        tk = contact_time(dx - k * lx, dy, dz, gx, gy, gz, sigma)
        if tk < INF:
            return tk
        missed += 1
        if a == 0.0 and missed == 2:  # motion along x only meets the first tube ahead: |g|^2 underflowed
            return INF
        k += step
    return INF


@leaf
def _sheared_contact_time(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon):
    dx, dy, dz, uj = _sheared_image(dx, dy, dz, t, geo)
    if uj == 0.0:
        return contact_time(dx, dy, dz, gx, gy, gz, sigma)
    return sliding_contact_time(dx, dy, dz, gx - uj, gy, gz, sigma, geo[G_LX], horizon)


def pair_contact_time(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon):
    """Time until the contact of a pair at the raw separation ``r_i - r_j`` with relative velocity
    ``g`` at local time ``t`` (through the minimum image; across a sliding Lees-Edwards face, through
    whichever image it meets first before ``horizon``: :func:`sliding_contact_time`)."""
    if sheared(geo):
        return _sheared_contact_time(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon)
    return contact_time(*wrap3(dx, dy, dz, geo), gx, gy, gz, sigma)


@overload(pair_contact_time, inline="always")
def _pair_contact_time_hook(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon):
    if sheared_type(geo):
        return lambda dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon: _sheared_contact_time(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon)

    def plain(dx, dy, dz, gx, gy, gz, sigma, t, geo, horizon):
        x, y, z = wrap3(dx, dy, dz, geo)
        return contact_time(x, y, z, gx, gy, gz, sigma)

    return plain


@leaf
def flight(P, i, t, geo):
    """Position and velocity of particle ``i`` at time ``t`` (physics.md §1.1, free flight; a
    particle riding on the vibrating wall moves with the wall along its axis, §1.6.3)."""
    dt = t - P[i, T]
    vx, vy, vz = P[i, VX], P[i, VY], P[i, VZ]
    x = P[i, X] + vx * dt
    y = P[i, Y] + vy * dt
    z = P[i, Z] + vz * dt
    if geo[G_ON] != 0.0:
        h = 0.5 * dt * dt
        x += geo[G_GX] * h
        y += geo[G_GY] * h
        z += geo[G_GZ] * h
        vx += geo[G_GX] * dt
        vy += geo[G_GY] * dt
        vz += geo[G_GZ] * dt
    return ride_flight(P, i, t, geo, x, y, z, vx, vy, vz)


@leaf
def advance(P, i, t, geo):
    """Stream the stored row of ``i`` to time ``t`` (lazy update, physics.md §1.1)."""
    x, y, z, vx, vy, vz = flight(P, i, t, geo)
    P[i, X] = x
    P[i, Y] = y
    P[i, Z] = z
    P[i, VX] = vx
    P[i, VY] = vy
    P[i, VZ] = vz
    P[i, T] = t


@leaf
def relative_to(xi, yi, zi, vxi, vyi, vzi, P, j, t, geo):
    """Minimum-image separation and relative velocity of a particle at ``(x_i, v_i)`` and ``j`` at time ``t``."""
    xj, yj, zj, vxj, vyj, vzj = flight(P, j, t, geo)
    dx, dy, dz, uj = shear_image(xi - xj, yi - yj, zi - zj, t, geo)
    return dx, dy, dz, vxi - vxj - uj, vyi - vyj, vzi - vzj


@leaf
def separation(P, i, j, t, geo):
    """Minimum-image separation ``r_i(t) - r_j(t)`` and relative velocity ``v_i(t) - v_j(t)`` (of
    the image of ``j`` nearest ``i``: under shear, its velocity is shifted with it, :mod:`.images`)."""
    xi, yi, zi, vxi, vyi, vzi = flight(P, i, t, geo)
    return relative_to(xi, yi, zi, vxi, vyi, vzi, P, j, t, geo)


@leaf
def pair_time(P, i, j, t, geo):
    """Absolute time of the next contact of ``i`` and ``j`` seen from time ``t`` (``inf``: none)."""
    dx, dy, dz, gx, gy, gz = separation(P, i, j, t, geo)
    return t + contact_time(dx, dy, dz, gx, gy, gz, P[i, R] + P[j, R])


@leaf
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


@leaf
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
