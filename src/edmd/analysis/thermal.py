"""Temperatures, the velocity distribution (Maxwell reference, Sonine a2), pressure, Haff's law."""

from __future__ import annotations

import math
import os
from fractions import Fraction

import numpy as np

from ..state import State
from ._common import axes, each_state, contact_value, maxwell_speed_pdf


class Temperature:
    r"""Translational and rotational (granular) temperature of a State (:math:`k_B = 1`).

    .. math::
        T_{\rm tr} = \frac{1}{dN}\sum_i m_i|\mathbf v_i-\mathbf u|^2,\qquad
        T_{\rm rot} = \frac{1}{fN}\sum_i I_i|\boldsymbol\omega_i|^2

    with :math:`\mathbf u` the centre-of-mass velocity and :math:`f` the rotational degrees of
    freedom per particle (3 for spheres, 1 for disks).

    Attributes:
        translational: :math:`T_{\rm tr}`.
        rotational: :math:`T_{\rm rot}`.
        kinetic_energy: translational kinetic energy.
        rotational_energy: rotational kinetic energy.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(500, 0.2), kT=2.0, seed=1, spin=True)
        >>> t = Temperature().compute(s)
        >>> round(t.translational, 12), round(t.rotational, 12)
        (2.0, 2.0)
    """

    def compute(self, state: State) -> Temperature:
        """Compute the temperatures of ``state``; returns ``self``."""
        dof = 3 if state.dim == 3 else 1
        self.translational = state.temperature()
        self.kinetic_energy = state.kinetic_energy()
        self.rotational_energy = state.rotational_energy()
        self.rotational = 2.0 * self.rotational_energy / (dof * state.n)
        return self


def sonine_a2(c: np.ndarray, dim: int) -> float:
    r"""Second Sonine coefficient (kurtosis excess) of reduced speeds :math:`c` in :math:`d` dimensions.

    .. math:: a_2 = \frac{d}{d+2}\,\frac{\langle c^4\rangle}{\langle c^2\rangle^2} - 1

    (physics.md §5.4); zero for a Maxwellian, :math:`-2/(d+2)` for a single speed.

    Example:
        >>> round(sonine_a2(np.ones(10), 3), 12)
        -0.4
    """
    c2 = np.asarray(c, float) ** 2
    return dim / (dim + 2) * float(np.mean(c2 * c2)) / float(np.mean(c2)) ** 2 - 1.0


class VelocityDistribution:
    r"""Distribution of reduced speeds with the Maxwell reference and the Sonine coefficient a2.

    Each particle contributes :math:`c_i = |\mathbf v_i-\mathbf u|\sqrt{m_i/T}` (:math:`T`, :math:`\mathbf u`
    of its frame), so that a Maxwellian gives

    .. math:: f_M(c) = \frac{c^{d-1} e^{-c^2/2}}{2^{d/2-1}\Gamma(d/2)}

    for any masses. With :math:`x = c^2/2` the first Sonine correction is
    :math:`f = f_M\,[1 + a_2 S_2(x)]`, :math:`S_2(x) = x^2/2 - (d+2)x/2 + d(d+2)/8` (physics.md §5.4;
    the homogeneous cooling state has :math:`a_2(e_n = 0.9) = -0.01456` in 3D).

    Args:
        bins: number of histogram bins on :math:`[0, c_{\max}]`.
        c_max: largest reduced speed binned.

    Attributes:
        bin_edges, bin_centers: histogram bins in :math:`c`.
        pdf: normalised histogram (speeds beyond ``c_max`` count in the normalisation).
        maxwell: :math:`f_M` at the bin centres.
        sonine: :math:`f_M[1 + a_2 S_2]` at the bin centres.
        a2: measured Sonine coefficient.
        a2_error: standard deviation of ``a2`` for as many independent Maxwellian speeds,
            :math:`\sqrt{8/(d(d+2)N_s)}` (delta method on the moments of :math:`\chi^2_d`).
        temperature: mean temperature of the frames.
        samples: number of speeds.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(4000, 0.1), kT=1.0, seed=3)
        >>> vd = VelocityDistribution().compute(s)
        >>> abs(vd.a2) < 5 * vd.a2_error
        True
    """

    def __init__(self, bins: int = 60, c_max: float = 5.0):
        if bins < 1 or not c_max > 0:
            raise ValueError(f"need bins >= 1 and c_max > 0, got bins={bins}, c_max={c_max}")
        self.bins = int(bins)
        self.c_max = float(c_max)

    def compute(self, system) -> VelocityDistribution:
        """Histogram the reduced speeds of one State, several States or a GSD file (read frame by frame); returns ``self``."""
        speeds, temps = [], []
        for s in each_state(system):
            t = s.temperature()
            if not t > 0:
                raise ValueError(f"the state at t = {s.time} has zero temperature: no velocity distribution")
            u = s.momentum() / s.mass.sum()
            speeds.append(np.linalg.norm(s.committed_velocity - u, axis=1) * np.sqrt(s.mass / t))
            temps.append(t)
        c = np.concatenate(speeds)
        d = s.dim
        self.dim = d
        self.samples = c.size
        self.temperature = float(np.mean(temps))
        self.bin_edges = np.linspace(0.0, self.c_max, self.bins + 1)
        self.bin_centers = 0.5 * (self.bin_edges[1:] + self.bin_edges[:-1])
        counts, _ = np.histogram(c, self.bin_edges)
        self.pdf = counts / (c.size * np.diff(self.bin_edges))
        self.a2 = sonine_a2(c, d)
        self.a2_error = math.sqrt(8.0 / (d * (d + 2) * c.size))
        self.maxwell = maxwell_speed_pdf(self.bin_centers, d)
        x = 0.5 * self.bin_centers**2
        self.sonine = self.maxwell * (1.0 + self.a2 * (0.5 * x * x - 0.5 * (d + 2) * x + d * (d + 2) / 8.0))
        return self

    def plot(self, ax=None):
        """P(c) (points) against the Maxwell and Sonine references, log scale; returns the Axes."""
        ax = axes(ax)
        ax.semilogy(self.bin_centers, self.pdf, "o", ms=3, label=f"simulation ($a_2$ = {self.a2:.4f})")
        ax.semilogy(self.bin_centers, self.maxwell, "-", label="Maxwell")
        ax.semilogy(self.bin_centers, self.sonine, "--", label="Maxwell + Sonine $a_2$")
        ax.set_xlabel(r"reduced speed $c = |v - u|\,\sqrt{m/T}$")
        ax.set_ylabel("P(c)")
        ax.set_ylim(bottom=max(1e-5, 0.5 / max(self.samples, 1)))
        ax.legend(fontsize="small")
        return ax


class Pressure:
    r"""Pressure and compressibility factor from a thermo table (physics.md §5.3).

    Every thermo row holds the pressure averaged over the interval that ends at it (kinetic part
    plus collision virial), so the mean of equally spaced rows is the time average over the
    window. The compressibility factor is :math:`Z = \bar P / (n \bar T)`.

    Args:
        t_min: average rows with ``time > t_min`` only (skip equilibration).

    Attributes:
        time, pressure: the rows used.
        mean: time-averaged pressure.
        error: standard error of ``mean`` from 5 blocks (``nan`` with fewer than 5 rows).
        temperature: mean temperature over the rows.
        compressibility: :math:`Z` (only when a density is known, else ``nan``).

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(500, 0.1), 1.0, seed=1))
        >>> th = sim.add(edmd.Thermo(1.0)); sim.run(until_time=5.0)
        >>> p = Pressure().compute(th, state=sim.state)
        >>> 1.3 < p.compressibility < 1.8
        True
    """

    def __init__(self, t_min: float = -math.inf):
        self.t_min = t_min

    def compute(self, thermo, state: State | None = None, density: float | None = None) -> Pressure:
        """From a :class:`~edmd.Thermo`, its table or a thermo CSV; ``state`` or ``density`` gives :math:`n`."""
        table = _thermo_table(thermo)
        keep = (table["time"] > self.t_min) & np.isfinite(table["pressure"])
        if not keep.any():
            raise ValueError("no thermo rows with a pressure in the requested window")
        self.time = table["time"][keep]
        self.pressure = table["pressure"][keep]
        self.mean = float(self.pressure.mean())
        blocks = np.array_split(self.pressure, 5) if self.pressure.size >= 5 else []
        self.error = float(np.std([b.mean() for b in blocks], ddof=1) / math.sqrt(5)) if blocks else math.nan
        self.temperature = float(table["temperature"][keep].mean())
        n = state.n / state.volume if state is not None else density
        self.compressibility = self.mean / (n * self.temperature) if n else math.nan
        return self


def _thermo_table(thermo) -> dict[str, np.ndarray]:
    """A thermo table from a Thermo observer, a dict of columns or a CSV path."""
    if isinstance(thermo, (str, os.PathLike)):
        from ..files.thermo import read_thermo

        table = read_thermo(thermo)
    elif hasattr(thermo, "table"):
        table = thermo.table()
    else:
        table = thermo
    missing = [c for c in ("time", "temperature", "pressure") if c not in table]
    if missing:
        raise ValueError(f"the thermo table lacks columns {missing}")
    return table


class HaffLaw:
    r"""Haff's law of a freely cooling granular gas with constant :math:`e_n` (physics.md §5.4).

    .. math::
        T(t) = \frac{T_0}{(1 + (t-t_0)/\tau_0)^2},\qquad
        \tau_0^{-1} = \begin{cases}\tfrac23(1-e_n^2)\,n\sigma^2\chi\sqrt{\pi T_0/m} & 3D\\
        \tfrac12(1-e_n^2)\,n\sigma\chi\sqrt{\pi T_0/m} & 2D\end{cases}

    with :math:`\chi` from Carnahan–Starling (3D) or Henderson (2D) unless given.

    Example (physics.md W7):
        >>> round(HaffLaw(e_n=0.9, dim=3, density=0.190986, sigma=1.0, kT0=1.0, eta=0.1).tau0, 3)
        17.896
    """

    def __init__(self, e_n: float, dim: int, density: float, sigma: float, kT0: float, mass: float = 1.0,
                 t0: float = 0.0, eta: float | None = None, chi: float | None = None):  # fmt: skip
        if not 0 <= e_n < 1:
            raise ValueError(f"Haff's law needs 0 <= e_n < 1, got {e_n}")
        if not (kT0 > 0 and math.isfinite(kT0)):
            raise ValueError(f"Haff's law needs a positive initial temperature kT0, got {kT0}")
        if chi is None:
            if eta is None:
                raise ValueError("give the packing fraction eta or the contact value chi")
            chi = contact_value(eta, dim)
        self.e_n, self.dim, self.density, self.sigma = e_n, dim, density, sigma
        self.kT0, self.mass, self.t0, self.chi = kT0, mass, t0, chi
        pref = 2.0 / 3.0 * sigma**2 if dim == 3 else 0.5 * sigma
        self.tau0 = 1.0 / (pref * (1 - e_n**2) * density * chi * math.sqrt(math.pi * kT0 / mass))

    @classmethod
    def from_state(cls, state: State, e_n: float, kT0: float | None = None, t0: float | None = None) -> HaffLaw:
        """Haff's law for ``state`` (mean diameter and mass; :math:`T_0`, :math:`t_0` default to the state's)."""
        return cls(
            e_n=e_n,
            dim=state.dim,
            density=state.n / state.volume,
            sigma=2.0 * float(state.radius.mean()),
            kT0=state.temperature() if kT0 is None else kT0,
            mass=float(state.mass.mean()),
            t0=state.time if t0 is None else t0,
            eta=state.packing_fraction,
        )

    @property
    def label(self) -> str:
        """Legend text of the law."""
        return rf"Haff's law, $\tau_0$ = {self.tau0:.4g}"

    def __call__(self, t):
        """:math:`T(t)`."""
        return self.kT0 / (1.0 + (np.asarray(t, float) - self.t0) / self.tau0) ** 2


class AlgebraicCooling:
    r"""Late-time algebraic cooling :math:`T \propto (t - t_0)^{-p}` through the point :math:`(t_1, T_1)`.

    .. math:: T(t) = T_1\Big(\frac{t - t_0}{t_1 - t_0}\Big)^{-p}

    Viscoelastic spheres cool as :math:`T(t)=T_0[1+t/\tau_0]^{-5/3}\propto t^{-5/3}` at late
    times (physics.md §5.4), the default ``exponent``; anchored at the last measured point it
    shows whether a run has reached that regime.

    Example:
        >>> law = AlgebraicCooling(t1=10.0, kT1=0.5)
        >>> round(float(law(20.0)), 6), round(0.5 * 2 ** (-5 / 3), 6)
        (0.15749, 0.15749)
    """

    def __init__(self, t1: float, kT1: float, exponent: float = 5.0 / 3.0, t0: float = 0.0):
        if not t1 > t0:
            raise ValueError(f"the reference time t1 = {t1} must come after t0 = {t0}")
        self.t1, self.kT1, self.exponent, self.t0 = float(t1), float(kT1), float(exponent), float(t0)

    @property
    def label(self) -> str:
        """Legend text of the law."""
        p = Fraction(self.exponent).limit_denominator(12)
        return rf"$\propto t^{{-{p}}}$ (viscoelastic, late times)"

    def __call__(self, t):
        """:math:`T(t)`."""
        return self.kT1 * ((np.asarray(t, float) - self.t0) / (self.t1 - self.t0)) ** -self.exponent
