r"""Square-well attraction between hard cores (docs/physics.md §2.5; the compiled side is ``_core/wells.py``).

Each pair :math:`(i, j)` has the potential

.. math::
    u(r) = \infty\ (r < \sigma_{ij}),\qquad -\varepsilon\ (\sigma_{ij} \le r < \lambda\sigma_{ij}),\qquad 0\ (r \ge \lambda\sigma_{ij}),

with :math:`\sigma_{ij} = R_i + R_j`. A pair crossing the edge :math:`\lambda\sigma_{ij}` is an
event: entering, it gains :math:`\varepsilon` of kinetic energy (*capture*); leaving, it pays
:math:`\varepsilon` if its normal kinetic energy :math:`\tfrac12\mu g_n^2` suffices (*release*) and
is reflected back into the well otherwise (*bounce*). The core collisions follow the collision
rule. Whether a pair is captured is part of the state (:attr:`edmd.State.captured_pairs`),
saved in trajectories and checkpoints, so restarts stay bit for bit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import layout as L


@dataclasses.dataclass(frozen=True)
class SquareWell:
    r"""A square well of relative width ``width`` (:math:`\lambda > 1`) and depth ``depth`` (:math:`\varepsilon > 0`).

    The potential energy of a state is :math:`-\varepsilon` times its number of captured pairs
    (:attr:`edmd.Simulation.well_energy`).
    Square-well runs use neighbour lists, whose range is the well's edge :math:`\lambda\sigma_{ij}`.

    Example:
        >>> import edmd
        >>> state = edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), kT=1.0, seed=1)
        >>> sim = edmd.Simulation(state, well=edmd.SquareWell(width=1.5, depth=1.0))
        >>> e0 = sim.state.kinetic_energy() + sim.well_energy
        >>> sim.run(until_time=2.0)
        >>> abs(sim.state.kinetic_energy() + sim.well_energy - e0) < 1e-9 * abs(e0)
        True
    """

    width: float
    depth: float

    def __post_init__(self):
        if not (isinstance(self.width, int | float) and math.isfinite(self.width) and self.width > 1.0):
            raise ValueError(f"SquareWell width (the edge in units of the contact distance) must be a number > 1, got {self.width!r}")
        if not (isinstance(self.depth, int | float) and math.isfinite(self.depth) and self.depth > 0.0):
            raise ValueError(f"SquareWell depth must be a positive number (an energy), got {self.depth!r}")

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write the well into the core's parameter arrays."""
        ip[L.IP_WELL] = 1
        fp[L.FP_WELL_WIDTH] = float(self.width) - 1.0
        fp[L.FP_WELL_DEPTH] = float(self.depth)

    def capacity(self, radius: np.ndarray, dim: int) -> int:
        r"""Most partners one particle can have inside its well: disjoint cores of radius
        :math:`\ge R_{\min}` within :math:`(2\lambda + 1)R_{\max}`, by volume.

        Example:
            >>> SquareWell(1.5, 1.0).capacity(np.array([0.5, 0.5]), 3)
            1
            >>> SquareWell(1.5, 1.0).capacity(np.full(1000, 0.5), 3)
            64
        """
        bound = ((2.0 * self.width + 1.0) * float(radius.max()) / float(radius.min())) ** dim
        return int(max(1, min(len(radius) - 1, math.floor(bound * (1.0 + 1e-12)))))

    def to_dict(self) -> dict:
        """JSON-ready parameters."""
        return {"kind": "square_well", **dataclasses.asdict(self)}
