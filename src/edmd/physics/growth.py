r"""Growing particles: Lubachevsky–Stillinger compression (docs/physics.md §1.7; the compiled side is ``_core/growth.py``).

Every radius grows linearly in time, :math:`R_i(t) = R_i(t_0)\,(1 + g\,(t - t_0))`, so size ratios
are kept and the packing fraction rises as :math:`\eta(t) = \eta_0(1 + g(t - t_0))^d`. Pair times
solve :math:`|\mathbf r_{ij} + \mathbf g_{ij}t| = \sigma_{ij}(t)` exactly, and a collision reverses the
rate at which the *surfaces* approach, so pairs separate after contact. Collisions with growing
partners put energy in; the engine rescales the velocities to ``kT`` at the end of every
*segment*: at the exact times :math:`t_0 + k\,\Delta` (``segment``), where it also rebuilds its
neighbour lists, and after every ``events`` events per particle in between. Each collision heats
the pair by a fixed fraction of order :math:`g\sigma/\bar v`, whatever the density, so the count
bounds the heating of a segment even as the collision rate diverges near jamming; the growth
rate stays the same in reduced units (:math:`\sqrt{kT/m} = 1`) to within that bound.

The growth stops (the run continues at fixed radii) at the time ``end``, or at the first segment
end whose reduced pressure reaches ``pressure``.
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
        segment: the longest time between rescalings (default: the time in which the largest
            contact distance grows by a fifth of the neighbour-list skin, chosen at the start; the
            lists' range grows by as much).
        events: events per particle after which a segment ends early (default:
            :math:`0.05\,\bar v/(g\sigma_{\max})` with :math:`\bar v = \sqrt{kT/m}`, at least 1,
            which keeps the heating of a segment to about 5 %, see :meth:`resolved`).
        end: the time at which the radii stop growing (default: never).
        packing_fraction: stop growing when the packing fraction reaches this (sets ``end``; an
            ``end`` given, as in a resolved growth saved in a checkpoint, takes precedence).
        pressure: stop growing at the first segment end whose reduced pressure
            :math:`Z = PV/(NkT)` reaches this (e.g. ``1e12``: jammed).

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
    events: float | None = None
    end: float | None = None
    packing_fraction: float | None = None
    pressure: float | None = None

    def __post_init__(self):
        for name in ("rate", "kT"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"Growth {name} must be a positive number, got {value!r}")
        for name in ("start", "end"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, int | float) and math.isfinite(value)):
                raise ValueError(f"Growth {name} must be a finite time, got {value!r}")
        for name in ("segment", "events", "packing_fraction", "pressure"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"Growth {name} must be a positive number, got {value!r}")
        if self.packing_fraction is not None and self.packing_fraction >= 1.0:
            raise ValueError(f"Growth packing_fraction must be below 1, got {self.packing_fraction!r}")

    def resolved(self, time: float, packing_fraction: float, dim: int, sigma_max: float, speed: float, skin: float) -> Growth:
        r"""This growth with ``start``, ``segment``, ``events`` and ``end`` filled in for a state at
        ``time`` and ``packing_fraction`` in ``dim`` dimensions, whose largest contact distance is
        ``sigma_max`` and whose thermal speed at ``kT`` is ``speed``, with neighbour-list skin ``skin``.

        A collision puts :math:`2\mu\dot\sigma|u|` into its pair, :math:`4\dot\sigma/|u| \sim 4g\sigma/\bar v` of the energy of its relative motion
        (docs/physics.md §1.7), so :math:`0.05\,\bar v/(g\sigma)` events per particle keep a
        segment's heating to about 5 % (measured: 4-5 % at every pressure from 10 to :math:`10^{12}`).
        """
        start = float(time) if self.start is None else float(self.start)
        if start > time:
            raise ValueError(f"Growth start {start!r} is after the state's time {time!r}: the radii grow from a time the run has reached")
        segment = 0.2 * skin / (sigma_max * self.rate) if self.segment is None else float(self.segment)
        events = max(1.0, 0.05 * speed / (self.rate * sigma_max)) if self.events is None else float(self.events)
        end = self.end
        if end is None and self.packing_fraction is not None:
            if self.packing_fraction <= packing_fraction:
                raise ValueError(f"Growth packing_fraction {self.packing_fraction!r} must exceed the state's ({packing_fraction:.6g})")
            grown = (self.packing_fraction / packing_fraction) ** (1.0 / dim) * (1.0 + self.rate * (time - start))
            end = start + (grown - 1.0) / self.rate
        return dataclasses.replace(self, start=start, segment=segment, events=events, end=end)

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
