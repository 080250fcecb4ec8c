r"""Kinematics of the vibrating wall and of the particles riding on it (physics.md §1.6).

The wall (one wall of a walled axis, see :func:`wall_params`) is displaced into the box by
:math:`d(t) = a\,(1 + w(\omega t + \varphi))` with a waveform ``w`` of :data:`.layout.WAVE_SINE`,
``WAVE_TRIANGLE`` or ``WAVE_SAWTOOTH`` (the contact search is in :mod:`.walls`).

**Riding: the sticking solution** (physics.md §1.6.3). A particle that chatters to rest on the
wall, bounces converging in finite time while the wall presses it (the wall's acceleration
along its inward normal exceeds gravity's component, :math:`\ddot d > g_n`), rides with the
wall: its coordinate along the axis is the wall's plane plus (or minus) its radius, its velocity
there the wall's, while it keeps its free flight across the axis. It takes off, exactly and
in closed form, when the wall stops pressing it:

* sine: :math:`\ddot d = -a\omega^2\sin\theta < g_n` first holds at the up-crossing of
  :math:`\sin\theta = c`, :math:`c = -g_n/(a\omega^2)` (:math:`1/\Gamma` for a floor under
  gravity); no take-off if :math:`c \ge 1`;
* triangle and sawtooth: the end of the linear piece (a peak or the sawtooth's drop release
  the particle; at a triangle's trough the wall turns and strikes it, an ordinary impact).

A riding particle is marked in the extra column :data:`.layout.RIDE` of its row (rows have it
only in runs with a vibrating wall). Everything here depends on the run having a vibrating
wall only through the type of ``geo`` (:func:`has_wall`): other runs fold it away.
"""

import math

import numpy as np
from numba import types
from numba.extending import overload

from .jit import jit, leaf
from .stress import free_fall_fluxes
from .layout import A_ENERGY_INPUT, A_KE, A_KE_INT, A_LAST_T, A_PX, A_PY, A_PZ, A_RIDE_MASS, A_WALL, G_GX, G_GY, G_GZ, G_WALL_A, G_WALL_AXIS, G_WALL_FACE, G_WALL_OMEGA, G_WALL_PHASE, G_WALL_STICK, G_WALL_WAVE, N_GEO_SHEAR, NO_MOVING_WALL, R, RIDE, ROW, VX, WAVE_SINE, WAVE_TRIANGLE, X

TWO_PI = 2.0 * math.pi
INF = math.inf


def has_wall(geo):
    """Whether a geometry (:func:`.layout.make_geo`) has a vibrating wall; compiled code decides
    it from the tuple's length at typing time.

    Example:
        >>> has_wall((1.0,) * 10)
        False
    """
    return len(geo) > N_GEO_SHEAR


@overload(has_wall, inline="always")
def _has_wall(geo):
    if isinstance(geo, types.BaseTuple) and len(geo) > N_GEO_SHEAR:
        return lambda geo: True
    return lambda geo: False


def wall_params(geo):
    """The vibrating wall's ``(axis, face, wave, amplitude, omega, phase at local time 0)`` of a
    geometry (:func:`.layout.make_geo`); ``NO_MOVING_WALL`` when it has none.

    Compiled code reads them by the tuple's length at typing time (:func:`_wall_params`): the
    wall code of a run without a vibrating wall folds to nothing.

    Example:
        >>> wall_params((1.0,) * 10)
        (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    """
    return tuple(geo[G_WALL_AXIS : G_WALL_PHASE + 1]) if len(geo) > N_GEO_SHEAR else NO_MOVING_WALL


@overload(wall_params, inline="always")
def _wall_params(geo):
    if isinstance(geo, types.BaseTuple) and len(geo) > N_GEO_SHEAR:
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


def stick_speed(geo):
    """The rebound speed relative to the vibrating wall below which a particle it presses sticks
    to it (0: never, and without a vibrating wall).

    Example:
        >>> stick_speed((1.0,) * 10)
        0.0
    """
    return geo[G_WALL_STICK] if len(geo) > G_WALL_STICK else 0.0


@overload(stick_speed, inline="always")
def _stick_speed(geo):
    if isinstance(geo, types.BaseTuple) and len(geo) > G_WALL_STICK:
        return lambda geo: geo[G_WALL_STICK]
    return lambda geo: 0.0


@leaf
def ride_axis(geo):
    """The vibrating wall's axis, the sign of its inward normal (+1 for the lower wall) and
    gravity's component along that normal, :math:`g_n`."""
    k = int(wall_params(geo)[0])
    sign = 1.0 if wall_params(geo)[1] == 0.0 else -1.0
    return k, sign, sign * geo[G_GX + k]


@leaf
def _rider_coordinate(d, u, r, geo):
    """Axis, coordinate and velocity along it of a rider of radius ``r`` on the vibrating wall
    displaced by ``d`` and moving into the box at ``u`` (the planes of :func:`wall_planes`)."""
    k, sign, _g = ride_axis(geo)
    half = 0.5 * geo[k]
    plane = -half + d if sign > 0.0 else half - d
    return k, plane + sign * r, sign * u


@leaf
def rider_axis(t, r, geo):
    """Axis ``k``, coordinate and velocity along it of a particle of radius ``r`` riding on the
    vibrating wall at local time ``t``: the wall's plane plus ``r`` along the inward normal."""
    d, u = wall_shift(t, geo)
    return _rider_coordinate(d, u, r, geo)


@leaf
def _ride_piece(t, geo):
    """The displacement and velocity of the vibrating wall at the end of the motion a rider
    follows up to local time ``t``: the wall's own at ``t``, but the left limit just past a corner
    of a linear wave (the end of the piece just ridden, which :func:`ride_end` puts there)."""
    _k, _face, wave, a, om, phase = wall_params(geo)
    wave = int(wave)
    theta = phase + om * t
    done = (math.pi if wave == WAVE_TRIANGLE else TWO_PI) - _piece_left(wave, theta)
    if wave == WAVE_SINE or done > 1e-6:
        return wall_shift(t, geo)
    _w, dw = _linear_wave(wave, _cycle(wave, theta - 0.5))  # (pieces are at least pi long)
    return a * (2.0 if dw > 0.0 else 0.0), a * om * dw


def vibrating_type(geo):
    """Whether the Numba type of a geometry is that of a run with a vibrating wall (typing time)."""
    return isinstance(geo, types.BaseTuple) and len(geo) > N_GEO_SHEAR  # (a sheared geometry has 12 entries, a vibrating wall's 17)


# The hooks below are the only doors from the event loop into the riders' code. Each is an
# overload: a geometry without a vibrating wall gets a no-op, so the loop variants of other
# runs never type (nor compile) any of it (typed dead branches cost plain runs 6 CPU-s, measured).


@leaf
def _release(P, i, mass, acc):
    if P.shape[1] > ROW and P[i, RIDE] != 0.0:
        P[i, RIDE] = 0.0
        acc[A_RIDE_MASS] -= mass[i]


def release(P, i, mass, acc, geo):
    """End the ride of ``i`` (streamed to now) if it rides: it flies on from where it is."""
    if has_wall(geo):
        _release(P, i, mass, acc)


@overload(release, inline="always")
def _release_hook(P, i, mass, acc, geo):
    if vibrating_type(geo):
        return lambda P, i, mass, acc, geo: _release(P, i, mass, acc)
    return lambda P, i, mass, acc, geo: None


@leaf
def _take_off(P, i, t, mass, acc, geo):
    d, u = _ride_piece(t, geo)
    k, x, v = _rider_coordinate(d, u, P[i, R], geo)
    P[i, X + k] = x
    P[i, VX + k] = v
    _release(P, i, mass, acc)


def take_off(P, i, t, mass, acc, geo):
    """The take-off of rider ``i`` at local time ``t`` (:func:`ride_end`), streamed to ``t``:
    it leaves with the wall's motion just before ``t`` (on a linear wave, the end of the piece
    it rode) and flies on."""
    if has_wall(geo):
        _take_off(P, i, t, mass, acc, geo)


@overload(take_off, inline="always")
def _take_off_hook(P, i, t, mass, acc, geo):
    if vibrating_type(geo):
        return lambda P, i, t, mass, acc, geo: _take_off(P, i, t, mass, acc, geo)
    return lambda P, i, t, mass, acc, geo: None


@jit
def _rider_flight(P, i, t, geo, x, y, z, vx, vy, vz):
    k, xk, vk = rider_axis(t, P[i, R], geo)
    if k == 0:
        x, vx = xk, vk
    elif k == 1:
        y, vy = xk, vk
    else:
        z, vz = xk, vk
    return x, y, z, vx, vy, vz


@leaf
def _ride_flight(P, i, t, geo, x, y, z, vx, vy, vz):
    if P.shape[1] > ROW and P[i, RIDE] != 0.0:  # (called, not inlined: flight is inlined everywhere)
        return _rider_flight(P, i, t, geo, x, y, z, vx, vy, vz)
    return x, y, z, vx, vy, vz


def ride_flight(P, i, t, geo, x, y, z, vx, vy, vz):
    """Position and velocity ``(x, v)`` of particle ``i`` at local time ``t`` from its free flight:
    a rider's along the wall's axis are the wall's (:func:`rider_axis`)."""
    if has_wall(geo):
        return _ride_flight(P, i, t, geo, x, y, z, vx, vy, vz)
    return x, y, z, vx, vy, vz


@overload(ride_flight, inline="always")
def _ride_flight_hook(P, i, t, geo, x, y, z, vx, vy, vz):
    if vibrating_type(geo):
        return lambda P, i, t, geo, x, y, z, vx, vy, vz: _ride_flight(P, i, t, geo, x, y, z, vx, vy, vz)
    return lambda P, i, t, geo, x, y, z, vx, vy, vz: (x, y, z, vx, vy, vz)


@leaf
def start_ride(P, i, axis, uw, mass, acc):
    """``i``, at the vibrating wall, rides on it from now: its velocity along the axis is the wall's ``uw``."""
    P[i, VX + axis] = uw
    P[i, RIDE] = 1.0
    acc[A_RIDE_MASS] += mass[i]


@leaf
def _sticks(P, axis, face, t, rebound, geo):
    vs = stick_speed(geo)
    return P.shape[1] > ROW and is_moving(axis, face, geo) and vs > 0.0 and rebound <= vs and pressing(t, geo)


def sticks(P, axis, face, t, rebound, geo):
    """Whether a particle bouncing off wall ``face`` of ``axis`` at local time ``t`` with the
    normal speed ``rebound`` relative to it sticks to it: the vibrating wall, pressing, and a
    rebound slower than the stick speed (:func:`stick_speed`)."""
    return has_wall(geo) and _sticks(P, axis, face, t, rebound, geo)


@overload(sticks, inline="always")
def _sticks_hook(P, axis, face, t, rebound, geo):
    if vibrating_type(geo):
        return lambda P, axis, face, t, rebound, geo: _sticks(P, axis, face, t, rebound, geo)
    return lambda P, axis, face, t, rebound, geo: False


@leaf
def free_fall(acc, tau, geo, total_mass, k, held):
    r"""Advance the kinetic energy, its time integral and the momentum over ``tau`` in free fall
    under gravity, all of the mass but ``held`` along axis ``k`` (the riders' axial motion, taken
    out by :func:`_integrate_riding`; 0 for the event loop's :func:`.loop.integrate_kinetic`):

    .. math::
        E(\tau) = E_0 + \mathbf G\cdot\mathbf P_0\,\tau + \tfrac12 (M G^2 - M_h G_k^2)\tau^2,\qquad
        P_m(\tau) = P_{m,0} + (M - M_h\delta_{mk}) G_m\tau.
    """
    gp = geo[G_GX] * acc[A_PX] + geo[G_GY] * acc[A_PY] + geo[G_GZ] * acc[A_PZ]
    mg2 = total_mass * (geo[G_GX] ** 2 + geo[G_GY] ** 2 + geo[G_GZ] ** 2) - held * geo[G_GX + k] ** 2
    acc[A_KE_INT] += acc[A_KE] * tau + 0.5 * gp * tau * tau + mg2 * tau * tau * tau / 6.0
    acc[A_KE] += gp * tau + 0.5 * mg2 * tau * tau
    free_fall_fluxes(acc, tau, geo, total_mass)  # (not reported in runs with a vibrating wall)
    for m in range(3):
        acc[A_PX + m] += (total_mass - (held if m == k else 0.0)) * geo[G_GX + m] * tau


@jit
def _integrate_riding(acc, t, geo, total_mass):
    r""":func:`.loop.integrate_kinetic` with particles of total mass :math:`M_r` riding on the vibrating
    wall (physics.md §1.6.3): they all move with the wall along its axis :math:`k`,
    :math:`v_k = u(t)`, and freely across it.

    Their axial motion is taken out of the free-flight integral and added back exactly, with
    :math:`\int_{t_0}^{t} \tfrac12 M_r u^2\,dt'` in closed form (sine:
    :math:`u^2 = a^2\omega^2\cos^2\theta`; a linear piece: :math:`u` constant). The wall's
    work on them, :math:`M_r[\tfrac12(u^2 - u_0^2) - G_k(x_k - x_{k,0})]`, is energy input, and
    the momentum it gives them, :math:`M_r[u - u_0 - G_k(t - t_0)]`, the wall's momentum.
    """
    t0 = acc[A_LAST_T]
    tau = t - t0
    mr = acc[A_RIDE_MASS]
    k, sign, _gn = ride_axis(geo)
    _k, face, wave, a, om, phase = wall_params(geo)
    if int(wave) == WAVE_SINE:
        _k, x0, u0 = rider_axis(t0, 0.0, geo)
        _k, x1, u1 = rider_axis(t, 0.0, geo)
        th0, th1 = phase + om * t0, phase + om * t
        u2_int = a * a * om * om * (0.5 * tau + (math.sin(2.0 * th1) - math.sin(2.0 * th0)) / (4.0 * om))
    else:  # one linear piece (a ride ends at the piece's end): its velocity
        _k, _x, u0 = rider_axis(0.5 * (t0 + t), 0.0, geo)
        u1, x0, x1 = u0, 0.0, u0 * tau
        u2_int = u0 * u0 * tau
    acc[A_PX + k] -= mr * u0
    acc[A_KE] -= 0.5 * mr * u0 * u0
    free_fall(acc, tau, geo, total_mass, k, mr)
    acc[A_KE_INT] += 0.5 * mr * u2_int
    acc[A_KE] += 0.5 * mr * u1 * u1
    acc[A_PX + k] += mr * u1
    gk = geo[G_GX + k]
    acc[A_ENERGY_INPUT] += mr * (0.5 * (u1 * u1 - u0 * u0) - gk * (x1 - x0))
    acc[A_WALL + 2 * k + int(face)] += sign * mr * (u1 - u0 - gk * tau)
    acc[A_LAST_T] = t


def integrate_riding(acc, t, geo, total_mass):
    """Advance the accumulators to local time ``t`` as :func:`_integrate_riding` if particles ride
    on the vibrating wall, and say whether it did (the event loop's integral does it otherwise)."""
    if has_wall(geo) and acc[A_RIDE_MASS] != 0.0:
        _integrate_riding(acc, t, geo, total_mass)
        return True
    return False


@overload(integrate_riding, inline="always")
def _integrate_riding_hook(acc, t, geo, total_mass):
    if not vibrating_type(geo):
        return lambda acc, t, geo, total_mass: False

    def impl(acc, t, geo, total_mass):
        if acc[A_RIDE_MASS] != 0.0:
            _integrate_riding(acc, t, geo, total_mass)
            return True
        return False

    return impl


@leaf
def _takeoff_level(geo):
    r"""The sine's level :math:`c = -g_n/(a\omega^2)`: the wall presses a rider while :math:`\sin\theta < c`."""
    _k, _face, _wave, a, om, _phase = wall_params(geo)
    return -ride_axis(geo)[2] / (a * om * om)


@leaf
def pressing(t, geo):
    r"""Whether the vibrating wall presses a particle resting on it at local time ``t``: its
    acceleration along the inward normal exceeds gravity's, :math:`\ddot d > g_n` (on the linear
    pieces of a triangle or sawtooth :math:`\ddot d = 0`)."""
    _k, _face, wave, _a, om, phase = wall_params(geo)
    if int(wave) == WAVE_SINE:
        return math.sin(phase + om * t) < _takeoff_level(geo)
    return ride_axis(geo)[2] < 0.0


@jit
def ride_end(t, geo):
    r"""Local time at which riders leave the vibrating wall, seen from local time ``t`` (``t``
    itself if the wall no longer presses them, ``INF`` if it always will): the up-crossing of
    :math:`\sin\theta = c` (sine) or the end of the linear piece (triangle, sawtooth)."""
    if not pressing(t, geo):
        return t
    _k, _face, wave, _a, om, phase = wall_params(geo)
    wave = int(wave)
    theta = phase + om * t
    if wave == WAVE_SINE:
        c = _takeoff_level(geo)
        if c >= 1.0:
            return INF
        d = math.asin(c) - theta
        return t + (d - TWO_PI * math.floor(d / TWO_PI)) / om
    end = t + _piece_left(wave, theta) / om
    while _piece_left(wave, phase + om * end) < 1.0:  # put the end just past the corner: the wall
        end = np.nextafter(end, INF)  # there already moves as on the next piece (a trough's impact)
    return end


@leaf
def _piece_left(wave, theta):
    """Phase left in the linear piece of a triangle or sawtooth wave at ``theta``."""
    q = _cycle(wave, theta)
    ends = (0.5, 1.0) if wave == WAVE_TRIANGLE else (1.0, 1.0)
    return ((ends[0] if q < ends[0] else ends[1]) - q) * TWO_PI


@jit
def level_time(level, t, geo):
    """Time after local time ``t`` at which the wall's displacement :math:`d` crosses ``level``
    (``INF``: never on the sine, or not before the linear piece ends). A crossing at ``t`` itself
    (round-off of the phase) is the one just made."""
    _k, _face, wave, a, om, phase = wall_params(geo)
    wave = int(wave)
    theta = phase + om * t
    tiny = 1e-12 + 4e-16 * abs(theta)
    if wave == WAVE_SINE:
        y = level / a - 1.0
        if not abs(y) < 1.0:
            return INF
        best = INF
        b = math.asin(y)
        for target in (b, math.pi - b):
            d = target - theta
            d -= TWO_PI * math.floor(d / TWO_PI)
            if tiny < d < best:
                best = d
        return best / om
    d, u = wall_shift(t, geo)
    if u == 0.0:
        return INF
    s = (level - d) / u
    return s if s > tiny / om and s * om < _piece_left(wave, theta) else INF
