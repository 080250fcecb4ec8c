r"""Thermostats that act through events of the compiled core.

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

The thermostats of :mod:`edmd.updaters` (velocity rescaling, white noise) act on the whole
system at fixed intervals instead.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ._core import layout as L


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
        for name in ("kT", "rate"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"Andersen {name} must be a positive number, got {value!r}")
        if not (isinstance(self.seed, int | np.integer) and not isinstance(self.seed, bool) and 0 <= self.seed < 2**63):
            raise ValueError(f"Andersen seed must be an integer in [0, 2**63), got {self.seed!r}")

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write the bath's parameters into the core's parameter arrays."""
        ip[L.IP_BATH] = 1
        ip[L.IP_BATH_SEED] = int(self.seed)
        fp[L.FP_BATH_KT] = float(self.kT)
        fp[L.FP_BATH_RATE] = float(self.rate)

    def to_dict(self) -> dict:
        """JSON-ready parameters (``kind`` names the thermostat)."""
        return {"kind": "andersen", **dataclasses.asdict(self)}


THERMOSTATS = {"andersen": Andersen}


def thermostat_from_dict(data: dict | None) -> Andersen | None:
    """The thermostat of :meth:`Andersen.to_dict` (``None`` stays ``None``).

    Example:
        >>> thermostat_from_dict({"kind": "andersen", "kT": 1.0, "rate": 0.5})
        Andersen(kT=1.0, rate=0.5, seed=0)
        >>> thermostat_from_dict({"kind": "nose", "kT": 1.0})
        Traceback (most recent call last):
        ...
        ValueError: unknown thermostat kind 'nose'; the kinds are andersen
    """
    if data is None:
        return None
    data = dict(data)
    kind = data.pop("kind", None)
    if kind not in THERMOSTATS:
        raise ValueError(f"unknown thermostat kind {kind!r}; the kinds are {', '.join(THERMOSTATS)}")
    return THERMOSTATS[kind](**data)
