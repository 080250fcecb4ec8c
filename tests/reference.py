"""Independent brute-force EDMD for tests: pure numpy, all pairs, all periodic images, no cells, no queue.

Every particle is advanced at every event (eager update) and every pair is re-examined through
each of the 3^d nearest periodic images, so nothing here shares code or assumptions with the
engine's lazy update, neighbour lists, cells or calendar.
"""

import itertools

import numpy as np


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
        b = np.einsum("ijk,ijk->ij", dr, dv)
        c = np.einsum("ijk,ijk->ij", dr, dr) - sig**2
        disc = b * b - a * c
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where((b < 0) & (disc > 0), c / (-b + np.sqrt(np.maximum(disc, 0))), np.inf)
        t = np.where((b < 0) & (c <= 0), 0.0, t)
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
