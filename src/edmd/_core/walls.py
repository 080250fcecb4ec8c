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

from numba import types
from numba.extending import overload

from .jit import jit, leaf
from .layout import G_WALL_A, G_WALL_AXIS, G_WALL_FACE, G_WALL_OMEGA, G_WALL_PHASE, G_WALL_WAVE, NO_MOVING_WALL, WAVE_SINE, WAVE_TRIANGLE
from .predict import INF, gap_time

TWO_PI = 2.0 * math.pi


def wall_params(geo):
    """The vibrating wall's ``(axis, face, wave, amplitude, omega, phase at local time 0)`` of a
    geometry (:func:`.layout.make_geo`); ``NO_MOVING_WALL`` when it has none.

    Compiled code reads them by the tuple's length at typing time (:func:`_wall_params`): the
    wall code of a run without a vibrating wall folds to nothing.

    Example:
        >>> wall_params((1.0,) * 10)
        (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    """
    return tuple(geo[G_WALL_AXIS : G_WALL_PHASE + 1]) if len(geo) > G_WALL_AXIS else NO_MOVING_WALL


@overload(wall_params, inline="always")
def _wall_params(geo):
    if isinstance(geo, types.BaseTuple) and len(geo) > G_WALL_AXIS:
        return lambda geo: (geo[G_WALL_AXIS], geo[G_WALL_FACE], geo[G_WALL_WAVE], geo[G_WALL_A], geo[G_WALL_OMEGA], geo[G_WALL_PHASE])
    return lambda geo: (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # NO_MOVING_WALL


@leaf
def wave_value(wave, theta):
    r"""The waveform :math:`w(\theta)` and :math:`dw/d\theta` (see the module doc).

    Example:
        >>> from edmd._core.layout import WAVE_TRIANGLE
        >>> w, dw = wave_value(WAVE_TRIANGLE, 0.5 * math.pi)   # the triangle's peak
        >>> round(w, 12), round(dw * math.pi, 12)
        (1.0, -2.0)
    """
    if wave == WAVE_SINE:
        return math.sin(theta), math.cos(theta)
    return _linear_wave(wave, _cycle(wave, theta))


@leaf
def _cycle(wave, theta):
    """Where a triangle or sawtooth wave is in its cycle: the fraction ``q`` in ``[0, 1)``, counted
    from the start of its rising piece (where ``w = -1``)."""
    q = theta / TWO_PI + (0.25 if wave == WAVE_TRIANGLE else 0.5)
    return q - math.floor(q)


@leaf
def _linear_wave(wave, q):
    """``w`` and ``dw/dtheta`` of a triangle or sawtooth wave at cycle fraction ``q`` (:func:`_cycle`)."""
    if wave == WAVE_TRIANGLE:
        if q < 0.5:
            return -1.0 + 4.0 * q, 4.0 / TWO_PI
        return 3.0 - 4.0 * q, -4.0 / TWO_PI
    return -1.0 + 2.0 * q, 2.0 / TWO_PI


@leaf
def wall_shift(t, geo):
    """Displacement of the vibrating wall into the box and its rate at local time ``t``."""
    _k, _face, wave, a, om, phase = wall_params(geo)
    w, dw = wave_value(int(wave), phase + om * t)
    return a * (1.0 + w), a * om * dw


@leaf
def is_moving(k, face, geo):
    """Whether wall ``face`` (0 lower, 1 upper) of axis ``k`` is the vibrating wall."""
    p = wall_params(geo)
    return p[0] == k and p[1] == face


@leaf
def wall_velocity(k, face, t, geo):
    """Lab-frame velocity along axis ``k`` of wall ``face`` at local time ``t`` (0 for a fixed wall)."""
    if not is_moving(k, face, geo):
        return 0.0
    _d, u = wall_shift(t, geo)
    return u if face == 0 else -u


@leaf
def wall_planes(k, t, geo):
    """Positions of the lower and upper wall of axis ``k`` at local time ``t``."""
    half = 0.5 * geo[k]
    lo, hi = -half, half
    p = wall_params(geo)
    if p[0] == k:
        d, _u = wall_shift(t, geo)
        if p[1] == 0:
            lo += d
        else:
            hi -= d
    return lo, hi


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
