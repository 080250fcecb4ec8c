r"""Uniform shear flow (Lees-Edwards, :class:`edmd.Shear`): steady-state rheology from a thermo table,
and the kinetic theory of the steady uniform shear flow of a granular gas (physics.md §5.8).

In the steady state of a sheared system at rate :math:`\dot\gamma` the thermo table's rows hold
the temperature and the pressure tensor relative to the flow (peculiar velocities) over each
interval. :class:`ShearFlow` averages them after a settling time with blocking errors
(:class:`.SteadyState`) and reports the shear viscosity :math:`\eta = -P_{xy}/\dot\gamma`, the
reduced pressure tensor and the reduced shear rate :math:`a^* = \dot\gamma/(\chi\nu)` with the
collision frequency :math:`\nu = p/\eta_0` (:func:`usf_collision_frequency`) and Enskog's factor
:math:`\chi` (the contact value), which :func:`usf_grad` predicts for inelastic hard spheres.
"""

from __future__ import annotations

import math

import numpy as np

from ._common import axes, contact_value
from .steady import SteadyState
from .thermal import _thermo_table


def dilute_viscosity(dim: int, sigma: float = 1.0, mass: float = 1.0, kT: float = 1.0) -> float:
    r"""The Boltzmann (first Sonine) shear viscosity of dilute elastic hard spheres or disks,
    :math:`\eta_0 = \frac{d+2}{8}\,\Gamma(d/2)\,\pi^{-(d-1)/2}\,\sigma^{1-d}\sqrt{mk_BT}`:
    :math:`\frac{5}{16\sigma^2}\sqrt{mk_BT/\pi}` (3D), :math:`\frac{1}{2\sigma}\sqrt{mk_BT/\pi}` (2D).

    Example:
        >>> round(dilute_viscosity(3) / (5 / 16 / math.sqrt(math.pi)), 12), round(dilute_viscosity(2) * 2 * math.sqrt(math.pi), 12)
        (1.0, 1.0)
    """
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    return (dim + 2) / 8.0 * math.gamma(dim / 2.0) * math.pi ** (-(dim - 1) / 2.0) * sigma ** (1 - dim) * math.sqrt(mass * kT)


def usf_collision_frequency(number_density: float, dim: int, sigma: float = 1.0, mass: float = 1.0, kT: float = 1.0) -> float:
    r"""The collision frequency :math:`\nu = p/\eta_0 = nk_BT/\eta_0` (:func:`dilute_viscosity`) that
    reduces the shear rate of uniform shear flow, :math:`a^* = \dot\gamma/\nu` (physics.md §5.8):
    :math:`\tfrac{16}{5}\sqrt\pi\,n\sigma^2\sqrt{k_BT/m}` (3D), :math:`2\sqrt\pi\,n\sigma\sqrt{k_BT/m}` (2D).

    Example:
        >>> round(usf_collision_frequency(1.0, 3), 4), round(usf_collision_frequency(1.0, 2), 4)
        (5.6719, 3.5449)
    """
    return number_density * kT / dilute_viscosity(dim, sigma, mass, kT)


def usf_grad(alpha: float, dim: int) -> dict[str, float]:
    r"""The steady uniform shear flow of dilute smooth inelastic hard spheres (3D) or disks (2D) with
    restitution :math:`\alpha`, by Grad's method with the linear closure (physics.md §5.8):

    .. math::
        \zeta^* = \frac{d+2}{4d}(1-\alpha^2),\quad \nu^*_\eta = \frac{(1+\alpha)(2d+3-3\alpha)}{4d},\quad
        P^*_{yy} = 1 - \frac{\zeta^*}{\nu^*_\eta},\quad P^*_{xx} = 1 + (d-1)\frac{\zeta^*}{\nu^*_\eta},\quad
        a^{*2} = \frac d2\,\frac{\zeta^*\nu_\eta^{*2}}{\nu^*_\eta - \zeta^*},\quad P^*_{xy} = -\frac{a^*P^*_{yy}}{\nu^*_\eta}

    (pressures in units of :math:`nk_BT`, :math:`a^* = \dot\gamma/\nu`, :func:`usf_collision_frequency`;
    :math:`P^*_{zz} = P^*_{yy}`). Returns ``a``, ``xx``, ``yy``, ``xy``, ``viscosity`` (:math:`\eta^* = -P^*_{xy}/a^*`),
    ``zeta``, ``nu_eta``.

    Example:
        >>> {k: round(v, 4) for k, v in usf_grad(0.9, 3).items() if k in ("a", "xy", "yy")}
        {'a': 0.3587, 'yy': 0.9206, 'xy': -0.3311}
    """
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    if not 0.0 <= alpha < 1.0:
        raise ValueError(f"alpha must be in [0, 1) (an elastic gas has no steady shear flow), got {alpha}")
    zeta = (dim + 2) / (4 * dim) * (1 - alpha**2)
    nu = (1 + alpha) * (2 * dim + 3 - 3 * alpha) / (4 * dim)
    a = math.sqrt(dim / 2 * zeta * nu**2 / (nu - zeta))
    yy = 1 - zeta / nu
    return {"a": a, "yy": yy, "xx": 1 + (dim - 1) * zeta / nu, "xy": -a * yy / nu, "viscosity": yy / nu, "zeta": zeta, "nu_eta": nu}


def usf_temperature(rate: float, packing_fraction: float, alpha: float, dim: int, sigma: float = 1.0, mass: float = 1.0) -> float:
    r"""The steady temperature of uniform shear flow at rate :math:`\dot\gamma`: the :math:`T` at which
    :math:`\dot\gamma/(\chi\nu(T))` is Grad's :math:`a^*(\alpha)` (:func:`usf_grad`), with Enskog's :math:`\chi` at
    the packing fraction:

    .. math::
        k_BT = m\Big[\frac{\dot\gamma}{a^*\chi\,c_d\,n\sigma^{d-1}}\Big]^2,\qquad c_3 = \tfrac{16}{5}\sqrt\pi,\; c_2 = 2\sqrt\pi .

    Example:
        >>> round(usf_temperature(0.02, 0.005, 0.9, 3), 3)
        1.034
    """
    n = packing_fraction / (math.pi / 6 * sigma**3 if dim == 3 else math.pi / 4 * sigma**2)
    nu1 = usf_collision_frequency(n, dim, sigma, mass, 1.0)  # at k_BT = 1; it grows as sqrt(T)
    return (abs(rate) / (usf_grad(alpha, dim)["a"] * contact_value(packing_fraction, dim) * nu1)) ** 2


class ShearFlow:
    r"""Steady uniform shear flow from a thermo table: temperature, pressure tensor, viscosity, :math:`a^*`.

    Args:
        rate: the shear rate :math:`\dot\gamma` of the run (:class:`edmd.Shear`).
        settle: ignore rows before this time (the approach to the steady state).
        min_blocks: blocking levels used for the errors (:class:`.SteadyState`).

    Attributes:
        temperature, temperature_error: the mean peculiar temperature and its standard error.
        pressure, pressure_error: dicts of the mean pressure tensor components (``"xx"``, ``"xy"``, ...)
            and their errors.
        viscosity, viscosity_error: :math:`\eta = -P_{xy}/\dot\gamma`.
        reduced_rate: :math:`a^* = \dot\gamma/(\chi\nu(T))` (:func:`usf_collision_frequency`, Enskog's
            :math:`\chi` at the packing fraction; monodisperse systems only, ``nan`` otherwise).
        reduced_pressure: the components divided by :math:`p = nk_BT` (the kinetic-theory :math:`P^*_{ab}`).
        time, series: the rows used and their ``pressure_xy`` and ``temperature`` (for plots).

    Example:
        >>> import edmd
        >>> shear = edmd.Shear(0.5)
        >>> s = edmd.maxwell_boltzmann(edmd.random_packing(400, 0.05, seed=1), 1.0, seed=2)
        >>> sim = edmd.Simulation(shear.with_profile(s), shear=shear, e_n=0.9)
        >>> th = sim.add(edmd.Thermo(1.0)); sim.run(until_time=400.0)
        >>> flow = ShearFlow(rate=0.5, settle=100.0).compute(th, sim.state)
        >>> bool(flow.viscosity > 0 and flow.pressure["xy"] < 0 < flow.reduced_rate)
        True
    """

    def __init__(self, rate: float, settle: float = -math.inf, min_blocks: int = 16):
        if not (math.isfinite(rate) and rate != 0.0):
            raise ValueError(f"rate must be a finite non-zero shear rate, got {rate!r}")
        self.rate = float(rate)
        self.settle = settle
        self.min_blocks = min_blocks

    def compute(self, thermo, state) -> ShearFlow:
        """From a :class:`~edmd.Thermo`, its table or a thermo CSV of a sheared run, and the run's
        ``state`` (volume, particles); returns ``self``."""
        table = _thermo_table(thermo)
        if "shear_work" not in table or "pressure_xy" not in table:
            raise ValueError("the thermo table is not that of a sheared run (it has no shear_work and pressure_xy columns)")
        average = SteadyState(self.settle, self.min_blocks)
        t = average.compute(table, "temperature")
        self.temperature, self.temperature_error = t.mean, t.error
        names = [c[len("pressure_") :] for c in table if c.startswith("pressure_")]
        self.pressure, self.pressure_error = {}, {}
        for name in names:
            p = average.compute(table, f"pressure_{name}")
            self.pressure[name], self.pressure_error[name] = p.mean, p.error
        self.viscosity = -self.pressure["xy"] / self.rate
        self.viscosity_error = self.pressure_error["xy"] / abs(self.rate)
        n = state.n / state.volume
        kinetic = n * self.temperature
        self.reduced_pressure = {name: value / kinetic for name, value in self.pressure.items()}
        mono = bool(np.all(state.radius == state.radius[0]) and np.all(state.mass == state.mass[0]))
        chi = contact_value(state.packing_fraction, state.dim)
        nu = chi * usf_collision_frequency(n, state.dim, 2.0 * state.radius[0], state.mass[0], self.temperature) if mono else math.nan
        self.reduced_rate = abs(self.rate) / nu
        time = np.asarray(table["time"], float)
        keep = (time >= self.settle) & np.isfinite(np.asarray(table["pressure_xy"], float))
        self.time = time[keep]
        self.series = {c: np.asarray(table[c], float)[keep] for c in ("pressure_xy", "temperature")}
        return self

    def plot(self, ax=None):
        """The shear stress :math:`-P_{xy}` and the temperature against time, with their means; returns the Axes."""
        ax = axes(ax)
        ax.plot(self.time, -self.series["pressure_xy"], lw=0.8, label=r"$-P_{xy}$")
        ax.axhline(-self.pressure["xy"], color="C0", ls="--", lw=1, label=rf"mean $-P_{{xy}} = {-self.pressure['xy']:.4g} \pm {self.pressure_error['xy']:.2g}$")
        ax.plot(self.time, self.series["temperature"], lw=0.8, color="C1", label="temperature")
        ax.axhline(self.temperature, color="C1", ls="--", lw=1)
        ax.set_xlabel("time")
        ax.legend(fontsize="small")
        return ax
