r"""Transport coefficients at equilibrium: Einstein–Helfand shear viscosity and thermal conductivity,
self-diffusion, Enskog references (physics.md §5.6).

The shear viscosity follows from the growth of the Helfand moment :math:`G_{ab}(t) = V\int_0^t P_{ab}\,dt'`
(:math:`a\ne b`), whose increments the thermo table holds exactly: its ``pressure_<ab>`` columns are
the pressure tensor averaged over each interval (:func:`edmd.files.thermo.pressure_tensor`), kinetic
part and collisional virial, so :math:`\Delta G_{ab} = V P_{ab}\,\Delta t` with no sampling error — the
Einstein–Helfand form DynamO uses, exact for the impulsive forces of hard spheres:

.. math::
    \eta = \lim_{\tau\to\infty}\frac{1}{2Vk_BT}\frac{d}{d\tau}\big\langle[G_{ab}(t+\tau) - G_{ab}(t)]^2\big\rangle .

The thermal conductivity follows the same way from the energy moment, whose increments are the
``energy_flux_<a>`` columns (:math:`\Delta G_a = V J_{E,a}\Delta t`, the kinetic transport
:math:`\sum_i e_i\mathbf v_i` and the collisional transfer, physics.md §5.6):
:math:`\lambda = \lim \frac{1}{2Vk_BT^2}\frac{d}{d\tau}\langle\Delta G_a^2\rangle`. The energy current is the heat
current only without convection: equal masses and zero total momentum (the analysis checks both).
"""

from __future__ import annotations

import math

import numpy as np

from ..state import State
from ._common import axes, contact_value, each_state
from .thermal import _thermo_table

#: Chapman–Cowling's factor of the second Sonine approximation to the dilute viscosity (3D spheres, 2D disks)
_SONINE_VISCOSITY = {3: 1.016, 2: 1.022}
#: ... to the dilute thermal conductivity
_SONINE_CONDUCTIVITY = {3: 1.025, 2: 1.029}
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


def enskog_conductivity(eta: float, dim: int, sigma: float = 1.0, mass: float = 1.0, kT: float = 1.0, g_contact: float | None = None) -> float:
    r"""Enskog's thermal conductivity of hard spheres (3D) or disks (2D), :math:`k_B = 1`.

    physics.md §5.6, with :math:`y` and :math:`\chi` as in :func:`enskog_viscosity`:

    .. math::
        \frac{\lambda_E}{\lambda_0} = \frac1\chi + \tfrac65 y + 0.7575\,y^2\chi,\quad
        \lambda_0 = 1.025\,\frac{75}{64\sigma^2}\sqrt{\frac{k_BT}{\pi m}}\quad(3D);\qquad
        \frac{\lambda_E}{\lambda_0} = \frac1\chi + \tfrac32 y + \big(\tfrac9{16} + \tfrac1\pi\big)y^2\chi,\quad
        \lambda_0 = 1.029\,\frac{2}{\sigma}\sqrt{\frac{k_BT}{\pi m}}\quad(2D).

    Example:
        >>> round(enskog_conductivity(math.pi * 0.5 / 6, 3), 4)   # n sigma^3 = 0.5
        2.3815
    """
    _check(eta, dim)
    chi = contact_value(eta, dim) if g_contact is None else g_contact
    root = math.sqrt(kT / (math.pi * mass))
    if dim == 3:
        y = 4.0 * eta
        return _SONINE_CONDUCTIVITY[3] * 75.0 / (64.0 * sigma**2) * root * (1.0 / chi + 1.2 * y + 0.7575 * y * y * chi)
    y = 2.0 * eta
    return _SONINE_CONDUCTIVITY[2] * 2.0 / sigma * root * (1.0 / chi + 1.5 * y + (9.0 / 16.0 + 1.0 / math.pi) * y * y * chi)


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


def _fit_slope(lags: np.ndarray, values: np.ndarray, fit: slice) -> float:
    return float(np.polyfit(lags[fit], values[fit], 1)[0])


def _monodisperse(state: State) -> bool:
    return bool(np.all(state.radius == state.radius[0]) and np.all(state.mass == state.mass[0]))


class _Einstein:
    """A coefficient from the growth of a mean square over lags in ``[fit_from, lag_max]``, error by blocks.

    Args:
        t_min: use rows (frames) with ``time > t_min`` only (skip equilibration).
        lag_max: the longest lag (time); ``fit_from`` the shortest fitted one (default ``lag_max / 2``).
            Both need to exceed the decay time of the correlations (a few mean free times; longer
            near freezing).
        blocks: equal parts of the run for the error estimate.
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

    def _lags(self, times: np.ndarray, what: str) -> tuple[float, int, slice]:
        """The spacing of equally spaced ``times``, the number of lags and the fitted ones."""
        if times.size < 2:
            raise ValueError(f"fewer than two {what} in the requested window")
        steps = np.diff(times)
        dt = float(steps[0])
        if not np.allclose(steps, dt, rtol=1e-9, atol=0.0):
            raise ValueError(f"Einstein relations need equally spaced {what} (one interval, no gaps)")
        lags = int(round(self.lag_max / dt))
        first = max(int(math.ceil(self.fit_from / dt - 1e-9)), 1)
        if lags - first < 1:
            raise ValueError(f"lag_max {self.lag_max} and fit_from {self.fit_from} leave fewer than two lags of the interval {dt}")
        if times.size < 4 * lags * self.blocks:
            raise ValueError(f"{times.size} {what} are too few for lags up to {lags} intervals in {self.blocks} blocks (need {4 * lags * self.blocks})")
        self.lag_times = dt * np.arange(lags + 1)
        return dt, lags, slice(first, lags + 1)

    def _fit(self, series: np.ndarray, mean_square, scale: float, lags: int, fit: slice) -> tuple[np.ndarray, float, float]:
        """``mean_square(series, lags)``, the slope over ``fit`` divided by ``scale``, and its block error."""
        ms = mean_square(series, lags)[: lags + 1]
        value = _fit_slope(self.lag_times, ms, fit) / scale
        parts = [_fit_slope(self.lag_times, mean_square(p, lags)[: lags + 1], fit) / scale for p in np.array_split(series, self.blocks)]
        return ms, value, float(np.std(parts, ddof=1) / math.sqrt(self.blocks))

    def _helfand(self, thermo, state: State, columns: list[str], what: str) -> tuple[np.ndarray, dict, np.ndarray]:
        """Fit the Helfand moments of thermo ``columns`` (each a flux per volume, averaged over a row's interval)."""
        table = _thermo_table(thermo)
        if any(c not in table for c in columns):
            raise ValueError(f"the thermo table has no {what} (columns {', '.join(columns)})")
        t = np.asarray(table["time"], float)
        keep = (t > self.t_min) & np.isfinite(table[columns[0]])
        dt, lags, fit = self._lags(t[keep], "thermo rows")
        increments = np.column_stack([np.asarray(table[c], float)[keep] for c in columns]) * state.volume * dt
        self.temperature = float(np.asarray(table["temperature"], float)[keep].mean())
        self.packing_fraction = state.packing_fraction
        return increments, lags, fit

    def _coefficient(self, thermo, state: State, columns: list[str], what: str, power: int, reference) -> float:
        """The Helfand fit of ``columns`` scaled by :math:`2Vk_BT^{\\rm power}`; sets ``error``, ``running``, ``enskog``."""
        increments, lags, fit = self._helfand(thermo, state, columns, what)
        scale = 2.0 * state.volume * self.temperature**power
        ms, value, self.error = self._fit(increments, _helfand_msd, scale, lags, fit)
        with np.errstate(invalid="ignore", divide="ignore"):
            self.running = ms / (scale * self.lag_times)
        self.enskog = self._enskog(reference, state)
        return value

    def _enskog(self, reference, state: State) -> float:
        """``reference`` (an Enskog coefficient) at the state's packing fraction and the mean temperature (``nan``: polydisperse)."""
        if not _monodisperse(state):
            return math.nan
        return reference(state.packing_fraction, state.dim, 2.0 * state.radius[0], state.mass[0], self.temperature)

    def _plot(self, value: float, error: float, enskog: float, symbol: str, name: str, ax=None):
        ax = axes(ax)
        ax.plot(self.lag_times[1:], self.running[1:], "o-", ms=3, label=r"$\langle\Delta G^2\rangle$ / (scale $\tau$)")
        ax.axhline(value, color="k", lw=1, label=rf"Einstein–Helfand ${symbol} = {value:.4g} \pm {error:.2g}$")
        if math.isfinite(enskog):
            ax.axhline(enskog, color="C3", ls="--", lw=1, label=rf"Enskog ${symbol}_E = {enskog:.4g}$")
        ax.set_xlabel(r"lag $\tau$")
        ax.set_ylabel(name)
        ax.legend(fontsize="small")
        return ax


class ShearViscosity(_Einstein):
    r"""Shear viscosity by Einstein–Helfand from a thermo table's pressure tensor (module doc).

    The Helfand moments of the off-diagonal components (``xy, xz, yz``; 2D ``xy``; those of
    periodic axes only: walls take impulses that the pressure tensor does not hold) are averaged over
    every time origin and component; :math:`\eta` is the slope of their mean square against the lag,
    fitted over ``[fit_from, lag_max]`` and divided by :math:`2Vk_BT` (``T`` the mean temperature of
    the rows). Its error is the standard error of the same fit in ``blocks`` equal parts of the run.
    Arguments as for :class:`SelfDiffusion`.

    Attributes:
        lag_times, running: the lags and the running estimate :math:`\langle\Delta G^2\rangle/(2Vk_BT\tau)`.
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

    def compute(self, thermo, state: State) -> ShearViscosity:
        """From a :class:`~edmd.Thermo`, its table or a thermo CSV with the pressure tensor, and the
        run's ``state`` (volume, dimension, radii); returns ``self``."""
        pairs = [(a, b) for a, b in ((0, 1), (0, 2), (1, 2)) if b < state.dim and state.periodic[a] and state.periodic[b]]
        if not pairs:
            raise ValueError("the shear viscosity needs two periodic axes (walls take impulses that the pressure tensor does not hold)")
        columns = [f"pressure_{'xyz'[a]}{'xyz'[b]}" for a, b in pairs]
        what = "pressure tensor (DEM runs, vibrated beds and thermo tables continued from checkpoints of older versions have none)"
        self.viscosity = self._coefficient(thermo, state, columns, what, 1, enskog_viscosity)
        return self

    def plot(self, ax=None):
        """The running estimate against the lag, the fitted value and Enskog's; returns the Axes."""
        return self._plot(self.viscosity, self.error, self.enskog, r"\eta", "shear viscosity", ax)


class ThermalConductivity(_Einstein):
    r"""Thermal conductivity by Einstein–Helfand from a thermo table's energy flux (module doc).

    The energy moments of the ``d`` components (periodic axes only) are averaged over every time origin and component;
    :math:`\lambda` is the slope of their mean square against the lag over ``[fit_from, lag_max]``,
    divided by :math:`2Vk_BT^2`, with block errors as :class:`ShearViscosity`. The energy flux is
    the heat flux only for equal masses at zero total momentum (``ValueError`` otherwise).

    Attributes:
        lag_times, running: the lags and :math:`\langle\Delta G^2\rangle/(2Vk_BT^2\tau)`.
        conductivity, error: :math:`\lambda` and its standard error.
        temperature, packing_fraction, enskog: as :class:`ShearViscosity` (:func:`enskog_conductivity`).

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2618), 1.0, seed=1))
        >>> th = sim.add(edmd.Thermo(interval=0.25)); sim.run(until_time=100.0)
        >>> c = ThermalConductivity(lag_max=2.0).compute(th, sim.state)
        >>> bool(0.3 < c.conductivity / c.enskog < 1.7)
        True
    """

    def compute(self, thermo, state: State) -> ThermalConductivity:
        """From a :class:`~edmd.Thermo`, its table or a thermo CSV with the energy flux, and the run's ``state``; returns ``self``."""
        if not np.all(state.mass == state.mass[0]):
            raise ValueError("the thermal conductivity needs equal masses (the energy flux of a mixture carries enthalpy by diffusion)")
        axes_used = [k for k in range(state.dim) if state.periodic[k]]
        if not axes_used:
            raise ValueError("the thermal conductivity needs a periodic axis")
        p = np.abs(state.momentum()[axes_used]).max()
        if p > 1e-9 * state.mass.sum() * math.sqrt(max(state.temperature(), 0.0) / state.mass[0]):
            raise ValueError(f"the thermal conductivity needs zero total momentum along its axes (the state has |P| = {p:.3g}: the energy flux then convects)")
        columns = [f"energy_flux_{'xyz'[k]}" for k in axes_used]
        what = "energy flux (kept without gravity, square wells or white noise, and not in tables continued from checkpoints of older versions)"
        self.conductivity = self._coefficient(thermo, state, columns, what, 2, enskog_conductivity)
        return self

    def plot(self, ax=None):
        """The running estimate against the lag, the fitted value and Enskog's; returns the Axes."""
        return self._plot(self.conductivity, self.error, self.enskog, r"\lambda", "thermal conductivity", ax)


class SelfDiffusion(_Einstein):
    r"""Self-diffusion coefficient from the mean-squared displacement of a trajectory, with block errors.

    :math:`D` is the slope of :math:`\mathrm{MSD}(\tau)/(2d)` (:func:`edmd.analysis.msd_window`, every
    time origin) fitted over ``[fit_from, lag_max]``; its error is the standard error of the same
    fit in ``blocks`` consecutive parts of the frames. Periodic boxes hold finite-size effects: the
    hydrodynamic correction :math:`2.837297\,k_BT/(6\pi\eta L)` (Yeh & Hummer, J. Phys. Chem. B 108,
    15873 (2004)) is not applied.

    Args:
        t_min: use frames with ``time > t_min`` only (skip equilibration).
        lag_max: the longest lag (time); ``fit_from`` the shortest fitted one (default ``lag_max / 2``).
            Both need to exceed the decay time of the correlations (a few mean free times; longer
            near freezing).
        blocks: equal parts of the run for the error estimate.

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
        _dt, lags, fit = self._lags(np.array(times), "frames")
        self.msd, self.diffusion, self.error = self._fit(np.stack(positions), lambda r, _lags: msd_window(r), 2.0 * last.dim, lags, fit)
        self.temperature = float(np.mean(temperatures))
        self.enskog = self._enskog(enskog_diffusion, last)
        return self
