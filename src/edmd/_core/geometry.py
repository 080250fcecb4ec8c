"""Whole-system geometry helpers: overlap search and spatial ordering (compiled)."""

import numpy as np
from .jit import jit_alloc

from .cells import cell_block, cell_insert, cell_of_point
from .predict import wrap3


@jit_alloc
def worst_overlap(pos, radius, geo, grid, rel_tol):
    """Return ``(i, j, distance)`` of the deepest overlap beyond ``rel_tol`` (``-1, -1, 0`` if none).

    ``pos`` is ``(N, 3)``; ``grid`` must have cells of edge at least the largest contact distance.
    """
    n = pos.shape[0]
    head, nxt = grid[0], grid[1]
    head[:] = -1
    for i in range(n):
        cell_insert(grid, i, cell_of_point(pos[i, 0], pos[i, 1], pos[i, 2], geo, grid))
    cbuf = np.empty(27, np.int32)
    bi, bj, worst, bd = -1, -1, 0.0, 0.0
    for i in range(n):
        nc = cell_block(grid, grid[2][i], geo, cbuf, -1, 0)
        for s in range(nc):
            j = head[cbuf[s]]
            while j >= 0:
                if j > i:
                    dx, dy, dz = wrap3(pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1], pos[i, 2] - pos[j, 2], geo)
                    sig = radius[i] + radius[j]
                    d = np.sqrt(dx * dx + dy * dy + dz * dz)
                    depth = 1.0 - d / sig
                    if depth > rel_tol and depth > worst:
                        bi, bj, worst, bd = i, j, depth, d
                j = nxt[j]
    return bi, bj, bd


@jit_alloc
def random_insert(radius, geo, grid, pos, uniforms, start, dim):
    """Sequentially place particles ``start, start+1, ...`` at random without overlap.

    ``uniforms[p - start, a, :dim]`` are the uniform numbers of attempt ``a`` for particle ``p``;
    particles ``< start`` are already in ``pos`` and in ``grid``. Returns the index of the first
    particle that could not be placed in the attempts given (``start + len(uniforms)`` if all were).
    """
    n = start + uniforms.shape[0]
    head, nxt = grid[0], grid[1]
    cbuf = np.empty(27, np.int32)
    for p in range(start, n):
        u = uniforms[p - start]
        ok = False
        for a in range(u.shape[0]):
            for k in range(3):
                pos[p, k] = (u[a, k] - 0.5) * geo[k] if k < dim else 0.0
            c = cell_of_point(pos[p, 0], pos[p, 1], pos[p, 2], geo, grid)
            grid[2][p] = c
            ok = True
            nc = cell_block(grid, c, geo, cbuf, -1, 0)
            for s in range(nc):
                j = head[cbuf[s]]
                while j >= 0 and ok:
                    dx, dy, dz = wrap3(pos[p, 0] - pos[j, 0], pos[p, 1] - pos[j, 1], pos[p, 2] - pos[j, 2], geo)
                    sig = radius[p] + radius[j]
                    if dx * dx + dy * dy + dz * dz < sig * sig:
                        ok = False
                    j = nxt[j]
                if not ok:
                    break
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
    head, nxt = grid[0], grid[1]
    cbuf = np.empty(27, np.int32)
    push = np.zeros((n, 3))
    for it in range(max_iter):
        head[:] = -1
        for i in range(n):
            for k in range(dim):
                if pos[i, k] >= geo[3 + k]:
                    pos[i, k] -= geo[k]
                elif pos[i, k] < -geo[3 + k]:
                    pos[i, k] += geo[k]
            cell_insert(grid, i, cell_of_point(pos[i, 0], pos[i, 1], pos[i, 2], geo, grid))
        push[:] = 0.0
        worst = 0.0
        for i in range(n):
            nc = cell_block(grid, grid[2][i], geo, cbuf, -1, 0)
            for s in range(nc):
                j = head[cbuf[s]]
                while j >= 0:
                    if j > i:
                        dx, dy, dz = wrap3(pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1], pos[i, 2] - pos[j, 2], geo)
                        sig = (radius[i] + radius[j]) * inflate
                        r2 = dx * dx + dy * dy + dz * dz
                        if r2 < sig * sig:
                            r = np.sqrt(r2)
                            if r == 0.0:
                                dx, r = 1e-6 * sig, 1e-6 * sig
                            o = (sig - r) / r
                            worst = max(worst, o * r / sig)
                            push[i, 0] += o * dx
                            push[i, 1] += o * dy
                            push[i, 2] += o * dz
                            push[j, 0] -= o * dx
                            push[j, 1] -= o * dy
                            push[j, 2] -= o * dz
                    j = nxt[j]
        if worst <= 0.5 * (inflate - 1.0) / inflate:
            return it
        for i in range(n):
            for k in range(dim):
                pos[i, k] += step * push[i, k]
    return max_iter + 1
