"""Whole-system geometry helpers: overlap search and spatial ordering (compiled).

A grid with big particles (:mod:`.cells`; made by :func:`edmd.run.neighbours.overlap_grid`)
keeps the cells as small as the other particles need: a big walks its block of
:func:`.cells.reach_of` cells to each side and tests every big (physics.md §1.4 "Big particles").
"""

import numpy as np
from .jit import jit_alloc

from .cells import GF_RSMALL, GI_BIGS, GI_REACH, bin_all, cell_insert, cell_of_point, next_or_big, reach_of, walk_block, walk_reach
from .predict import INF, shear_image, wrap3


@jit_alloc
def _walk_buffer(grid):
    """Room for the cells of any walk of ``grid``: a sliding face's rows or a big's block (:func:`.cells.cells_buffer_size`)."""
    return np.empty(max(18 + 3 * max(grid.shape[0], 3), (2 * grid.shape[GI_REACH] + 1) ** 3), np.int32)


@jit_alloc
def close_pairs(pos, radius, geo, grid, scale):
    """Every pair ``i < j`` closer than ``scale * (R_i + R_j)``: arrays ``(i, j, dx, dy, dz, r)``.

    ``pos`` is ``(N, 3)`` (inside the box); ``grid`` must have cells of edge at least
    ``scale`` times the largest contact distance, or of its big particles' reach
    (:func:`edmd.run.neighbours.overlap_grid`). ``(dx, dy, dz)`` is the minimum-image
    ``pos[i] - pos[j]`` (in a sheared ``geo``, with the images' offset at local time 0).
    Each pair once: two small ones from the walk of the first, a big and a small one from the
    big's block, two bigs from the first's test of every big.
    """
    n = pos.shape[0]
    bin_all(pos, geo, grid)
    cbuf = _walk_buffer(grid)
    nbig, r_small = grid.shape[GI_BIGS], grid.size[GF_RSMALL]
    ii, jj, dd = [], [], []
    for i in range(n):
        big = radius[i] > r_small
        nc, s, j = walk_reach(grid, np.int64(grid.cell[i]), geo, cbuf, radius[i])
        b = 0 if big else nbig
        while True:
            in_walk = j >= 0
            k, nc, s, j, b = next_or_big(grid, cbuf, nc, s, j, b)
            if k < 0:
                break
            if radius[k] <= r_small and (k > i or big) if in_walk else k > i:
                a, c = min(i, k), max(i, k)
                dx, dy, dz, _uc = shear_image(pos[a, 0] - pos[c, 0], pos[a, 1] - pos[c, 1], pos[a, 2] - pos[c, 2], 0.0, geo)
                sig = scale * (radius[a] + radius[c])
                r2 = dx * dx + dy * dy + dz * dz
                if r2 < sig * sig:
                    ii.append(a)
                    jj.append(c)
                    dd.append((dx, dy, dz, np.sqrt(r2)))
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
    A trial position is tested against the placed particles of its walk and every placed big.
    """
    n = start + uniforms.shape[0]
    cbuf = _walk_buffer(grid)
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
            nc, s, j = walk_block(grid, c, geo, cbuf, np.int64(-1), np.int64(0), reach_of(grid, radius[p]))  # (never sheared)
            b = 0
            while True:
                in_walk = j >= 0
                k, nc, s, j, b = next_or_big(grid, cbuf, nc, s, j, b)
                if k < 0:
                    break
                if not in_walk and k >= p:  # (a big not placed yet)
                    continue
                dx, dy, dz = wrap3(pos[p, 0] - pos[k, 0], pos[p, 1] - pos[k, 1], pos[p, 2] - pos[k, 2], geo)
                sig = radius[p] + radius[k]
                if dx * dx + dy * dy + dz * dz < sig * sig:
                    ok = False
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
    asymptotically; this leaves every pair a gap). A particle with :math:`z_i > 6d` overlapping
    partners moves :math:`6d/z_i` of that (a Jacobi step: the energy's curvature grows as
    :math:`z_i/d`, and an intruder overlapping hundreds would overshoot; physics.md §1.4 "Big
    particles"). Returns the number of sweeps used (``max_iter + 1`` if overlaps remain).
    """
    n = pos.shape[0]
    push = np.zeros((n, 3))
    touching = np.zeros(n)  # overlapping partners per particle
    for it in range(max_iter):
        for i in range(n):
            for k in range(dim):
                if pos[i, k] >= geo[3 + k]:
                    pos[i, k] -= geo[k]
                elif pos[i, k] < -geo[3 + k]:
                    pos[i, k] += geo[k]
        ii, jj, d = close_pairs(pos, radius, geo, grid, inflate)
        push[:] = 0.0
        touching[:] = 0.0
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
            touching[ii[k]] += 1.0
            touching[jj[k]] += 1.0
            for a in range(3):
                da = d[k, a] if d[k, 3] > 0.0 else (1e-6 * sig if a == 0 else 0.0)
                push[ii[k], a] += o * da
                push[jj[k], a] -= o * da
        if worst <= 0.5 * (inflate - 1.0) / inflate:
            return it
        for i in range(n):
            damp = max(1.0, touching[i] / (6.0 * dim))
            for k in range(dim):
                pos[i, k] += step * push[i, k] / damp
    return max_iter + 1
