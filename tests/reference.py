"""Independent brute-force EDMD for tests: pure numpy, all pairs, all periodic images, no cells, no queue.

Every particle is advanced at every event (eager update) and every pair is re-examined through
each of the 3^d nearest periodic images, so nothing here shares code or assumptions with the
engine's lazy update, neighbour lists, cells or calendar. Also: a direct Cartesian integration
of two soft spheres (scipy), the reference of the soft-contact and eMD* tests.
"""

import itertools
import math

import numpy as np
from scipy.integrate import solve_ivp


def _contact_times(dr, dv, a, sig):
    """Contact time of every pair at separations ``dr`` moving with ``dv`` (``a = |dv|^2``): the
    textbook root, 0 for overlapping approaching pairs, inf for receding ones."""
    b = np.einsum("ijk,ijk->ij", dr, dv)
    c = np.einsum("ijk,ijk->ij", dr, dr) - sig**2
    disc = b * b - a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where((b < 0) & (disc > 0), c / (-b + np.sqrt(np.maximum(disc, 0))), np.inf)
    return np.where((b < 0) & (c <= 0), 0.0, t)


def _pair_times(pos, vel, radius, box, periodic):
    """Earliest contact time of every pair over all 3^d image shifts (periodic axes); also the best shift."""
    n, d = pos.shape
    dr0 = pos[:, None, :] - pos[None, :, :]
    dr0 -= np.where(periodic, box * np.round(dr0 / box), 0.0)
    dv = vel[:, None, :] - vel[None, :, :]
    sig = radius[:, None] + radius[None, :]
    best = np.full((n, n), np.inf)
    best_shift = np.zeros((n, n, d))
    a = np.einsum("ijk,ijk->ij", dv, dv)
    for s in itertools.product(*[(-1, 0, 1) if p else (0,) for p in periodic]):
        shift = np.asarray(s, float) * box
        dr = dr0 + shift
        t = _contact_times(dr, dv, a, sig)
        better = t < best
        best = np.where(better, t, best)
        best_shift[better] = shift
    np.fill_diagonal(best, np.inf)
    return best, dr0 + best_shift


def _wall_times(pos, vel, radius, box, gravity, periodic):
    """Earliest wall contact per particle: (time, (axis, face)), textbook quadratic formula, vectorised."""
    n, d = pos.shape
    best = np.full(n, np.inf)
    which = np.full((n, 2), -1)
    eps = 1e-12 * box.max()
    for k in range(d):
        if periodic[k]:
            continue
        for face, sign in ((0, 1.0), (1, -1.0)):
            # gap h(t) = h0 + u t + a t^2 / 2 to the plane x = -L/2 (face 0) or +L/2 (face 1)
            h0 = sign * pos[:, k] + 0.5 * box[k] - radius
            u, a = sign * vel[:, k], sign * gravity[k]
            with np.errstate(invalid="ignore", divide="ignore"):
                if a != 0:
                    root = np.sqrt(u * u - 2 * a * h0)
                    cands = np.stack([(-u - root) / a, (-u + root) / a])
                else:
                    cands = np.stack([-h0 / u, np.full(n, np.inf)])
            ok = np.isfinite(cands) & (cands > eps) & (u + a * cands < 0)
            t = np.where(ok, cands, np.inf).min(axis=0)
            better = t < best
            best[better] = t[better]
            which[better] = (k, face)
    return best, which


def run_reference(pos, vel, radius, mass, box, t_end, e_n=1.0, gravity=None, periodic=None, e_wall=1.0):
    """Smooth hard spheres (constant e_n) in a box with periodic axes and smooth walls, in gravity.

    Returns ``(pos, vel, log)`` with positions wrapped on periodic axes and
    ``log = [(t, i, j), ...]``: ``i < j`` for collisions, ``j = -1 - (2 * axis + face)`` for walls.
    """
    pos = np.array(pos, float)
    vel = np.array(vel, float)
    radius = np.asarray(radius, float)
    mass = np.asarray(mass, float)
    box = np.asarray(box, float)
    d = pos.shape[1]
    gravity = np.zeros(d) if gravity is None else np.asarray(gravity, float)
    periodic = np.ones(d, bool) if periodic is None else np.asarray(periodic, bool)
    t = 0.0
    log = []
    while True:
        times, dr = _pair_times(pos, vel, radius, box, periodic)
        k = int(np.argmin(times))
        i, j = divmod(k, len(pos))
        dt = times[i, j]
        tw, which = _wall_times(pos, vel, radius, box, gravity, periodic)
        w = int(np.argmin(tw))
        wall_first = tw[w] < dt
        dt = min(dt, tw[w])
        if t + dt >= t_end:
            dt = t_end - t
            pos += vel * dt + 0.5 * gravity * dt * dt
            vel += gravity * dt
            break
        pos += vel * dt + 0.5 * gravity * dt * dt
        vel += gravity * dt
        t += dt
        if wall_first:
            axis, face = which[w]
            vel[w, axis] *= -e_wall
            log.append((t, w, -1 - (2 * axis + face)))
            continue
        rij = dr[i, j] + (vel[i] - vel[j]) * dt
        n = rij / np.linalg.norm(rij)
        gn = (vel[i] - vel[j]) @ n
        mu = mass[i] * mass[j] / (mass[i] + mass[j])
        jimp = -(1 + e_n) * mu * gn * n
        vel[i] += jimp / mass[i]
        vel[j] -= jimp / mass[j]
        log.append((t, min(i, j), max(i, j)))
    pos = np.where(periodic, (pos + 0.5 * box) % box - 0.5 * box, pos)
    return pos, vel, log


def direct_two_spheres(contact, m, R, r0, v0, gravity, t_end):
    """Cartesian Newtonian integration of two soft spheres from first contact (scipy DOP853).

    Force F n on sphere 1 (n from 2 to 1) while the overlap is positive and until F vanishes,
    then free flight (parabolic with gravity) to t_end.
    """
    a, b = contact.constants()
    reff = R[0] * R[1] / (R[0] + R[1])
    sigma = R[0] + R[1]

    def force(y):
        d = y[0:3] - y[3:6]
        r = np.linalg.norm(d)
        n = d / r
        xi = sigma - r
        xi_dot = -np.dot(y[6:9] - y[9:12], n)
        if contact.code == 1:
            f = a * math.sqrt(reff) * math.sqrt(max(xi, 0.0)) * (xi + b * xi_dot)
        else:
            f = a * xi + b * xi_dot
        return f, n, xi, xi_dot

    def rhs(t, y):
        f, n, _xi, _xd = force(y)
        return np.concatenate([y[6:9], y[9:12], f * n / m[0] + gravity, -f * n / m[1] + gravity])

    def ended(t, y):
        f, _n, xi, xi_dot = force(y)
        if t < 1e-12 * t_end:
            return 1.0
        return xi + b * xi_dot if contact.code == 1 else a * xi + b * xi_dot

    ended.terminal = True
    ended.direction = -1
    y0 = np.concatenate([r0[0], r0[1], v0[0], v0[1]])
    sol = solve_ivp(rhs, (0, t_end), y0, method="DOP853", rtol=1e-13, atol=1e-16 * t_end, events=ended)
    tc = sol.t_events[0][0]
    y = sol.y_events[0][0]
    dt = t_end - tc
    pos = [y[0:3] + y[6:9] * dt + 0.5 * gravity * dt**2, y[3:6] + y[9:12] * dt + 0.5 * gravity * dt**2]
    vel = [y[6:9] + gravity * dt, y[9:12] + gravity * dt]
    return tc, pos, vel


def random_contact(rng, dim, R, speed, b):
    """Positions and velocities of two spheres touching with impact speed ``speed``, eccentricity ``b``."""
    n = rng.normal(size=3)
    if dim == 2:
        n[2] = 0.0
    n /= np.linalg.norm(n)
    t = rng.normal(size=3)
    if dim == 2:
        t[2] = 0.0
    t -= (t @ n) * n
    t /= np.linalg.norm(t)
    g = speed * (-math.sqrt(1 - b * b) * n + b * t)
    V = rng.normal(size=3) * speed
    if dim == 2:
        V[2] = 0.0
    center = rng.normal(size=3)
    if dim == 2:
        center[2] = 0.0
    sigma = R[0] + R[1]
    return [center + 0.6 * sigma * n, center - 0.4 * sigma * n], [V + 0.7 * g, V - 0.3 * g]


def _sheared_pair_times(pos, vel, radius, box, rate, offset):
    """Earliest contact of every pair in a Lees-Edwards box over every image explicitly: the
    images ``s_y`` = -1, 0, 1 along y (x shifted by ``s_y * offset``, v_x by ``s_y * rate * L_y``),
    each at x shifts -1, 0, 1 (after rounding) and z shifts -1, 0, 1. Returns times and the
    separation and relative velocity of the image used."""
    n, d = pos.shape
    sig = radius[:, None] + radius[None, :]
    best = np.full((n, n), np.inf)
    best_dr = np.zeros((n, n, d))
    best_dv = np.zeros((n, n, d))
    dr0 = pos[:, None, :] - pos[None, :, :]
    dv0 = vel[:, None, :] - vel[None, :, :]
    for sy in (-1, 0, 1):
        dr1 = dr0.copy()
        dv1 = dv0.copy()
        dr1[..., 1] -= sy * box[1]
        dr1[..., 0] -= sy * offset
        dv1[..., 0] -= sy * rate * box[1]
        dr1[..., 0] -= box[0] * np.round(dr1[..., 0] / box[0])
        if d == 3:
            dr1[..., 2] -= box[2] * np.round(dr1[..., 2] / box[2])
        a = np.einsum("ijk,ijk->ij", dv1, dv1)
        for s in itertools.product((-1, 0, 1), *[(-1, 0, 1)] * (d - 2)):
            dr = dr1.copy()
            dr[..., 0] += s[0] * box[0]
            if d == 3:
                dr[..., 2] += s[1] * box[2]
            t = _contact_times(dr, dv1, a, sig)
            better = t < best
            best = np.where(better, t, best)
            best_dr[better] = dr[better]
            best_dv[better] = dv1[better]
    np.fill_diagonal(best, np.inf)
    return best, best_dr, best_dv


def _fold_sheared(pos, vel, box, rate, offset):
    """Every particle's image inside the box of a Lees-Edwards system (positions and velocities in place)."""
    while True:
        s = np.floor((pos[:, 1] + 0.5 * box[1]) / box[1])
        if not np.any(s):
            break
        pos[:, 1] -= s * box[1]
        pos[:, 0] -= s * offset
        vel[:, 0] -= s * rate * box[1]
    pos[:, 0] = (pos[:, 0] + 0.5 * box[0]) % box[0] - 0.5 * box[0]
    if pos.shape[1] == 3:
        pos[:, 2] = (pos[:, 2] + 0.5 * box[2]) % box[2] - 0.5 * box[2]


def run_sheared_reference(pos, vel, radius, mass, box, t_end, rate, offset0=0.0, e_n=1.0):
    """Smooth hard spheres (constant e_n) in a Lees-Edwards box (periodic, flow along x, gradient
    along y): every particle advanced at every event, every pair through every image.

    Returns ``(pos, vel, log, offset)``: the final state folded into the box, ``log = [(t, i, j), ...]``
    with ``i < j`` and the final image offset (unreduced).
    """
    pos = np.array(pos, float)
    vel = np.array(vel, float)
    radius = np.asarray(radius, float)
    mass = np.asarray(mass, float)
    box = np.asarray(box, float)
    t = 0.0
    log = []
    while True:
        offset = offset0 + rate * box[1] * t
        times, dr, dv = _sheared_pair_times(pos, vel, radius, box, rate, offset)
        k = int(np.argmin(times))
        i, j = divmod(k, len(pos))
        dt = times[i, j]
        if t + dt >= t_end:
            pos += vel * (t_end - t)
            t = t_end
            break
        pos += vel * dt
        t += dt
        rij = dr[i, j] + dv[i, j] * dt
        n = rij / np.linalg.norm(rij)
        gn = dv[i, j] @ n
        mu = mass[i] * mass[j] / (mass[i] + mass[j])
        jimp = -(1 + e_n) * mu * gn * n
        vel[i] += jimp / mass[i]
        vel[j] -= jimp / mass[j]
        log.append((t, min(i, j), max(i, j)))
        _fold_sheared(pos, vel, box, rate, offset0 + rate * box[1] * t)
    offset = offset0 + rate * box[1] * t
    _fold_sheared(pos, vel, box, rate, offset)
    return pos, vel, log, offset
