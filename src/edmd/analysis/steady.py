r"""Steady states: time averages with honest error bars, and profiles along an axis.

:class:`SteadyState` averages a thermo column after a settling time and estimates the standard
error of that mean by blocking (H. Flyvbjerg and H. G. Petersen, J. Chem. Phys. 91, 461 (1989)):
consecutive samples are averaged in pairs again and again; at blocking level :math:`k` the
:math:`n_k` block means give

.. math::
    \varepsilon_k = \sqrt{\frac{\operatorname{var}(\bar x^{(k)})}{n_k - 1}},

which grows with :math:`k` while blocks are shorter than the correlation time and then levels
off at the true standard error of the mean. The estimate is the largest :math:`\varepsilon_k`
among the levels with at least ``min_blocks`` blocks (each :math:`\varepsilon_k` itself is
uncertain by :math:`1/\sqrt{2(n_k-1)}`, 18 % for 16 blocks).

:class:`Profile` bins the particles of many frames along one axis (the vibration or gravity axis
of a bed): number density, granular temperature and mean velocity per bin, pooled over frames.
"""

from __future__ import annotations

import math

import numpy as np

from ._common import axes, each_state
from .thermal import _thermo_table

AXES = "xyz"


def blocking_errors(values) -> tuple[np.ndarray, np.ndarray]:
    """Blocks per level and the standard error of the mean estimated at each level (see module doc).

    Example:
        >>> n, err = blocking_errors(np.arange(8.0))
        >>> n.tolist()
        [8, 4, 2]
    """
    x = np.asarray(values, float)
    counts, errors = [], []
    while x.size >= 2:
        counts.append(x.size)
        errors.append(float(np.std(x, ddof=1) / math.sqrt(x.size)))
        x = x[: x.size // 2 * 2]
        x = 0.5 * (x[0::2] + x[1::2])
    return np.array(counts), np.array(errors)


class SteadyState:
    r"""Time average of a thermo column after a settling time, with a blocking error estimate.

    Args:
        settle: ignore rows with ``time < settle`` (the approach to the steady state).
        min_blocks: the error estimate uses blocking levels with at least this many blocks.

    Attributes:
        mean: the time average (thermo rows are equally spaced in time).
        error: standard error of ``mean`` (blocking, see the module doc).
        samples: number of rows averaged.
        blocks, errors: blocks per level and the error estimated at each level.
        converged: whether the two highest levels used agree within the uncertainty of the
            estimate (if not, the series is too short for its correlation time: ``error`` is a
            lower bound).

    Example:
        >>> import edmd
        >>> state = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), 1.0, seed=2)
        >>> sim = edmd.Simulation(state, e_n=0.8, forcing=edmd.WhiteNoise(xi0=0.3, interval=0.1, seed=3))
        >>> th = sim.add(edmd.Thermo(0.5)); sim.run(until_time=200.0)
        >>> t = SteadyState(settle=50.0).compute(th, "temperature")
        >>> 0.8 < t.mean < 1.2, 0 < t.error < 0.05
        (True, True)
    """

    def __init__(self, settle: float = -math.inf, min_blocks: int = 16):
        if int(min_blocks) < 4:
            raise ValueError(f"min_blocks must be at least 4, got {min_blocks!r}")
        self.settle = settle
        self.min_blocks = int(min_blocks)

    def compute(self, thermo, column: str = "temperature") -> SteadyState:
        """From a :class:`~edmd.Thermo`, its table or a thermo CSV, the rows at or after ``settle``."""
        table = _thermo_table(thermo)
        if column not in table:
            raise ValueError(f"the thermo table has no column {column!r}; it has {', '.join(table)}")
        return self.compute_series(table["time"], table[column])

    def compute_series(self, time, values) -> SteadyState:
        """From equally spaced samples ``values`` at times ``time`` (non-finite ones, such as the
        first thermo row's pressure, are skipped)."""
        time, values = np.asarray(time, float), np.asarray(values, float)
        keep = (time >= self.settle) & np.isfinite(values)
        x = values[keep]
        if x.size < 2 * self.min_blocks:
            raise ValueError(f"{x.size} samples after settle = {self.settle}: the error estimate needs at least {2 * self.min_blocks}")
        self.samples = int(x.size)
        self.mean = float(x.mean())
        self.blocks, self.errors = blocking_errors(x)
        used = self.blocks >= self.min_blocks
        self.error = float(self.errors[used].max())
        top = np.flatnonzero(used)[-2:]
        spread = 2.0 / math.sqrt(2.0 * (self.blocks[top[-1]] - 1))
        self.converged = bool(abs(self.errors[top[-1]] - self.errors[top[0]]) <= spread * self.errors[top[-1]])
        return self

    def plot(self, ax=None):
        """Error estimate vs blocking level (it should level off)."""
        ax = axes(ax)
        ax.plot(np.arange(self.errors.size), self.errors, "o-")
        ax.axhline(self.error, color="k", lw=0.8, ls="--", label=f"estimate {self.error:.3g}")
        ax.set_xlabel("blocking level (block = 2^level samples)")
        ax.set_ylabel("standard error of the mean")
        ax.legend(fontsize="small")
        return ax


class Profile:
    r"""Number density, granular temperature and mean velocity along an axis, pooled over frames.

    For the particles of bin :math:`b` over all frames (:math:`N_b` of them, masses :math:`m_i`),

    .. math::
        n_b = \frac{N_b}{F\,V_b},\qquad \mathbf u_b = \frac{\sum m_i\mathbf v_i}{\sum m_i},\qquad
        T_b = \frac{\sum m_i|\mathbf v_i - \mathbf u_b|^2}{d\,N_b}

    with :math:`F` frames and :math:`V_b` the bin's volume (area in 2D): the classic profiles of
    a vibrated or sheared bed. Bins span the box along ``axis``; empty bins give ``nan``.

    Args:
        axis: ``"x"``, ``"y"`` or ``"z"`` (``"z"`` only in 3D).
        bins: number of bins.

    Attributes:
        edges, centres: bin edges and centres along the axis.
        density, temperature: per bin.
        velocity: ``(bins, d)`` mean velocity per bin.
        counts: particles per bin, summed over frames; frames: frames used.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(4000, 0.2), kT=1.5, seed=1)
        >>> p = Profile("x", bins=4).compute(s)
        >>> bool(np.allclose(p.density, 4000 / s.volume, rtol=0.05)), bool(np.allclose(p.temperature, 1.5, rtol=0.1))
        (True, True)
    """

    def __init__(self, axis: str = "z", bins: int = 20):
        if axis not in AXES:
            raise ValueError(f"axis must be 'x', 'y' or 'z', got {axis!r}")
        if not (isinstance(bins, int | np.integer) and bins >= 1):
            raise ValueError(f"bins must be a positive integer, got {bins!r}")
        self.axis = AXES.index(axis)
        self.bins = int(bins)

    def compute(self, system) -> Profile:
        """From a State, States or a trajectory file (every frame)."""
        sums = None
        for state in each_state(system):
            if self.axis >= state.dim:
                raise ValueError(f"a {state.dim}D system has no {AXES[self.axis]} axis")
            length = float(state.box[self.axis])
            edges = np.linspace(-0.5 * length, 0.5 * length, self.bins + 1)
            if sums is None:
                self.edges, self.frames = edges, 0
                sums = {"count": np.zeros(self.bins), "mass": np.zeros(self.bins), "p": np.zeros((self.bins, state.dim)), "e2": np.zeros(self.bins)}
                self.bin_volume = state.volume / self.bins
            elif not np.array_equal(edges, self.edges):
                raise ValueError("the frames have different boxes along the profile axis")
            b = np.clip(np.searchsorted(edges, state.position[:, self.axis], side="right") - 1, 0, self.bins - 1)
            v = state.committed_velocity
            m = state.mass
            sums["count"] += np.bincount(b, minlength=self.bins)
            sums["mass"] += np.bincount(b, weights=m, minlength=self.bins)
            for k in range(state.dim):
                sums["p"][:, k] += np.bincount(b, weights=m * v[:, k], minlength=self.bins)
            sums["e2"] += np.bincount(b, weights=m * np.sum(v * v, axis=1), minlength=self.bins)
            self.frames += 1
            dim = state.dim
        self.centres = 0.5 * (self.edges[1:] + self.edges[:-1])
        self.counts = sums["count"]
        with np.errstate(invalid="ignore", divide="ignore"):
            self.density = self.counts / (self.frames * self.bin_volume)
            self.velocity = sums["p"] / sums["mass"][:, None]
            internal = sums["e2"] - sums["mass"] * np.sum(self.velocity**2, axis=1)
            self.temperature = np.where(self.counts > 0, internal / (dim * self.counts), np.nan)
        return self

    def plot(self, ax=None, quantity: str = "temperature"):
        """One profile vs position: ``"density"``, ``"temperature"`` or ``"velocity"`` (along the axis)."""
        values = {"density": lambda: self.density, "temperature": lambda: self.temperature, "velocity": lambda: self.velocity[:, self.axis]}
        if quantity not in values:
            raise ValueError(f"quantity must be one of {', '.join(values)}, got {quantity!r}")
        ax = axes(ax)
        ax.plot(self.centres, values[quantity](), "o-")
        ax.set_xlabel(AXES[self.axis])
        ax.set_ylabel({"density": "number density", "temperature": "granular temperature", "velocity": f"mean v_{AXES[self.axis]}"}[quantity])
        return ax
