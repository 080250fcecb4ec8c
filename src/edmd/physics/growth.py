r"""Growing particles: Lubachevsky–Stillinger compression (docs/physics.md §1.7; the compiled side is ``_core/growth.py``).

Every radius grows linearly in time, :math:`R_i(t) = R_i(t_0)\,(1 + g\,(t - t_0))`, so size ratios
are kept and the packing fraction rises as :math:`\eta(t) = \eta_0(1 + g(t - t_0))^d`. Pair times
solve :math:`|\mathbf r_{ij} + \mathbf g_{ij}t| = \sigma_{ij}(t)` exactly, and a collision reverses the
rate at which the *surfaces* approach, so pairs separate after contact. Collisions with growing
partners put energy in; the engine rescales the velocities to ``kT`` at the exact times
:math:`t_0 + k\,\Delta` (``segment``), where it also rebuilds its neighbour lists, so the growth rate
stays the same in reduced units (:math:`\sqrt{kT/m} = 1`) between rescalings.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import layout as L


@dataclasses.dataclass(frozen=True)
class Growth:
    r"""Radii growing at relative rate ``rate`` (:math:`g`) from ``start``, velocities rescaled to ``kT`` every ``segment``.

    Args:
        rate: :math:`g > 0`, per unit time: diameters grow by :math:`g\sigma(t_0)` per unit time.
        kT: the temperature the velocities are rescaled to at every segment end.
        start: :math:`t_0` (default: the time of the state it is used with).
        segment: time between rescalings (default: the time in which the largest contact distance
            grows by a fifth of the neighbour-list skin, chosen at the start; the lists' range grows
            by as much).

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.1, seed=1), kT=1.0, seed=2)
        >>> dense = edmd.compress(s, 0.3, rate=0.05)
        >>> round(dense.packing_fraction, 10), round(dense.temperature(), 1)
        (0.3, 1.0)
    """

    rate: float
    kT: float = 1.0
    start: float | None = None
    segment: float | None = None

    def __post_init__(self):
        for name in ("rate", "kT"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"Growth {name} must be a positive number, got {value!r}")
        if self.start is not None and not (isinstance(self.start, int | float) and math.isfinite(self.start)):
            raise ValueError(f"Growth start must be a finite time, got {self.start!r}")
        if self.segment is not None and not (isinstance(self.segment, int | float) and math.isfinite(self.segment) and self.segment > 0):
            raise ValueError(f"Growth segment must be a positive time, got {self.segment!r}")

    def resolved(self, time: float, sigma_max: float, skin: float) -> Growth:
        """This growth with ``start`` and ``segment`` filled in for a state at ``time`` whose largest
        contact distance is ``sigma_max``, with neighbour-list skin ``skin``."""
        start = float(time) if self.start is None else float(self.start)
        segment = 0.2 * skin / (sigma_max * self.rate) if self.segment is None else float(self.segment)
        return dataclasses.replace(self, start=start, segment=segment)

    def factor(self, time: float) -> float:
        """:math:`1 + g(t - t_0)`: how much the radii of ``start`` have grown by ``time``."""
        return 1.0 + self.rate * (time - self.start)

    def segment_end(self, k: int) -> float:
        """The time of the ``k``-th rescaling, :math:`t_0 + k\\Delta`."""
        return self.start + k * self.segment

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """The absolute parameters (the engine sets the rates relative to each load, ``FP_GROW_LOCAL``)."""
        fp[L.FP_GROW_RATE] = self.rate
        fp[L.FP_GROW_START] = self.start
        fp[L.FP_GROW_SEGMENT] = self.segment

    def to_dict(self) -> dict:
        """JSON-ready parameters."""
        return {"kind": "growth", **dataclasses.asdict(self)}
