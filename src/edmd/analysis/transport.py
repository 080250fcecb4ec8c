r"""Transport coefficients at equilibrium: Einstein–Helfand shear viscosity, self-diffusion, Enskog references (physics.md §5.6).

The shear viscosity follows from the growth of the Helfand moment :math:`G_{ab}(t) = V\int_0^t P_{ab}\,dt'`
(:math:`a\ne b`), whose increments the thermo table holds exactly: its ``pressure_<ab>`` columns are
the pressure tensor averaged over each interval (:func:`edmd.files.thermo.pressure_tensor`), kinetic
part and collisional virial, so :math:`\Delta G_{ab} = V P_{ab}\,\Delta t` with no sampling error — the
Einstein–Helfand form DynamO uses, exact for the impulsive forces of hard spheres:

.. math::
    \eta = \lim_{\tau\to\infty}\frac{1}{2Vk_BT}\frac{d}{d\tau}\big\langle[G_{ab}(t+\tau) - G_{ab}(t)]^2\big\rangle .
"""

from __future__ import annotations

import math

import numpy as np

from ..state import State
from ._common import axes, contact_value, each_state
from .thermal import _thermo_table

#: Chapman–Cowling's factor of the second Sonine approximation to the dilute viscosity (3D spheres, 2D disks)
_SONINE_VISCOSITY = {3: 1.016, 2: 1.022}
#: ... and to the dilute self-diffusion coefficient (3D)
_SONINE_DIFFUSION = {3: 1.019, 2: 1.0}


def _check(eta: float, dim: int):
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    if not 0.0 < eta < 1.0:
        raise ValueError(f"packing fraction must be in (0, 1), got {eta}")


def enskog_viscosity(eta: float, dim: int, sigma: float = 1.0, mass: float = 1.0, kT: float = 1.0, g_contact: float | None = None) -> float:
    r"""Enskog's shear viscosity of hard spheres (3D) or disks (2D) at packing fraction ``eta``.

    physics.md §5.6 (Chapman & Cowling, 3rd ed., ch. 16; Gass, J. Chem. Phys. 54, 1898 (1971) for disks),
    with :math:`y = 4\eta` (3D), :math:`2\eta` (2D) and the contact value :math:`\chi` (:func:`contact_value`):

    .. math::
        \frac{\eta_E}{\eta_0} = \frac1\chi + \tfrac45 y + 0.7614\,y^2\chi,\quad
        \eta_0 = 1.016\,\frac{5}{16\sigma^2}\sqrt{\frac{mk_BT}{\pi}}\quad(3D);\qquad
        \frac{\eta_E}{\eta_0} = \frac1\chi + y + \big(\tfrac14 + \tfrac2\pi\big)y^2\chi,\quad
        \eta_0 = 1.022\,\frac{1}{2\sigma}\sqrt{\frac{mk_BT}{\pi}}\quad(2D).

    Example:
        >>> round(enskog_viscosity(math.pi * 0.5 / 6, 3), 4)   # n sigma^3 = 0.5
        0.5561
    """
    _check(eta, dim)
    chi = contact_value(eta, dim) if g_contact is None else g_contact
    root = math.sqrt(mass * kT / math.pi)
    if dim == 3:
        y = 4.0 * eta
        return _SONINE_VISCOSITY[3] * 5.0 / (16.0 * sigma**2) * root * (1.0 / chi + 0.8 * y + 0.7614 * y * y * chi)
    y = 2.0 * eta
    return _SONINE_VISCOSITY[2] / (2.0 * sigma) * root * (1.0 / chi + y + (0.25 + 2.0 / math.pi) * y * y * chi)


def enskog_diffusion(eta: float, dim: int, sigma: float = 1.0, mass: float = 1.0, kT: float = 1.0, g_contact: float | None = None) -> float:
    r"""Enskog's self-diffusion coefficient :math:`D_E = D_0/\chi` of hard spheres (3D) or disks (2D).

    physics.md §5.6, with the number density :math:`n`:

    .. math::
        D_0 = 1.019\,\frac{3}{8n\sigma^2}\sqrt{\frac{k_BT}{\pi m}}\quad(3D),\qquad
        D_0 = \frac{1}{2n\sigma}\sqrt{\frac{k_BT}{\pi m}}\quad(2D,\ \text{first Sonine approximation}).

    Example:
        >>> round(enskog_diffusion(math.pi * 0.5 / 6, 3), 4)
        0.1996
    """
    _check(eta, dim)
    chi = contact_value(eta, dim) if g_contact is None else g_contact
    root = math.sqrt(kT / (math.pi * mass))
    if dim == 3:
        n = 6.0 * eta / (math.pi * sigma**3)
        return _SONINE_DIFFUSION[3] * 3.0 / (8.0 * n * sigma**2) * root / chi
    n = 4.0 * eta / (math.pi * sigma**2)
    return root / (2.0 * n * sigma) / chi


def _helfand_msd(increments: np.ndarray, lags: int) -> np.ndarray:
    """Time-origin averaged :math:`\\langle[G(t+m) - G(t)]^2\\rangle` for ``m = 0..lags`` of the
    cumulated ``increments`` (rows: intervals, columns: components), averaged over the components."""
    g = np.vstack([np.zeros(increments.shape[1]), np.cumsum(increments, axis=0)])
    out = np.zeros(lags + 1)
    for m in range(1, lags + 1):
        out[m] = float(np.mean((g[m:] - g[:-m]) ** 2))
    return out


class ShearViscosity:
    r"""Shear viscosity by Einstein–Helfand from a thermo table's pressure tensor (module doc).

    The Helfand moments of the off-diagonal components (``xy, xz, yz``; 2D ``xy``) are averaged over
    every time origin and component; :math:`\eta` is the slope of their mean square against the lag,
    fitted over ``[fit_from, lag_max]`` and divided by :math:`2Vk_BT` (``T`` the mean temperature of
    the rows). Its error is the standard error of the same fit in ``blocks`` equal parts of the run.

    Args:
        t_min: use rows with ``time > t_min`` only (skip equilibration).
        lag_max: the longest lag (time); ``fit_from`` the shortest fitted one (default ``lag_max / 2``).
            Both need to exceed the decay time of the stress correlations (a few mean free times;
            longer near freezing).
        blocks: parts of the run for the error estimate.

    Attributes:
        lag_times, eta_t: the lags and the running estimate :math:`\langle\Delta G^2\rangle/(2Vk_BT\tau)`.
        viscosity, error: :math:`\eta` and its standard error.
        temperature, packing_fraction: of the rows / the state.
        enskog: :func:`enskog_viscosity` of a monodisperse system at that packing fraction (``nan`` if polydisperse).

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2618), 1.0, seed=1))
        >>> th = sim.add(edmd.Thermo(interval=0.25)); sim.run(until_time=100.0)
        >>> v = ShearViscosity(lag_max=2.0).compute(th, sim.state)
        >>> bool(0.3 < v.viscosity / v.enskog < 1.7)
        True
    """

    def __init__(self, t_min: float = -math.inf, lag_max: float = 2.0, fit_from: float | None = None, blocks: int = 5):
        if not lag_max > 0:
            raise ValueError(f"lag_max must be positive, got {lag_max}")
        if blocks < 2:
            raise ValueError(f"blocks must be at least 2, got {blocks}")
        self.t_min, self.lag_max, self.blocks = t_min, float(lag_max), int(blocks)
        self.fit_from = 0.5 * self.lag_max if fit_from is None else float(fit_from)
        if not 0 <= self.fit_from < self.lag_max:
            raise ValueError(f"fit_from must be in [0, lag_max), got {self.fit_from}")

    def compute(self, thermo, state: State) -> ShearViscosity:
        """From a :class:`~edmd.Thermo`, its table or a thermo CSV with the pressure tensor, and the
        run's ``state`` (volume, dimension, radii); returns ``self``."""
        table = _thermo_table(thermo)
        comps = [f"pressure_{c}" for c in (("xy",) if state.dim == 2 else ("xy", "xz", "yz"))]
        if any(c not in table for c in comps):
            raise ValueError("the thermo table has no pressure tensor (columns pressure_xy, ...): DEM runs and vibrated beds do not keep it")
        t = np.asarray(table["time"], float)
        keep = (t > self.t_min) & np.isfinite(table[comps[0]])
        t = t[keep]
        if t.size < 2:
            raise ValueError("fewer than two thermo rows with a pressure tensor in the requested window")
        steps = np.diff(t)
        dt = float(np.median(steps))
        if not np.allclose(steps, dt, rtol=1e-9, atol=0.0):
            raise ValueError("Einstein-Helfand needs equally spaced thermo rows (one observer interval, no gaps)")
        lags = int(round(self.lag_max / dt))
        first = int(math.ceil(self.fit_from / dt - 1e-9))
        if lags < 1 or lags - max(first, 1) < 1:
            raise ValueError(f"lag_max {self.lag_max} and fit_from {self.fit_from} leave fewer than two lags of the interval {dt}")
        if t.size < 4 * lags * self.blocks:
            raise ValueError(f"{t.size} rows are too few for lags up to {lags} rows in {self.blocks} blocks (need {4 * lags * self.blocks})")
        increments = np.column_stack([np.asarray(table[c], float)[keep] for c in comps]) * state.volume * dt
        self.temperature = float(np.asarray(table["temperature"], float)[keep].mean())
        scale = 2.0 * state.volume * self.temperature
        self.lag_times = dt * np.arange(lags + 1)
        msd = _helfand_msd(increments, lags)
        with np.errstate(invalid="ignore", divide="ignore"):
            self.eta_t = msd / (scale * self.lag_times)
        fit = slice(max(first, 1), lags + 1)
        self.viscosity = _fit_slope(self.lag_times, msd, fit) / scale
        parts = [_fit_slope(self.lag_times, _helfand_msd(p, lags), fit) / scale for p in np.array_split(increments, self.blocks)]
        self.error = float(np.std(parts, ddof=1) / math.sqrt(self.blocks))
        self.packing_fraction = state.packing_fraction
        r = state.radius
        mono = bool(np.all(r == r[0]) and np.all(state.mass == state.mass[0]))
        self.enskog = enskog_viscosity(self.packing_fraction, state.dim, 2.0 * r[0], state.mass[0], self.temperature) if mono else math.nan
        return self

    def plot(self, ax=None):
        """The running estimate against the lag, the fitted value and Enskog's; returns the Axes."""
        ax = axes(ax)
        ax.plot(self.lag_times[1:], self.eta_t[1:], "o-", ms=3, label=r"$\langle\Delta G^2\rangle/(2Vk_BT\tau)$")
        ax.axhline(self.viscosity, color="k", lw=1, label=rf"Einstein–Helfand $\eta = {self.viscosity:.4g} \pm {self.error:.2g}$")
        if math.isfinite(self.enskog):
            ax.axhline(self.enskog, color="C3", ls="--", lw=1, label=rf"Enskog $\eta_E = {self.enskog:.4g}$")
        ax.set_xlabel(r"lag $\tau$")
        ax.set_ylabel(r"shear viscosity")
        ax.legend(fontsize="small")
        return ax


def _fit_slope(lags: np.ndarray, values: np.ndarray, fit: slice) -> float:
    return float(np.polyfit(lags[fit], values[fit], 1)[0])


class SelfDiffusion:
    r"""Self-diffusion coefficient from the mean-squared displacement of a trajectory, with block errors.

    :math:`D` is the slope of :math:`\mathrm{MSD}(\tau)/(2d)` (:func:`edmd.analysis.msd_window`, every
    time origin) fitted over ``[fit_from, lag_max]``; its error is the standard error of the same
    fit in ``blocks`` consecutive parts of the frames. Periodic boxes hold finite-size effects: the
    hydrodynamic correction :math:`2.837297\,k_BT/(6\pi\eta L)` (Yeh & Hummer, J. Phys. Chem. B 108,
    15873 (2004)) is not applied.

    Args:
        t_min: use frames with ``time > t_min`` only.
        lag_max, fit_from: the longest lag (time) and the shortest fitted one (default ``lag_max / 2``).
        blocks: parts of the frames for the error estimate.

    Attributes:
        lag_times, msd: the lags and the MSD of all frames.
        diffusion, error: :math:`D` and its standard error.
        temperature: mean temperature of the frames; ``enskog``: :func:`enskog_diffusion` (``nan`` if polydisperse).

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2618), 1.0, seed=1))
        >>> frames = []
        >>> for k in range(200):
        ...     sim.run(until_time=0.25 * k); frames.append(sim.state)
        >>> d = SelfDiffusion(lag_max=2.5).compute(frames)
        >>> bool(0.5 < d.diffusion / d.enskog < 1.8)
        True
    """

    def __init__(self, t_min: float = -math.inf, lag_max: float = 5.0, fit_from: float | None = None, blocks: int = 5):
        if not lag_max > 0:
            raise ValueError(f"lag_max must be positive, got {lag_max}")
        if blocks < 2:
            raise ValueError(f"blocks must be at least 2, got {blocks}")
        self.t_min, self.lag_max, self.blocks = t_min, float(lag_max), int(blocks)
        self.fit_from = 0.5 * self.lag_max if fit_from is None else float(fit_from)
        if not 0 <= self.fit_from < self.lag_max:
            raise ValueError(f"fit_from must be in [0, lag_max), got {self.fit_from}")

    def compute(self, system) -> SelfDiffusion:
        """From States (a time series, equally spaced) or a GSD file; returns ``self``."""
        from .dynamics import msd_window

        times, positions, temperatures, last = [], [], [], None
        for s in each_state(system):
            if s.time > self.t_min:
                times.append(s.time)
                positions.append(s.unwrapped_position)
                temperatures.append(s.temperature())
                last = s
        if len(times) < 2:
            raise ValueError("fewer than two frames in the requested window")
        steps = np.diff(times)
        dt = float(steps[0])
        if not np.allclose(steps, dt, rtol=1e-9, atol=0.0):
            raise ValueError("the MSD needs equally spaced frames")
        lags = int(round(self.lag_max / dt))
        first = max(int(math.ceil(self.fit_from / dt - 1e-9)), 1)
        if lags - first < 1:
            raise ValueError(f"lag_max {self.lag_max} and fit_from {self.fit_from} leave fewer than two lags of the frame interval {dt}")
        if len(times) < 4 * lags * self.blocks:
            raise ValueError(f"{len(times)} frames are too few for lags up to {lags} frames in {self.blocks} blocks (need {4 * lags * self.blocks})")
        r = np.stack(positions)
        scale = 2.0 * last.dim
        self.lag_times = dt * np.arange(lags + 1)
        fit = slice(first, lags + 1)
        self.msd = msd_window(r)[: lags + 1]
        self.diffusion = _fit_slope(self.lag_times, self.msd, fit) / scale
        parts = [_fit_slope(self.lag_times, msd_window(p)[: lags + 1], fit) / scale for p in np.array_split(r, self.blocks)]
        self.error = float(np.std(parts, ddof=1) / math.sqrt(self.blocks))
        self.temperature = float(np.mean(temperatures))
        radius, mass = last.radius, last.mass
        mono = bool(np.all(radius == radius[0]) and np.all(mass == mass[0]))
        self.enskog = enskog_diffusion(last.packing_fraction, last.dim, 2.0 * radius[0], mass[0], self.temperature) if mono else math.nan
        return self
