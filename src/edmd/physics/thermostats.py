r"""Thermostats and forcing that act through events of the compiled core.

:class:`Andersen` is the heat bath of H. C. Andersen (J. Chem. Phys. 72, 2384 (1980)) in its
event-driven form: every particle meets the bath at the times of its own Poisson process of rate
:math:`\nu`, each meeting an event in the calendar (``_core/bath.py``). At a meeting the
particle's velocity, and its spin when the collision rule is rough, are drawn anew from the
Maxwell–Boltzmann distribution at :math:`k_BT`:

.. math::
    p(\mathbf v) \propto \exp\!\left(-\frac{m v^2}{2 k_BT}\right),\qquad
    p(\boldsymbol\omega) \propto \exp\!\left(-\frac{I \omega^2}{2 k_BT}\right).

Elastic hard spheres then sample the canonical ensemble at :math:`k_BT` (their equation of
state is unchanged); a granular gas reaches a steady state where the bath's input balances
the collisional loss. The energy the bath puts in is booked as ``energy_input`` (``Totals``,
``thermo.csv``), so ``energy_balance`` stays constant to round-off.

The random numbers come from a counter-based generator keyed by the seed, the particle and its
event counter, and the time of the engine's last load (:mod:`edmd._core.rng`): no generator
state exists, and a run restarted from a checkpoint continues bit for bit.

:class:`WhiteNoise` kicks every particle at fixed intervals: a global event of the calendar
(``_core/forcing.py``), the stochastic thermostat of granular gases. :mod:`edmd.run.updaters`
(velocity rescaling, your own) changes the system from Python at fixed intervals instead.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import layout as L
from .._core.forcing import tick_time
from .vibration import VibratingWall
from .growth import Growth
from .wells import SquareWell
from .shear import Shear


@dataclasses.dataclass(frozen=True)
class Andersen:
    """Andersen heat bath: Poisson resampling of each particle's velocity (and spin) at ``kT``.

    Args:
        kT: bath temperature :math:`k_BT` (> 0).
        rate: rate :math:`\\nu` of each particle's bath events (> 0): the mean time between two
            resamplings of one particle is :math:`1/\\nu`.
        seed: seed of the random numbers (an integer in ``[0, 2**63)``).

    Example:
        >>> import edmd
        >>> state = edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), kT=0.2, seed=1)
        >>> sim = edmd.Simulation(state, thermostat=edmd.Andersen(kT=1.0, rate=2.0, seed=7))
        >>> sim.run(until_time=5.0)
        >>> 0.8 < sim.state.temperature() < 1.2
        True
    """

    kT: float
    rate: float
    seed: int = 0

    def __post_init__(self):
        _check_parameters(self, ("kT", "rate"))

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write the bath's parameters into the core's parameter arrays."""
        ip[L.IP_BATH] = 1
        ip[L.IP_BATH_SEED] = int(self.seed)
        fp[L.FP_BATH_KT] = float(self.kT)
        fp[L.FP_BATH_RATE] = float(self.rate)

    def to_dict(self) -> dict:
        """JSON-ready parameters (``kind`` names the thermostat)."""
        return {"kind": "andersen", **dataclasses.asdict(self)}


@dataclasses.dataclass(frozen=True)
class WhiteNoise:
    r"""White-noise forcing: every particle gets a random kick every ``interval`` (Williams &
    MacKintosh, PRE 54, R9 (1996); van Noije & Ernst, Granular Matter 1, 57 (1998)).

    At the times :math:`t_j = t_{\rm start} + j\,\Delta t` every velocity changes by
    :math:`\xi_0\sqrt{\Delta t}\,(\mathbf g_i - \sum_k m_k\mathbf g_k / M)` with independent
    standard normal :math:`\mathbf g_i`: a variance of :math:`\xi_0^2\Delta t` per component, less
    the mass-weighted mean kick, so the total momentum stays what it was. For :math:`N`
    particles of equal mass :math:`m` in :math:`d` dimensions the mean energy input is
    :math:`\tfrac12 m d (N-1)\xi_0^2` per unit time. Each kick is one global event of the calendar
    (all particles streamed, kicked and re-predicted, no rebuild), booked as ``energy_input``.
    The kicks are a pure function of (seed, tick, particle): restarts continue bit for bit.

    Args:
        xi0: forcing strength :math:`\xi_0` (> 0).
        interval: time :math:`\Delta t` between kicks (> 0); choose it well below the mean free time.
        seed: seed of the random kicks (an integer in ``[0, 2**63)``).
        start: absolute time of kick 0 (the first kick of a run is the first tick at or after its start).

    Example:
        >>> import edmd
        >>> state = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), kT=1.0, seed=2)
        >>> sim = edmd.Simulation(state, e_n=0.8, forcing=edmd.WhiteNoise(xi0=1.0, interval=0.05, seed=3))
        >>> sim.run(until_time=1.0)
        >>> sim.totals().energy_input > 0, bool(abs(sim.state.momentum()).max() < 1e-9)
        (True, True)
    """

    xi0: float
    interval: float
    seed: int = 0
    start: float = 0.0

    def __post_init__(self):
        _check_parameters(self, ("xi0", "interval"))
        if not (isinstance(self.start, int | float) and math.isfinite(self.start)):
            raise ValueError(f"WhiteNoise start must be a finite time, got {self.start!r}")

    def tick_time(self, tick: int) -> float:
        """Absolute time of kick ``tick`` (by multiplication: it never drifts; the core's formula)."""
        return float(tick_time(float(self.start), float(self.interval), int(tick)))

    def first_tick(self, t: float) -> int:
        """The first kick at or after time ``t``."""
        tick = max(0, math.ceil((t - self.start) / self.interval))
        while tick > 0 and self.tick_time(tick - 1) >= t:
            tick -= 1
        while self.tick_time(tick) < t:
            tick += 1
        return tick

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write the forcing's parameters into the core's parameter arrays."""
        ip[L.IP_KICK] = 1
        ip[L.IP_KICK_SEED] = int(self.seed)
        fp[L.FP_KICK_XI0] = float(self.xi0)
        fp[L.FP_KICK_INTERVAL] = float(self.interval)
        fp[L.FP_KICK_START] = float(self.start)

    def to_dict(self) -> dict:
        """JSON-ready parameters (``kind`` names the forcing)."""
        return {"kind": "white_noise", **dataclasses.asdict(self)}


def _check_parameters(driver, positive: tuple[str, ...]):
    """The named fields of ``driver`` are positive numbers and its seed fits the generator's key."""
    owner = type(driver).__name__
    for name in positive:
        value = getattr(driver, name)
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ValueError(f"{owner} {name} must be a positive number, got {value!r}")
    seed = driver.seed
    if not (isinstance(seed, int | np.integer) and not isinstance(seed, bool) and 0 <= seed < 2**63):
        raise ValueError(f"{owner} seed must be an integer in [0, 2**63), got {seed!r}")


DRIVERS = {"andersen": Andersen, "white_noise": WhiteNoise, "vibrating_wall": VibratingWall, "square_well": SquareWell, "growth": Growth, "shear": Shear}


def driver_from_dict(data: dict | None, expected: type):
    """The thermostat, forcing, vibrating wall, square well, growth or shear of a ``to_dict()`` (``None`` stays ``None``), checked to be an ``expected``.

    Example:
        >>> driver_from_dict({"kind": "andersen", "kT": 1.0, "rate": 0.5}, Andersen)
        Andersen(kT=1.0, rate=0.5, seed=0)
        >>> driver_from_dict({"kind": "nose", "kT": 1.0}, Andersen)
        Traceback (most recent call last):
        ...
        ValueError: unknown kind 'nose'; the kinds are andersen, white_noise, vibrating_wall, square_well, growth, shear
    """
    if data is None:
        return None
    data = dict(data)
    kind = data.pop("kind", None)
    if kind not in DRIVERS:
        raise ValueError(f"unknown kind {kind!r}; the kinds are {', '.join(DRIVERS)}")
    driver = DRIVERS[kind](**data)
    if not isinstance(driver, expected):
        raise ValueError(f"{kind} is not a {expected.__name__}")
    return driver
