r"""Uniform shear flow by Lees-Edwards boundaries (physics.md §5.7; the compiled side is
``_core/images.py``).

Flow along x, gradient along y, shear rate :math:`\dot\gamma`: the periodic images above the box
slide along x at :math:`\dot\gamma L_y` (offset :math:`\delta(t)`, :attr:`edmd.State.shear_offset`)
and carry the extra velocity :math:`\dot\gamma L_y\hat{\mathbf x}`; a particle crossing the y face
takes the image's position and velocity, exactly at the crossing. Velocities are **lab**
velocities; the **peculiar** velocity :math:`\mathbf c = \mathbf v - \dot\gamma y\,\hat{\mathbf x}`
(relative to the linear profile, zero at :math:`y = 0`) defines the temperature, the kinetic
stress and the momentum that the thermo table reports.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

import numpy as np

from ..state import State, StateView


@dataclasses.dataclass(frozen=True)
class Shear:
    r"""Lees-Edwards boundaries with shear rate :math:`\dot\gamma` (flow along x, gradient along y).

    Args:
        rate: :math:`\dot\gamma` (any finite number; the images above move towards +x for a
            positive rate).

    The offset of the images at the start is the State's :attr:`~edmd.State.shear_offset`
    (0 for a new state); it grows as :math:`\delta(t) = \delta(t_0) + \dot\gamma L_y(t - t_0)`
    (mod :math:`L_x`), and snapshots, trajectories and checkpoints carry it, so restarts are exact.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.2, seed=1), kT=1.0)
        >>> shear = edmd.Shear(rate=0.5)
        >>> sim = edmd.Simulation(shear.with_profile(s), shear=shear)
        >>> sim.run(until_time=2.0)
        >>> L = s.box[0]
        >>> bool(abs(sim.state.shear_offset - ((0.5 * L * 2.0 + L / 2) % L - L / 2)) < 1e-9)
        True
    """

    rate: float

    def __post_init__(self):
        if not (isinstance(self.rate, numbers.Real) and not isinstance(self.rate, bool) and math.isfinite(self.rate)):
            raise ValueError(f"Shear rate must be a finite number, got {self.rate!r}")
        object.__setattr__(self, "rate", float(self.rate))

    def profile(self, y) -> np.ndarray:
        r"""The flow velocity along x at height(s) ``y``, :math:`\dot\gamma y`."""
        return self.rate * np.asarray(y, float)

    def peculiar_velocity(self, state: State) -> np.ndarray:
        r"""The velocities of ``state`` relative to the linear profile, :math:`\mathbf v - \dot\gamma y\hat{\mathbf x}`."""
        c = np.array(state.velocity, float)  # (no pending eMD* contacts under shear)
        c[:, 0] -= self.profile(state.position[:, 1])
        return c

    def peculiar_state(self, state: State) -> State:
        """``state`` with its velocities relative to the flow (:meth:`peculiar_velocity`); of a
        :class:`~edmd.state.StateView`, a view (:meth:`~edmd.state.StateView.in_flow`: its velocities
        made when read, its sums relative to the flow)."""
        if isinstance(state, StateView):
            return state.in_flow(self.rate, lambda: self.peculiar_velocity(state))
        return dataclasses.replace(state, velocity=self.peculiar_velocity(state), check_overlaps=False)

    def with_profile(self, state: State) -> State:
        r"""``state`` with the linear profile added to its velocities (:math:`v_x + \dot\gamma y`):
        a start in the flow instead of a start at rest that the boundaries must first set moving."""
        v = np.array(state.velocity, float)
        v[:, 0] += self.profile(state.position[:, 1])
        return dataclasses.replace(state, velocity=v, check_overlaps=False)

    def strain(self, t: float, t0: float = 0.0) -> float:
        r"""The shear strain :math:`\dot\gamma (t - t_0)`."""
        return self.rate * (t - t0)

    def to_dict(self) -> dict:
        """JSON-ready parameters (``kind`` names the driver)."""
        return {"kind": "shear", **dataclasses.asdict(self)}
