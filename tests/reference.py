"""Independent brute-force EDMD for tests: pure numpy, all pairs, all periodic images, no cells, no queue.

Every particle is advanced at every event (eager update) and every pair is re-examined through
each of the 3^d nearest periodic images, so nothing here shares code or assumptions with the
engine's lazy update, neighbour lists, cells or calendar.
"""

import itertools

import numpy as np


def _pair_times(pos, vel, radius, box):
    """Earliest contact time of every pair over all 3^d image shifts; also the best shift."""
    n, d = pos.shape
    dr0 = pos[:, None, :] - pos[None, :, :]
    dr0 -= box * np.round(dr0 / box)
    dv = vel[:, None, :] - vel[None, :, :]
    sig = radius[:, None] + radius[None, :]
    best = np.full((n, n), np.inf)
    best_shift = np.zeros((n, n, d))
    a = np.einsum("ijk,ijk->ij", dv, dv)
    for s in itertools.product((-1, 0, 1), repeat=d):
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


def run_reference(pos, vel, radius, mass, box, t_end, e_n=1.0):
    """Elastic/inelastic smooth hard spheres in a periodic box until ``t_end``.

    Returns ``(pos, vel, log)`` with positions wrapped into ``[-L/2, L/2)`` and
    ``log = [(t, i, j), ...]`` (``i < j``) for every collision.
    """
    pos = np.array(pos, float)
    vel = np.array(vel, float)
    radius = np.asarray(radius, float)
    mass = np.asarray(mass, float)
    box = np.asarray(box, float)
    t = 0.0
    log = []
    while True:
        times, dr = _pair_times(pos, vel, radius, box)
        k = int(np.argmin(times))
        i, j = divmod(k, len(pos))
        dt = times[i, j]
        if t + dt >= t_end:
            pos += vel * (t_end - t)
            break
        pos += vel * dt
        t += dt
        rij = dr[i, j] + (vel[i] - vel[j]) * dt
        n = rij / np.linalg.norm(rij)
        gn = (vel[i] - vel[j]) @ n
        mu = mass[i] * mass[j] / (mass[i] + mass[j])
        jimp = -(1 + e_n) * mu * gn * n
        vel[i] += jimp / mass[i]
        vel[j] -= jimp / mass[j]
        log.append((t, min(i, j), max(i, j)))
    pos = (pos + 0.5 * box) % box - 0.5 * box
    return pos, vel, log
