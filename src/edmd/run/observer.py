"""What observers see and how they are scheduled: :class:`Observer`, :class:`Callback` and the
cumulative :class:`Totals` of a run.

Observers read the system through the public, named quantities of a
:class:`~edmd.run.simulation.Simulation` (``state``, ``totals()``, ``gravity``, ``elastic_energy``,
``emd_counters()``, ...), never through its engine.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..state import State

if TYPE_CHECKING:
    from .simulation import Simulation


@dataclasses.dataclass(eq=False)
class Totals:
    """Cumulative counters and integrals of a simulation since its start (monotonic).

    Attributes:
        time: simulation time.
        events: events processed (collisions, crossings, rebuilds, stale predictions).
        collisions: binary collisions.
        virial: :math:`\\sum_{\\rm coll} \\mathbf r_{ij}\\cdot\\mathbf J` (physics.md §5.3).
        kinetic_integral: :math:`\\int E_{\\rm kin}\\,dt`.
        dissipated: kinetic (translational + rotational) energy lost in collisions.
        wall_impulse: ``(d, 2)`` normal momentum taken by the lower and upper wall of each axis.
        wall_collisions: particle-wall collisions.
        energy_input: mechanical energy put in by updaters (:mod:`edmd.run.updaters`).
        stress_integral: the six components (``xx, yy, zz, xy, xz, yz``) of
            :math:`\\int\\sum_i m_i\\mathbf v_i\\otimes\\mathbf v_i\\,dt + \\sum_{\\rm coll}\\tfrac12(\\mathbf r_{ij}\\otimes\\mathbf J + \\mathbf J\\otimes\\mathbf r_{ij})`
            (physics.md §5.3), or ``None`` where the engine does not keep it (the DEM, a vibrating wall).
        shear_work: the work of sliding Lees-Edwards boundaries on the peculiar motion,
            :math:`-\\dot\\gamma V\\int P_{xy}\\,dt` (the viscous heating; 0 without :class:`edmd.Shear`;
            with rough walls along z it also holds their tangential impulses' share).
        energy_flux_integral: the three components of
            :math:`\\int\\sum_i e_i\\mathbf v_i\\,dt + \\sum_{\\rm coll}\\tfrac12\\mathbf r_{ij}(\\Delta e_i - \\Delta e_j)`
            (physics.md §5.6), or ``None`` where the engine does not keep it (also gravity, square wells, white noise).
    """

    time: float
    events: int
    collisions: int
    virial: float
    kinetic_integral: float
    dissipated: float
    wall_impulse: np.ndarray
    wall_collisions: int
    energy_input: float = 0.0
    stress_integral: np.ndarray | None = None
    energy_flux_integral: np.ndarray | None = None
    shear_work: float = 0.0

    def __eq__(self, other):
        return isinstance(other, Totals) and self.to_dict() == other.to_dict()

    def to_dict(self) -> dict:
        """JSON-ready (exact: floats survive JSON's repr round trip)."""
        out = dataclasses.asdict(self)
        out["wall_impulse"] = self.wall_impulse.tolist()
        for name in ("stress_integral", "energy_flux_integral"):
            if out[name] is not None:
                out[name] = getattr(self, name).tolist()
        return out

    @classmethod
    def from_dict(cls, data: dict) -> Totals:
        data = dict(data)
        data["wall_impulse"] = np.asarray(data["wall_impulse"], np.float64).reshape(-1, 2)
        for name in ("stress_integral", "energy_flux_integral"):
            if data.get(name) is not None:
                data[name] = np.asarray(data[name], np.float64)
        return cls(**data)


class Observer:
    """Something that looks at the system at exact, equally spaced simulation times.

    Subclasses implement :meth:`observe`; ``interval`` is the spacing, ``start`` the first time
    (the simulation's time when attached, by default). Firing times are ``start + k*interval``
    computed by multiplication, so they never drift. Observers due at the same time fire in
    order of ``priority`` (then in the order they were added); checkpoints fire last.
    Observers that hold more than their schedule extend :meth:`checkpoint_data` and
    :meth:`restore_data` so that a restarted run continues them exactly.
    """

    priority = 0
    #: whether :meth:`fire` may change the state (updaters, :mod:`edmd.run.updaters`)
    changes_state = False
    #: whether :meth:`observe` reads its ``state`` argument (``None`` is passed otherwise: a
    #: checkpoint takes its own after a resync, and the copy of every particle is not kept for it)
    needs_state = True
    #: whether :meth:`observe` reads its state only while it runs (keeps nothing of it): such
    #: observers, when no other due then needs a copy, get a :class:`~edmd.state.StateView`
    #: (fields made when read) instead of a copy of every particle
    reads_once = False

    def __init__(self, interval: float, start: float | None = None):
        if not interval > 0 or not math.isfinite(interval):
            raise ValueError(f"observer interval must be a positive number, got {interval}")
        if start is not None and not math.isfinite(start):
            raise ValueError(f"observer start must be a finite time, got {start}")
        self.interval = float(interval)
        self.start = start
        self._k = 0

    def attach(self, sim: Simulation):
        if self.start is None:
            self.start = sim.time
        self._k = max(0, math.ceil((sim.time - self.start) / self.interval - 1e-9))

    @property
    def next_time(self) -> float:
        return self.start + self._k * self.interval

    @property
    def last_time(self) -> float | None:
        """The time this observer last fired on its schedule (``None`` before the first firing)."""
        return None if self._k == 0 else self.start + (self._k - 1) * self.interval

    def checkpoint_data(self) -> dict:
        """Everything needed to continue this observer exactly: JSON values or numpy arrays."""
        return {"start": self.start, "interval": self.interval, "k": self._k}

    def restore_data(self, data: dict):
        """Continue from :meth:`checkpoint_data` (called after :meth:`attach`)."""
        if data["interval"] != self.interval:
            raise ValueError(f"interval {self.interval!r} differs from the checkpoint's {data['interval']!r}")
        self.start = data["start"]
        self._k = int(data["k"])

    def fire(self, sim: Simulation, state: State, totals: Totals):
        self.observe(sim, state, totals)
        self._k += 1

    def observe(self, sim: Simulation, state: State, totals: Totals):  # pragma: no cover - interface
        raise NotImplementedError

    def sync(self):
        """Force what this observer has appended to its file onto the disk (called before every
        checkpoint, which counts those rows and frames: a power cut must not lose what it counts)."""

    def close(self):
        """Flush and release resources (files)."""


class Callback(Observer):
    """Observer that calls ``fn(state, totals)`` at every firing.

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), 1.0))
        >>> times = []
        >>> _ = sim.add(Callback(lambda s, tot: times.append(s.time), interval=0.5))
        >>> sim.run(until_time=1.0)
        >>> times
        [0.0, 0.5, 1.0]
    """

    def __init__(self, fn: Callable[[State, Totals], None], interval: float, start: float | None = None):
        super().__init__(interval, start)
        self.fn = fn

    def observe(self, sim, state, totals):
        self.fn(state, totals)
