"""Radial distribution function g(r) (own compiled pair histogram; freud optional) and contact values."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..state import State
from ._common import axes, each_state


@njit(cache=True)
def _axis_cells(x, length, n, periodic):
    c = int(math.floor((x + 0.5 * length) / length * n))
    if c < 0:
        return n - 1 if periodic else 0
    if c >= n:
        return 0 if periodic else n - 1
    return c


@njit(cache=True)
def _neighbour_cells(c, n, periodic, out):
    """Distinct neighbour cell indices of ``c`` along one axis; returns how many."""
    if periodic and n < 3:
        for k in range(n):
            out[k] = k
        return n
    m = 0
    for o in range(-1, 2):
        k = c + o
        if periodic:
            k %= n
        elif k < 0 or k >= n:
            continue
        out[m] = k
        m += 1
    return m


@njit(cache=True)
def pair_histogram(points, box, periodic, r_max, nbins, shear_offset=0.0):
    """Counts of unordered pairs by distance in ``nbins`` equal bins on ``[0, r_max)``.

    Minimum image on periodic axes (with Lees-Edwards images offset along x by ``shear_offset``,
    :attr:`edmd.State.shear_offset`); a cell list with cells of edge ``>= r_max`` (all cells of an
    axis with fewer than 3 of them; under shear, the whole row across the y face), so the cost is
    :math:`O(N)` per frame.
    """
    n = points.shape[0]
    nc = np.empty(3, np.int64)
    for k in range(3):
        nc[k] = max(1, int(box[k] // r_max))
    head = np.full(nc[0] * nc[1] * nc[2], -1, np.int64)
    nxt = np.empty(n, np.int64)
    cell = np.empty((n, 3), np.int64)
    for i in range(n):
        for k in range(3):
            cell[i, k] = _axis_cells(points[i, k], box[k], nc[k], periodic[k])
        c = (cell[i, 0] * nc[1] + cell[i, 1]) * nc[2] + cell[i, 2]
        nxt[i] = head[c]
        head[c] = i
    counts = np.zeros(nbins, np.int64)
    nb = np.empty((3, 3), np.int64)
    m = np.empty(3, np.int64)
    every_x = np.arange(nc[0])
    scale = nbins / r_max
    r2max = r_max * r_max
    sheared = shear_offset != 0.0
    for i in range(n):
        for k in range(3):
            m[k] = _neighbour_cells(cell[i, k], nc[k], periodic[k], nb[k])
        for b in range(m[1]):
            y2 = nb[1, b]
            across = sheared and (nc[1] < 3 or abs(y2 - cell[i, 1]) > 1)  # (the row across the sliding face: all of it)
            xs = every_x if across else nb[0, : m[0]]
            for x2 in xs:
                for cc in range(m[2]):
                    j = head[(x2 * nc[1] + y2) * nc[2] + nb[2, cc]]
                    while j >= 0:
                        if j > i:
                            r2 = _image_distance2(points, i, j, box, periodic, shear_offset)
                            if r2 < r2max:
                                counts[min(int(math.sqrt(r2) * scale), nbins - 1)] += 1
                        j = nxt[j]
    return counts


@njit(cache=True)
def _image_distance2(points, i, j, box, periodic, shear_offset):
    """Squared minimum-image distance of ``i`` and ``j`` (the y image first: it shifts x by the offset)."""
    dx = points[i, 0] - points[j, 0]
    dy = points[i, 1] - points[j, 1]
    dz = points[i, 2] - points[j, 2]
    if periodic[1]:
        s = np.rint(dy / box[1])
        dy -= box[1] * s
        dx -= shear_offset * s
    if periodic[0]:
        dx -= box[0] * np.rint(dx / box[0])
    if periodic[2]:
        dz -= box[2] * np.rint(dz / box[2])
    return dx * dx + dy * dy + dz * dz


#: :math:`\int\prod_{k\in S}|n_k|\,d\Omega` over the unit sphere (3D) or circle (2D) for :math:`|S|` = 0, 1, 2, 3
_SPHERE_MOMENTS = {3: (4.0 * math.pi, 2.0 * math.pi, 8.0 / 3.0, 1.0), 2: (2.0 * math.pi, 4.0, 2.0)}


def _shell_volumes(edges, dim, closed_lengths=()):
    r"""Ideal-gas weight of each shell: its volume, times the chance that a pair that far apart fits in the box.

    Two centres uniform on an axis closed by walls, with accessible length :math:`L` there,
    are :math:`|x|` apart with probability density :math:`\propto 1 - |x|/L` (periodic axes:
    uniform), so the shell :math:`[r_a, r_b)` weighs

    .. math:: W = \int_{\rm shell}\prod_{k\,\rm closed}\Big(1-\frac{|x_k|}{L_k}\Big)d^dx
        = \sum_s (-1)^s e_s c_s \frac{r_b^{d+s}-r_a^{d+s}}{d+s}

    (:math:`r_b \le \min L_k`) with :math:`e_s` the elementary symmetric polynomials of the
    :math:`1/L_k` and :math:`c_s` the moments :data:`_SPHERE_MOMENTS`.
    """
    e = np.atleast_1d(np.poly(-1.0 / np.asarray(closed_lengths, float)))
    return sum((-1) ** s * e[s] * _SPHERE_MOMENTS[dim][s] * np.diff(edges ** (dim + s)) / (dim + s) for s in range(len(e)))


def _accessible_lengths(state: State) -> np.ndarray:
    """Lengths the particle centres can reach on the axes closed by walls (box minus one mean diameter)."""
    return state.box[~state.periodic] - 2.0 * float(state.radius.mean())


class RDF:
    r"""Radial distribution function :math:`g(r)`, averaged over frames.

    For each frame, with :math:`h_k` the number of unordered pairs in the shell
    :math:`[r_k, r_{k+1})` (minimum image) and :math:`V_k` the shell volume (area in 2D),

    .. math:: g(r_k) = \frac{2 h_k}{N\,\frac{N-1}{V}\,V_k}

    so uncorrelated points give :math:`g = 1` exactly on average. On axes closed by walls the
    density is that of the volume the centres can reach (box lengths minus a mean diameter) and
    :math:`V_k` is weighted by the chance that a pair that far apart fits in the box
    (:func:`_shell_volumes`), so :math:`g \to 1` at large :math:`r` in a closed box too.

    Args:
        bins: number of bins.
        r_max: largest distance (default: half the shortest periodic box length); must not
            exceed that half length (the minimum image would be ambiguous).

    Attributes:
        bin_edges, bin_centers: the bins.
        rdf: :math:`g(r)` at the bin centres.
        frames: number of frames averaged.

    Example:
        >>> import edmd
        >>> s = edmd.lattice(500, 0.3)
        >>> g = RDF(bins=50, r_max=2.0).compute(s)
        >>> float(g.rdf[g.bin_centers < 0.99].max())   # no pairs closer than a diameter
        0.0
    """

    def __init__(self, bins: int = 100, r_max: float | None = None):
        if bins < 1 or (r_max is not None and not r_max > 0):
            raise ValueError(f"need bins >= 1 and r_max > 0, got bins={bins}, r_max={r_max}")
        self.bins = int(bins)
        self.r_max = r_max
        self.frames = 0

    def _limit(self, state: State) -> float:
        periodic = state.box[state.periodic]
        half = 0.5 * float(periodic.min()) if periodic.size else math.inf
        r_max = self.r_max if self.r_max is not None else half
        if not math.isfinite(r_max):
            raise ValueError("give r_max for a box without periodic axes")
        if r_max > half * (1 + 1e-12):
            raise ValueError(f"r_max = {r_max} exceeds half the shortest periodic box length ({half})")
        closed = _accessible_lengths(state)
        if closed.size and r_max > closed.min():
            raise ValueError(f"r_max = {r_max} exceeds the length the particles can reach between walls ({closed.min():.6g})")
        return float(r_max)

    def compute(self, system, reset: bool = True) -> RDF:
        """Accumulate :math:`g(r)` over one State, several States or a GSD file (read frame by frame); returns ``self``.

        With ``reset=False`` the frames are added to those of earlier calls.
        """
        if reset:
            self.frames = 0
        for s in each_state(system):
            self._add(s)
        self.rdf = self._sum / self.frames
        return self

    def _add(self, s: State):
        r_max = self._limit(s)
        if self.frames == 0:
            self._sum = np.zeros(self.bins)
            self.bin_edges = np.linspace(0.0, r_max, self.bins + 1)
            self.bin_centers = 0.5 * (self.bin_edges[1:] + self.bin_edges[:-1])
        elif r_max != self.bin_edges[-1]:
            raise ValueError("frames with a different r_max cannot be accumulated")
        box, _ = s.geometry()
        periodic = np.zeros(3, np.bool_)
        periodic[: s.dim] = s.periodic
        counts = pair_histogram(s.points, box, periodic, r_max, self.bins, s.shear_offset)
        closed = _accessible_lengths(s)
        volume = float(np.prod(s.box[s.periodic]) * np.prod(closed))
        self._sum += 2.0 * counts / (s.n * (s.n - 1) / volume * _shell_volumes(self.bin_edges, s.dim, closed))
        self.frames += 1

    def contact_value(self, sigma: float, width: float | None = None, order: int = 2) -> float:
        r"""Contact value :math:`g(\sigma^+)` by extrapolating a polynomial fit to :math:`r = \sigma`.

        The fit uses the bins lying entirely in :math:`[\sigma, \sigma + w]` (default
        :math:`w = 0.15\sigma`); it needs ``order + 2`` of them at least.
        """
        width = 0.15 * sigma if width is None else width
        left, right = self.bin_edges[:-1], self.bin_edges[1:]
        use = (left >= sigma * (1 - 1e-12)) & (right <= sigma + width * (1 + 1e-12))
        if use.sum() < order + 2:
            raise ValueError(f"only {int(use.sum())} bins lie in [sigma, sigma + {width:g}]: use finer bins or a wider window")
        coef = np.polyfit(self.bin_centers[use] - sigma, self.rdf[use], order)
        return float(coef[-1])

    def plot(self, ax=None):
        """g(r) with the ideal-gas line g = 1; returns the Axes."""
        ax = axes(ax)
        ax.plot(self.bin_centers, self.rdf, "-", label="g(r)")
        ax.axhline(1.0, color="0.6", lw=0.8, ls=":")
        ax.set_xlabel("r")
        ax.set_ylabel("g(r)")
        return ax
