r"""Updaters: operations that change the system at exact, equally spaced times (HOOMD-blue's updaters).

An :class:`Updater` is an observer whose firing returns a changed copy of the state; the
simulation continues from it (a resync: neighbour structures and the calendar are rebuilt)
and books the change of mechanical energy as ``energy_input``
(:attr:`~edmd.run.observer.Totals.energy_input`, the ``energy_input`` column of thermo.csv), so
that kinetic + rotational + potential + dissipated - input stays constant to round-off.

Firing times are ``start + k * interval``, cut into the run exactly like observers' times, so a
run split into several :meth:`~edmd.Simulation.run` calls is bit for bit the run done in one.
Updaters due at a time fire before the observers due then (which see the changed system), in
the order they were added. Random updaters draw from their own generator (numpy's PCG64 from
``seed``), whose state is saved in checkpoints: a restarted run continues bit for bit.

Each firing costs a resync, O(N): fine for intervals of a fraction of a mean free time or more.

Example:
    >>> import edmd
    >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(256, 0.1), 1.0, seed=1), e_n=0.8)
    >>> _ = sim.add(VelocityRescale(kT=1.0, interval=0.5))
    >>> sim.run(until_time=2.0)
    >>> round(sim.state.temperature(), 12), sim.totals().energy_input > 0
    (1.0, True)
"""

from __future__ import annotations

import numpy as np

from .observer import Observer, Totals
from .simulation import Simulation
from ..state import State, rescale_temperature


class Updater(Observer):
    """Changes the system at the times ``start + k * interval``.

    Subclasses implement :meth:`update`, which receives a copy of the state at the firing time
    (streamed there exactly) and the updater's random generator, and returns the changed state
    (the same object changed in place, or a new one): same particles, same time. Under shear
    (:class:`edmd.Shear`) it acts in the frame of the flow: it receives peculiar velocities and
    returns peculiar velocities, to which the linear profile is added back.

    Args:
        interval: spacing of the firing times.
        start: first firing time (default: the simulation's time when attached).
        seed: seed of the random generator (:attr:`rng`, numpy's PCG64).
    """

    priority = -1  # before the observers due at the same time
    changes_state = True

    def __init__(self, interval: float, start: float | None = None, seed: int = 0):
        super().__init__(interval, start)
        if not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
        self.rng = np.random.Generator(np.random.PCG64(int(seed)))

    def attach(self, sim: Simulation):
        if not hasattr(sim.engine, "replace"):
            raise TypeError(f"{type(self).__name__} needs an event-driven Simulation: the DEM cannot continue from a changed state")
        super().attach(sim)

    def fire(self, sim: Simulation, state: State, totals: Totals):
        shear = sim.shear
        if shear is None:
            sim.apply_update(state, self.update(state.copy(), self.rng))
        else:  # in the frame of the flow: the updater sees and sets peculiar velocities
            new = self.update(sim.peculiar_state(state).copy(), self.rng)
            sim.apply_update(state, shear.with_profile(new))
        self._k += 1

    def update(self, state: State, rng: np.random.Generator) -> State:  # pragma: no cover - interface
        raise NotImplementedError

    def checkpoint_data(self) -> dict:
        """The schedule and the generator's state (JSON: PCG64's state is two integers)."""
        return {**super().checkpoint_data(), "rng": self.rng.bit_generator.state}

    def restore_data(self, data: dict):
        super().restore_data(data)
        self.rng.bit_generator.state = data["rng"]


class VelocityRescale(Updater):
    r"""Exact rescaling of the translational temperature to ``kT`` at every firing.

    .. math::
        \mathbf v_i \leftarrow \mathbf u + \lambda(\mathbf v_i - \mathbf u),\qquad
        \lambda = \sqrt{k_BT/T},\qquad \mathbf u = \frac{\sum_i m_i\mathbf v_i}{\sum_i m_i}

    with :math:`T` the translational temperature of :meth:`edmd.State.temperature` (committed
    velocities: pending eMD* increments are scaled with the velocities). Momentum is kept; spins
    are not touched.

    Example:
        >>> VelocityRescale(kT=2.0, interval=0.1).kT
        2.0
    """

    def __init__(self, kT: float, interval: float, start: float | None = None):
        super().__init__(interval, start)
        if not (np.isfinite(kT) and kT > 0):
            raise ValueError(f"kT must be positive, got {kT!r}")
        self.kT = float(kT)

    def update(self, state: State, rng: np.random.Generator) -> State:
        return rescale_temperature(state, self.kT)
