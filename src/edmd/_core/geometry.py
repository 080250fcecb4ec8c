"""Whole-system geometry helpers: overlap search and spatial ordering (compiled)."""

import numpy as np
from .jit import jit_alloc

from .cells import bin_all, cell_insert, cell_of_point, walk_around, walk_next
from .predict import INF, shear_image, wrap3


@jit_alloc
def close_pairs(pos, radius, geo, grid, scale):
    """Every pair ``i < j`` closer than ``scale * (R_i + R_j)``: arrays ``(i, j, dx, dy, dz, r)``.

    ``pos`` is ``(N, 3)`` (inside the box); ``grid`` must have cells of edge at least
    ``scale`` times the largest contact distance. ``(dx, dy, dz)`` is the minimum-image
    ``pos[i] - pos[j]`` (in a sheared ``geo``, with the images' offset at local time 0).
    """
    n = pos.shape[0]
    bin_all(pos, geo, grid)
    cbuf = np.empty(18 + 3 * max(grid.shape[0], 3), np.int32)  # (cells_buffer_size)
    ii, jj, dd = [], [], []
    for i in range(n):
        nc, s, j = walk_around(grid, grid.cell[i], geo, cbuf)
        while j >= 0:
            if j > i:
                dx, dy, dz, _uj = shear_image(pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1], pos[i, 2] - pos[j, 2], 0.0, geo)
                sig = scale * (radius[i] + radius[j])
                r2 = dx * dx + dy * dy + dz * dz
                if r2 < sig * sig:
                    ii.append(i)
                    jj.append(j)
                    dd.append((dx, dy, dz, np.sqrt(r2)))
            nc, s, j = walk_next(grid, cbuf, nc, s, j)
    d = np.empty((len(dd), 4))
    for k in range(len(dd)):
        d[k, 0], d[k, 1], d[k, 2], d[k, 3] = dd[k]
    return np.array(ii, np.int64), np.array(jj, np.int64), d


@jit_alloc
def worst_overlap(pos, radius, geo, grid, rel_tol):
    """Return ``(i, j, distance)`` of the deepest overlap beyond ``rel_tol`` (``-1, -1, 0`` if none)."""
    ii, jj, d = close_pairs(pos, radius, geo, grid, 1.0)
    bi, bj, worst, bd = -1, -1, 0.0, 0.0
    for k in range(ii.shape[0]):
        depth = 1.0 - d[k, 3] / (radius[ii[k]] + radius[jj[k]])
        if depth > rel_tol and depth > worst:
            bi, bj, worst, bd = ii[k], jj[k], depth, d[k, 3]
    return bi, bj, bd


@jit_alloc
def random_insert(radius, geo, grid, pos, uniforms, start, dim):
    """Sequentially place particles ``start, start+1, ...`` at random without overlap.

    ``uniforms[p - start, a, :dim]`` are the uniform numbers of attempt ``a`` for particle ``p``;
    particles ``< start`` are already in ``pos`` and in ``grid``. Returns the index of the first
    particle that could not be placed in the attempts given (``start + len(uniforms)`` if all were).
    """
    n = start + uniforms.shape[0]
    cbuf = np.empty(27, np.int32)
    for p in range(start, n):
        u = uniforms[p - start]
        ok = False
        for a in range(u.shape[0]):
            for k in range(3):
                span = geo[k] if geo[3 + k] < INF else geo[k] - 2.0 * radius[p]  # walls: stay inside
                pos[p, k] = (u[a, k] - 0.5) * span if k < dim else 0.0
            c = cell_of_point(pos[p, 0], pos[p, 1], pos[p, 2], geo, grid)
            grid.cell[p] = c
            ok = True
            nc, s, j = walk_around(grid, c, geo, cbuf)
            while j >= 0:
                dx, dy, dz = wrap3(pos[p, 0] - pos[j, 0], pos[p, 1] - pos[j, 1], pos[p, 2] - pos[j, 2], geo)
                sig = radius[p] + radius[j]
                if dx * dx + dy * dy + dz * dz < sig * sig:
                    ok = False
                    break
                nc, s, j = walk_next(grid, cbuf, nc, s, j)
            if ok:
                cell_insert(grid, p, c)
                break
        if not ok:
            return p
    return n


@jit_alloc
def relax_overlaps(pos, radius, geo, grid, inflate, step, max_iter, dim):
    """Push overlapping particles apart by steepest descent on a harmonic overlap energy.

    Minimises :math:`\\sum_{ij}(\\sigma'_{ij} - r_{ij})^2` over overlapping pairs with radii
    inflated by ``inflate``, moving every particle by ``step`` times its net push per sweep, and
    stops once no pair overlaps at half that inflation (descent only approaches zero overlap
    asymptotically; this leaves every pair a gap). Returns the number of sweeps used
    (``max_iter + 1`` if overlaps remain).
    """
    n = pos.shape[0]
    push = np.zeros((n, 3))
    for it in range(max_iter):
        for i in range(n):
            for k in range(dim):
                if pos[i, k] >= geo[3 + k]:
                    pos[i, k] -= geo[k]
                elif pos[i, k] < -geo[3 + k]:
                    pos[i, k] += geo[k]
        ii, jj, d = close_pairs(pos, radius, geo, grid, inflate)
        push[:] = 0.0
        worst = 0.0
        for i in range(n):  # walls close the non-periodic axes
            ri = inflate * radius[i]
            for k in range(dim):
                if geo[3 + k] == INF:
                    lo = -0.5 * geo[k] + ri - pos[i, k]
                    hi = pos[i, k] - (0.5 * geo[k] - ri)
                    if lo > 0.0:
                        push[i, k] += lo / step
                        worst = max(worst, lo / (2.0 * ri))
                    elif hi > 0.0:
                        push[i, k] -= hi / step
                        worst = max(worst, hi / (2.0 * ri))
        for k in range(ii.shape[0]):
            sig = inflate * (radius[ii[k]] + radius[jj[k]])
            r = max(d[k, 3], 1e-6 * sig)
            o = (sig - r) / r
            worst = max(worst, (sig - r) / sig)
            for a in range(3):
                da = d[k, a] if d[k, 3] > 0.0 else (1e-6 * sig if a == 0 else 0.0)
                push[ii[k], a] += o * da
                push[jj[k], a] -= o * da
        if worst <= 0.5 * (inflate - 1.0) / inflate:
            return it
        for i in range(n):
            for k in range(dim):
                pos[i, k] += step * push[i, k]
    return max_iter + 1
