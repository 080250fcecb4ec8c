"""The cell size of cells mode from a cost model of the density (benchmarks/README.md, "Cell size").

In cells mode a particle sees the :math:`3^d` cells around its own, and every crossing of a cell
face is an event that scans the newly adjacent layer of :math:`3^{d-1}` cells (physics.md §1.4).
Cells of edge :math:`\\ell \\ge \\sigma_{max}` trade crossings (fewer as :math:`\\ell` grows)
against pair predictions (more). Per collision, with :math:`n` particles per volume and mean
free path :math:`\\lambda`:

.. math::

    C(\\ell) = \\frac{2 \\lambda k_d}{\\ell} \\left(c_x + 3^{d-1} n \\ell^d c_p\\right)
               + 2 \\cdot 3^d n \\ell^d c_p

where :math:`k_d \\ell^{-1}` is the number of face crossings per unit path of a Maxwellian
flight (:math:`k_3 = 3/2`, :math:`k_2 = 4/\\pi`: :math:`d \\langle|v_x|\\rangle / \\langle|v|\\rangle`),
:math:`c_x` the cost of a crossing event and :math:`c_p` that of one pair prediction. Only their
ratio matters: :data:`CROSSING_COST` (measured, see benchmarks/README.md). The two free paths that
end in each collision cross :math:`2 \\lambda k_d / \\ell` faces; the two partners then search
their full neighbourhoods.
"""

from __future__ import annotations

import math

import numpy as np

from .._core.cells import new_grid
from .memory import grid_shape

#: cost of a crossing event in pair predictions (c_x / c_p): 19 from the edge sweeps of 2026-12-02 (AMD
#: EPYC), 7-8 from those of 2026-12-04 (Intel Xeon, the prefetching loop); 10 measured 1.06-1.09x
#: faster than 19 on the latter in 3D, equal in 2D (benchmarks/README.md, "Cell size")
CROSSING_COST = 10.0


def mean_free_path(number_density: float, sigma: float, dim: int) -> float:
    """Enskog mean free path of hard spheres (3D) or disks (2D) of diameter ``sigma``.

    .. math::

        \\lambda_3 = \\frac{1}{\\sqrt{2} \\pi n \\sigma^2 \\chi}, \\qquad
        \\lambda_2 = \\frac{1}{2 \\sqrt{2} n \\sigma \\chi}

    with the contact value :math:`\\chi` of Carnahan–Starling (3D) or Henderson (2D)
    (physics.md §1.8).

    Example:
        >>> round(mean_free_path(0.0191, 1.0, 3), 2)   # eta = 0.01
        11.49
    """
    if number_density <= 0.0:
        return math.inf
    if dim == 3:
        eta = math.pi / 6.0 * number_density * sigma**3
        chi = (1.0 - 0.5 * eta) / (1.0 - eta) ** 3
        return 1.0 / (math.sqrt(2.0) * math.pi * number_density * sigma**2 * chi)
    eta = math.pi / 4.0 * number_density * sigma**2
    chi = (1.0 - 7.0 * eta / 16.0) / (1.0 - eta) ** 2
    return 1.0 / (2.0 * math.sqrt(2.0) * number_density * sigma * chi)


def crossings(edge: float, free_path: float, dim: int) -> float:
    """Cell-face crossings per collision: :math:`2\\lambda k_d / \\ell`, the two free paths that end in it (module doc)."""
    k = 1.5 if dim == 3 else 4.0 / math.pi
    return 2.0 * free_path * k / edge


def cell_cost(edge: float, number_density: float, free_path: float, dim: int) -> float:
    """:math:`C(\\ell) / c_p`: the work of one collision in pair predictions (module doc)."""
    per_cell = number_density * edge**dim
    return crossings(edge, free_path, dim) * (CROSSING_COST + 3 ** (dim - 1) * per_cell) + 2.0 * 3**dim * per_cell


def cell_edge(number_density, sigma_mean: float, sigma_max: float, dim: int, weights=None) -> float:
    """The cell edge of least :func:`cell_cost`, at least the largest contact distance ``sigma_max``.

    The free path is that of the mean diameter (a polydisperse system's cells are as wide as
    its largest contact, and the cost is counted over all its particles). An inhomogeneous
    system (a bed under gravity) gives ``number_density`` as the densities of its regions and
    ``weights`` as the particles in each (:func:`local_densities`): the edge then minimises the
    work per unit time, :math:`\\sum_v w_v C(\\ell; n_v)/\\lambda_v` (collisions per particle and
    unit time go as :math:`1/\\lambda`), which the dense regions dominate.

    Example:
        >>> round(cell_edge(0.0955, 1.0, 1.0, 3), 2), round(cell_edge(0.0191, 1.0, 1.0, 3), 2)   # eta = 0.05, 0.01
        (1.27, 2.58)
        >>> cell_edge(0.95, 1.0, 1.0, 3)   # dense: one contact distance
        1.0
        >>> cell_edge([0.0191, 0.95], 1.0, 1.0, 3, weights=[1, 1])   # half dilute, half dense: the dense half's
        1.0
    """
    densities = np.atleast_1d(np.asarray(number_density, float))
    weights = np.ones(densities.size) if weights is None else np.asarray(weights, float)
    keep = densities > 0.0
    densities, weights = densities[keep], weights[keep]
    # (crowded regions of small particles can exceed close packing at the mean diameter: their
    # free path is taken at a packing fraction of 0.6 (3D) or 0.8 (2D))
    unit = math.pi / 6.0 * sigma_mean**3 if dim == 3 else math.pi / 4.0 * sigma_mean**2
    densities = np.minimum(densities, (0.6 if dim == 3 else 0.8) / unit)
    if densities.size == 0:
        return sigma_max
    paths = np.array([mean_free_path(float(v), sigma_mean, dim) for v in densities])
    edges = sigma_max * np.exp(np.linspace(0.0, math.log(64.0), 601))  # 1..64 contact distances
    costs = sum(w * cell_cost(edges, float(v), p, dim) / p for v, w, p in zip(densities, weights, paths))
    return float(edges[int(np.argmin(costs))])


#: the most particles cells mode takes out of the cell size as big ones (each scan tests every big)
MAX_BIGS = 64


def big_count(radius, number_density: float, dim: int) -> int:
    """How many of the largest particles cells mode treats as big (physics.md §1.4, "Big particles").

    A few large particles (an intruder in a granular gas) would set every cell's edge: with a
    size ratio of 10 a cell holds some 200 times the particles of a monodisperse system's. Taken
    out, the cells are sized for the others (:func:`cell_edge` with their largest contact), each
    scan of a small particle also tests every big (:math:`m` more pair tests per crossing and per
    change of flight), and each big scans the block of :math:`(2K+1)^d` cells within its largest
    contact :math:`K\\ell \\ge R_b + r_{small}` whenever its own flight changes (at a rate that grows
    as its cross-section, :math:`((R_b + \\bar R) / 2\\bar R)^{d-1}` times a particle's). This returns
    the :math:`m \\le` :data:`MAX_BIGS` (0: none) of least :func:`cell_cost` plus that extra work,
    per collision and in pair predictions; ties in radius are never split.

    Example:
        >>> import numpy as np
        >>> big_count(np.r_[5.0, np.full(9999, 0.5)], 0.0955, 3)   # one intruder of size ratio 10, eta = 0.05
        1
        >>> big_count(np.full(10000, 0.5), 0.0955, 3), big_count(np.linspace(0.1, 1.0, 10000), 0.0955, 3)
        (0, 0)
    """
    radius = np.asarray(radius, float)
    n = radius.size
    top = min(MAX_BIGS, n - 1)
    if top < 1 or radius.max() == radius.min():  # (one size: no copy of the radii)
        return 0
    r = np.sort(np.partition(radius, n - top - 1)[n - top - 1 :])[::-1]  # the top + 1 largest, largest first
    if r[0] <= r[top]:
        return 0
    sigma_mean = 2.0 * float(radius.mean())
    path = mean_free_path(number_density, sigma_mean, dim)
    best, best_cost = 0, math.inf
    for m in range(top + 1):
        if m > 0 and r[m - 1] == r[m]:
            continue
        edge = cell_edge(number_density, sigma_mean, 2.0 * r[m], dim)
        cost = cell_cost(edge, number_density, path, dim) + m * (crossings(edge, path, dim) + 2.0)
        for b in range(m):  # a big's scans: its block of cells (their heads and particles)
            block = (2 * math.ceil((r[b] + r[m]) / edge) + 1) ** dim
            cost += 2.0 / n * ((r[b] + 0.5 * sigma_mean) / sigma_mean) ** (dim - 1) * block * (number_density * edge**dim + 0.3)
        if cost < best_cost:
            best, best_cost = m, cost
    return best


def local_densities(position: np.ndarray, box: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Number densities of the regions a system's particles are in, and the particles in each:
    the occupied bins of a grid of edge :math:`3\\sigma` (at least the mean volume per particle,
    so that there are no more bins than particles), their counts over their volume.

    Example:
        >>> rng = np.random.default_rng(0)
        >>> pos = np.concatenate([rng.uniform(-5, 5, (900, 2)) * [1, 0.1] - [0, 4.5], rng.uniform(-5, 5, (100, 2))])
        >>> dens, w = local_densities(pos, np.array([10.0, 10.0]), 1.0)
        >>> w.sum(), bool(np.average(dens, weights=w) > 2 * 1000 / 100)   # most particles see the dense layer
        (np.int64(1000), True)
    """
    n, dim = position.shape
    edge = max(3.0 * sigma, float(np.prod(box)) ** (1.0 / dim) / n ** (1.0 / dim))
    shape = np.maximum(np.floor(box / edge).astype(np.int64), 1)
    index = np.zeros(n, np.int64)
    for k in range(dim):  # (an axis at a time: one index array of every particle)
        index *= shape[k]
        index += np.clip(((position[:, k] + 0.5 * box[k]) * (shape[k] / box[k])).astype(np.int64), 0, shape[k] - 1)
    counts = np.bincount(index)
    del index
    occupied = counts[counts > 0]
    volume = float(np.prod(box / shape))
    values, bins = np.unique(occupied, return_counts=True)
    return values / volume, values * bins


def block_reach(distance: float, edges) -> int:
    """Cells ``K`` a big particle scans to each side: the fewest with :math:`K\\ell \\ge` ``distance``
    for the shortest of the cell ``edges`` (a relative margin of 1e-12 against rounding).

    Example:
        >>> block_reach(5.5, np.array([1.0, 1.1])), block_reach(5.0, np.array([1.0]))
        (6, 6)
    """
    return math.ceil(distance / float(np.min(edges)) * (1.0 + 1e-12))


def overlap_grid(radius: np.ndarray, box3: np.ndarray, periodic3, dim: int, scale: float = 1.0, shear: bool = False, pad: float = 0.0):
    """The cell grid of the set-up's overlap searches (:mod:`edmd._core.geometry`: placing,
    relaxing and checking particles) for contacts up to ``scale`` times :math:`R_i + R_j`, plus
    ``pad`` (the force-based MD's list skin, :func:`edmd._core.dem.build_list`).

    Its cells are as wide as the largest such contact, or, where :func:`big_count` takes big
    particles out (as cells mode does), as that of the others; each big then walks the block
    of :math:`(2K+1)^d` cells with :math:`K\\ell \\ge s(R_{\\max} + r_{\\rm small})`, kept only when
    it holds no cell twice (on a periodic axis :math:`2K+1` cells at most), and no big is
    taken out of a sheared box. A ratio-10 intruder among :math:`10^4` spheres then costs the
    search little instead of making it all-pairs.

    Example:
        >>> r = np.r_[5.0, np.full(9999, 0.5)]   # one intruder, eta = 0.1
        >>> box = np.full(3, (r**3).sum() * 4.18879 / 0.1) ** (1 / 3)
        >>> g = overlap_grid(r, box, np.ones(3, bool), 3)
        >>> g.shape[:3].tolist(), int(g.shape[5]), int(g.shape[6])   # cells, bigs, reach
        ([38, 38, 38], 1, 6)
    """
    n = radius.size
    r_max = float(radius.max())
    periodic3 = np.asarray(periodic3, bool)
    m = 0 if shear else big_count(radius, n / float(np.prod(box3[:dim])), dim)
    if m:
        r_small = float(np.partition(radius, n - m - 1)[n - m - 1])
        nc = grid_shape(box3, periodic3, 2.0 * scale * r_small + pad, n, dim)
        split = nc > 1
        if split.any():
            reach = block_reach(scale * (r_max + r_small) + pad, box3[split] / nc[split])
            if not np.any(periodic3 & split & (nc < 2 * reach + 1)):
                return new_grid(n, box3, nc, np.flatnonzero(radius > r_small).astype(np.int32), reach, r_small)
    return new_grid(n, box3, grid_shape(box3, periodic3, 2.0 * scale * r_max + pad, n, dim))
