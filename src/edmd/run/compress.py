r"""Compression to a packing fraction by growing the particles (Lubachevsky–Stillinger; docs/physics.md §1.7)."""

from __future__ import annotations

import math

from ..physics.growth import Growth
from ..state import State, StateError, rescale_temperature
from .simulation import Simulation


def compression_time(state: State, packing_fraction: float, rate: float) -> float:
    r"""Time in which radii growing at ``rate`` take ``state`` to ``packing_fraction``:
    :math:`\eta(t) = \eta_0(1 + gt)^d`, so :math:`t = ((\eta/\eta_0)^{1/d} - 1)/g`.

    Example:
        >>> import edmd
        >>> round(compression_time(edmd.lattice(108, 0.1), 0.8, rate=0.5), 12)   # 8 = 2^3: the radii double
        2.0
    """
    return ((packing_fraction / state.packing_fraction) ** (1.0 / state.dim) - 1.0) / rate


def compress(state: State, packing_fraction: float, rate: float = 0.02, kT: float = 1.0, engine: dict | None = None) -> State:
    r"""``state`` compressed to ``packing_fraction`` by growing every radius at the same relative rate.

    Event-driven Lubachevsky–Stillinger growth (:class:`edmd.Growth`): elastic hard spheres or disks
    in a periodic box, exact pair times with growing radii, velocities rescaled to ``kT`` at regular
    times; size ratios are kept, so any radius distribution can be compressed. Slow rates (about
    0.01-0.05 per unit time at :math:`kT = 1`, :math:`m = 1`) give equilibrium fluids; fast ones glasses.
    The result is at the time the target is reached, its packing fraction exact to round-off
    (:math:`\sim 10^{-15}`) and its temperature ``kT``.

    Args:
        state: a start without overlaps (e.g. :func:`edmd.random_packing` at a low packing fraction).
        packing_fraction: the target, above the state's.
        rate: :math:`g`: radii grow as :math:`R(t) = R(0)(1 + gt)`.
        kT: the temperature velocities are rescaled to (the start's velocities are rescaled first).
        engine: engine options (:class:`~edmd.run.engine.EngineOptions` as a dict), e.g. ``{"debug": True}``.

    Example:
        >>> import edmd
        >>> start = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), kT=1.0, seed=2)
        >>> dense = compress(start, 0.45, rate=0.05)
        >>> round(dense.packing_fraction, 12), dense.n
        (0.45, 500)
    """
    if not (isinstance(packing_fraction, int | float) and math.isfinite(packing_fraction)) or packing_fraction <= state.packing_fraction:
        raise StateError(f"compress: the target packing fraction {packing_fraction!r} must exceed the state's ({state.packing_fraction:.6g})")
    limit = 0.7405 if state.dim == 3 else 0.9069
    if packing_fraction >= limit:
        raise StateError(f"compress: a packing fraction of {packing_fraction:g} is beyond close packing ({limit} in {state.dim}D)")
    sim = Simulation(rescale_temperature(state.copy(), kT), growth=Growth(rate=rate, kT=kT), engine=engine)
    sim.run(until_time=state.time + compression_time(state, packing_fraction, rate))
    return rescale_temperature(sim.state, kT)
