r"""The vibrating wall: a planar wall moving along its normal as a prescribed function of time
(physics.md §1.6), the first moving boundary of the event interface.

One wall of a walled axis (axis and face in :func:`wall_params`) is displaced into the box by

.. math::
    d(t) = a\,\bigl(1 + w(\theta)\bigr),\qquad \theta = \omega t + \varphi,\qquad w \in [-1, 1],

so it sweeps :math:`[0, 2a]` from its rest plane at :math:`\pm L/2` and the box always holds it.
``w`` is :math:`\sin\theta` (``WAVE_SINE``), a triangle wave or a sawtooth (``WAVE_TRIANGLE``,
``WAVE_SAWTOOTH``); the piecewise-linear waves have :math:`w(0) = 0` rising like the sine, and
the sawtooth's jump moves the wall out of the box (it never jumps into a particle). Times in the
core are local: the phase of :func:`wall_params` is :math:`\theta` at local time 0.

**Contact times** (:func:`moving_wall_time`). With the particle's gap to the rest plane
:math:`h(s) = h_0 + v s + g s^2/2` (``g`` the component of gravity along the wall's inward
normal), the wall is met when :math:`f(s) = h(s) - d(t + s)` reaches 0 with :math:`\dot f < 0`.
The search skips the flight above the wall's reach (:math:`h > 2a`, closed form), then walks
segments on which the root is certain:

* sine: :math:`\ddot f = g + a\omega^2\sin\theta` changes sign only where
  :math:`\sin\theta = -g/(a\omega^2)`; between two such points ``f`` is convex or concave, and a
  convex or concave function has at most one closing root in a segment, which the signs of ``f``
  and :math:`\dot f` at the ends (and at the turning point of ``f``, the root of the monotonic
  :math:`\dot f`) decide and bracket. A bracketed root is refined by Newton steps kept inside
  the bracket (bisection otherwise). No root can be skipped, grazing ones included: the
  bound on the relative acceleration that Bannerman et al. (J. Comput. Chem. 35, 2014) use is
  here exact, as the inflection points themselves;
* triangle and sawtooth: on each linear piece the wall moves with constant velocity and ``f`` is
  a parabola, solved in closed form (:func:`.predict.gap_time`).

The search ends at ``horizon`` (the particle's next other event, after which it is re-predicted).

**Collisions** act in the wall's frame (:func:`edmd._core.collide.collide_wall` with
:func:`wall_velocity`): restitution and roughness apply to the velocity relative to the wall,
and the work done by the wall, :math:`W = u\,J_n`, is booked as energy input.
"""

import math

from .jit import jit, leaf
from numba.extending import overload

from .layout import G_GX, R, RIDE, ROW, WAVE_SINE, WAVE_TRIANGLE
from .predict import INF, flight, gap_time, wrap3
from .wallmotion import TWO_PI, _cycle, _linear_wave, vibrating_type, has_wall, ride_axis, ride_end, rider_axis, wall_params


@leaf
def _gap(s, h, v, g, a, om, th):
    """The sine wall's gap :math:`f(s)` and its first two derivatives."""
    ts = th + om * s
    sn = math.sin(ts)
    return h + v * s + 0.5 * g * s * s - a * (1.0 + sn), v + g * s - a * om * math.cos(ts), g + a * om * om * sn


@jit
def _bracket(order, lo, hi, h, v, g, a, om, th, scale):
    """Root of the ``order``-th derivative of the gap (0: ``f``, 1: its turning point) in ``[lo, hi]``,
    which holds exactly one sign change: Newton steps inside the bracket, bisection otherwise,
    down to the resolution of the absolute time (``scale``)."""
    side = _gap(lo, h, v, g, a, om, th)[order] > 0.0
    x = hi
    for _ in range(200):
        vals = _gap(x, h, v, g, a, om, th)
        fx, dx = vals[order], vals[order + 1]
        if (fx > 0.0) == side:
            lo = x
        else:
            hi = x
        nx = x - fx / dx if dx != 0.0 else lo
        if abs(nx - x) <= 4.4e-16 * scale:
            return min(max(nx, lo), hi)
        if not (lo < nx < hi):
            nx = 0.5 * (lo + hi)
            if nx <= lo or nx >= hi:
                return hi
        x = nx
    return hi


@jit
def _sine_root(sa, sb, h, v, g, a, om, th, scale):
    """Earliest closing root of the sine wall's gap on a segment of fixed convexity (``INF``: none)."""
    fa, da, _ca = _gap(sa, h, v, g, a, om, th)
    if fa <= 0.0 and da < 0.0:
        return sa  # touching (round-off) and approaching: now
    fb, db, _cb = _gap(sb, h, v, g, a, om, th)
    if _gap(0.5 * (sa + sb), h, v, g, a, om, th)[2] >= 0.0:  # convex: f' increases
        if da >= 0.0:
            return INF
        if db <= 0.0:
            return _bracket(0, sa, sb, h, v, g, a, om, th, scale) if fb <= 0.0 else INF
        sm = _bracket(1, sa, sb, h, v, g, a, om, th, scale)
        return _bracket(0, sa, sm, h, v, g, a, om, th, scale) if _gap(sm, h, v, g, a, om, th)[0] <= 0.0 else INF
    if fa > 0.0:  # concave and clear of the wall: a closing root iff f(sb) <= 0, and it is unique
        return _bracket(0, sa, sb, h, v, g, a, om, th, scale) if fb <= 0.0 else INF
    if da <= 0.0:  # at the wall (round-off) and not leaving it: the concave gap closes at once
        return sa
    if db >= 0.0:  # at the wall (round-off) and still leaving it
        return INF
    sm = _bracket(1, sa, sb, h, v, g, a, om, th, scale)
    if _gap(sm, h, v, g, a, om, th)[0] <= 0.0:
        return sm  # it never got clear: it meets the wall again where it turns back
    return _bracket(0, sm, sb, h, v, g, a, om, th, scale) if fb <= 0.0 else INF


@leaf
def _sine_segment(theta, c, tiny):
    """Phase to the next inflection of the sine gap (where ``sin = c``), or one period if none.
    An inflection closer than ``tiny`` (round-off of the phase) is the one just passed."""
    if not abs(c) < 1.0:
        return TWO_PI
    alpha = math.asin(c)
    q = theta - TWO_PI * math.floor(theta / TWO_PI)
    best = TWO_PI
    for b in (alpha, math.pi - alpha):
        d = b - q
        d -= TWO_PI * math.floor(d / TWO_PI)
        if tiny < d < best:
            best = d
    return best


@leaf
def _piece(wave, theta, tiny):
    """The linear piece of a triangle or sawtooth wave at phase ``theta``: the phase left in it,
    ``w`` and ``dw/dtheta`` there. A piece ending within ``tiny`` (round-off) is taken as ended."""
    q = _cycle(wave, theta)
    ends = (0.5, 1.0) if wave == WAVE_TRIANGLE else (1.0, 1.0)
    end = ends[0] if q < ends[0] else ends[1]
    if end - q < tiny / TWO_PI:
        q = 0.0 if end == 1.0 else end
        end = ends[0] if q < ends[0] else ends[1]
    w, dw = _linear_wave(wave, q)
    return (end - q) * TWO_PI, w, dw


@jit
def moving_wall_time(h, v, g, t, geo, horizon):
    """Time until a particle meets the vibrating wall, seen from local time ``t`` (``INF``: not
    before ``horizon``).

    ``h``, ``v`` and ``g`` are the gap between the particle's surface and the wall's rest plane,
    and its velocity and acceleration along the wall's inward normal (see the module doc).

    Example:
        >>> from edmd._core.layout import WAVE_SINE, make_geo
        >>> import numpy as np
        >>> box, half = np.full(3, 10.0), np.array([np.inf, np.inf, 5.0])
        >>> geo = make_geo(box, half, None, (2, 0, WAVE_SINE, 0.1, 2.0, 0.0))
        >>> round(moving_wall_time(1.0, -1.0, 0.0, 0.0, geo, np.inf), 12)   # meets w = sin(2 s)
        0.80004289054
    """
    _k, _face, wave, a, om, phase = wall_params(geo)
    wave = int(wave)
    th = phase + om * t
    reach = 2.0 * a
    c = -g / (a * om * om)
    s = 0.0
    while True:
        hs = h + v * s + 0.5 * g * s * s
        if hs > reach:  # above the wall's reach: skip the flight down to it
            skip = gap_time(hs - reach, v + g * s, g)
            if skip == INF:
                return INF
            s += skip
            hs = h + v * s + 0.5 * g * s * s
        if s >= horizon:
            return INF
        tiny = 1e-12 + 4e-16 * om * (abs(t) + s)  # the phase's round-off: segments are longer
        if wave == WAVE_SINE:
            end = min(s + _sine_segment(th + om * s, c, tiny) / om, horizon)
            root = _sine_root(s, end, h, v, g, a, om, th, abs(t) + abs(end))
        else:
            dphase, w, dw = _piece(wave, th + om * s, tiny)
            end = min(s + dphase / om, horizon)
            root = s + gap_time(hs - a * (1.0 + w), v + g * s - a * om * dw, g)
            if root > end:
                root = INF
        if root < INF:
            return root
        s = end


#: steps of :func:`ride_contact_time`'s search before it gives up (never reached in the tests)
MAX_RIDE_STEPS = 100000


@jit
def ride_contact_time(xf, yf, zf, vxf, vyf, vzf, rf, P, q, t, geo):
    r"""Time until a free particle (radius ``rf``, at ``x_f`` with ``v_f`` at local time ``t``)
    touches particle ``q``, which rides on the vibrating wall (``INF``: not before ``q`` takes off).

    Across the wall's axis the separation moves linearly (both feel the same gravity), along
    it the rider follows the wall and the free particle its parabola:
    :math:`f(s) = |\mathbf p_\perp + \mathbf w_\perp s|^2 + \Delta_k(s)^2 - \sigma^2`. The contact is
    the first root of ``f`` with :math:`\dot f < 0`, searched between the roots of the
    transverse part and the take-off (:func:`.wallmotion.ride_end`) by conservative
    advancement (Bannerman et al.'s stable event detection): over a window where
    :math:`|\ddot\Delta_k| \le Z_2 = a\omega^2 + |G_k|` and :math:`|\Delta_k| \le Z`,
    :math:`\ddot f \ge 2|\mathbf w_\perp|^2 - 2 Z Z_2 =: -F`, so ``f`` stays positive for the step
    to the positive root of :math:`f + \dot f s - F s^2/2`. The steps never pass a root and
    converge on it like Newton's from the safe side.

    Example:
        >>> import numpy as np
        >>> from edmd._core import layout as L
        >>> geo = L.make_geo(np.full(3, 10.0), np.array([5.0, 5.0, np.inf]), np.array([0.0, 0.0, -1.0]), (2, 0, L.WAVE_SINE, 0.1, 1.0, 0.0, 1e-6))
        >>> P = np.zeros((1, L.ROW + 1)); P[0, L.R] = 0.5; P[0, L.RIDE] = 1.0   # rides at z = -5 + 0.1 + 0.5
        >>> s = ride_contact_time(0.0, 0.0, -2.4, 0.0, 0.0, 0.0, 0.5, P, 0, 0.0, geo)   # dropped from 2 above it
        >>> round(s, 9)   # the root of 1 - s^2/2 - 0.1 sin(s) = 0
        1.343555601
    """
    xq, yq, zq, vxq, vyq, vzq = flight(P, q, t, geo)
    dx, dy, dz = wrap3(xq - xf, yq - yf, zq - zf, geo)
    d = (dx, dy, dz)
    w = (vxq - vxf, vyq - vyf, vzq - vzf)
    k, _sign, _gn = ride_axis(geo)
    rq = P[q, R]
    sigma = rq + rf
    pp = pw = ww = 0.0
    for m in range(3):
        if m != k:
            pp += d[m] * d[m]
            pw += d[m] * w[m]
            ww += w[m] * w[m]
    lo, end = 0.0, ride_end(t, geo) - t
    c = pp - sigma * sigma
    if ww > 0.0:  # the transverse separation is within sigma between two roots
        disc = pw * pw - ww * c
        if disc <= 0.0:
            return INF
        root = math.sqrt(disc)
        lo = max(lo, (-pw - root) / ww)
        end = min(end, (-pw + root) / ww)
    elif c > 0.0:
        return INF
    xk0, vk0, gk = (xf, yf, zf)[k], (vxf, vyf, vzf)[k], geo[G_GX + k]
    _k, _face, wave, a, om, _phase = wall_params(geo)
    z2 = abs(gk) + (a * om * om if int(wave) == WAVE_SINE else 0.0)
    s = lo
    window = sigma / (math.sqrt(ww) + abs(w[k]) + math.sqrt(sigma * z2) + 1e-300)
    for _ in range(MAX_RIDE_STEPS):
        if s >= end:
            return INF
        _k, xq_k, vq_k = rider_axis(t + s, rq, geo)
        dk = xq_k - (xk0 + vk0 * s + 0.5 * gk * s * s)
        dk1 = vq_k - (vk0 + gk * s)
        f = pp + 2.0 * pw * s + ww * s * s + dk * dk - sigma * sigma
        f1 = 2.0 * (pw + ww * s + dk * dk1)
        h = min(end - s, window)
        big = 2.0 * (abs(dk) + h * abs(dk1) + 0.5 * h * h * z2) * z2 - 2.0 * ww  # F
        res = 2.3e-16 * (abs(t) + s) + 1e-300  # the resolution of the clock
        if f <= 0.0:
            if f1 < 0.0:
                return s  # touching and approaching
            step = max(f1 / big if big > 0.0 else INF, 16.0 * res)  # f' >= 0 for this long: no closing root
        else:
            if big > 0.0:
                root = math.sqrt(f1 * f1 + 2.0 * big * f)
                step = 2.0 * f / (root - f1) if f1 < 0.0 else (f1 + root) / big
            else:  # convex over the window: the tangent bounds f from below
                step = f / -f1 if f1 < 0.0 else INF
            if f1 < 0.0 and step <= res:
                return s + step  # converged on the closing root from the safe side
        if step >= h:  # no closing root in the window
            if h >= end - s:
                return INF  # (the window reached the end: none before it)
            step = h
            window = 2.0 * h
        else:
            window = 4.0 * step
        s += step
    return s


@jit
def _rider_pair_dt(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, ride_i):
    if not ride_i:
        return ride_contact_time(xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo)
    xj, yj, zj, vxj, vyj, vzj = flight(P, j, t, geo)
    return ride_contact_time(xj, yj, zj, vxj, vyj, vzj, P[j, R], P, i, t, geo)


@leaf
def _ride_pair_dt(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, dt):
    ride_i = P.shape[1] > ROW and P[i, RIDE] != 0.0
    if ride_i == (P.shape[1] > ROW and P[j, RIDE] != 0.0):
        return dt  # (two riders move alike along the wall's axis: a straight relative flight)
    return _rider_pair_dt(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, ride_i)


def ride_pair_dt(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, dt):
    """The contact time of ``i`` (at ``x_i`` with ``v_i``, radius ``ri``) and ``j`` when one of them rides on the vibrating wall (:func:`ride_contact_time`); ``dt``,
    the straight-flight time, otherwise."""
    if has_wall(geo) and P.shape[1] > ROW:
        return _ride_pair_dt(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, dt)
    return dt


@overload(ride_pair_dt, inline="always")
def _ride_pair_dt_hook(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, dt):
    if vibrating_type(geo):
        return lambda i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, dt: _ride_pair_dt(i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, dt)
    return lambda i, xi, yi, zi, vxi, vyi, vzi, ri, P, j, t, geo, dt: dt
