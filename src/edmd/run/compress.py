r"""Compression by growing the particles (Lubachevsky–Stillinger; docs/physics.md §1.7): to a packing
fraction, to a reduced pressure, or to jamming."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np

from ..analysis.packing import ContactNetwork
from ..physics.growth import Growth
from ..state import State, StateError, rescale_temperature
from .simulation import Simulation

#: the reduced pressure at which :func:`compression` calls a packing jammed (Skoge et al. 2006); every
#: compression stops there, whatever its target
JAMMED = 1e12
#: the highest pressure target: the gaps (~ sigma / Z) reach the round-off of the positions near 1e14
MAX_PRESSURE = 1e13
#: close packing: the densest packing fraction (fcc/hcp in 3D, hexagonal in 2D)
CLOSE_PACKING = {3: math.pi / math.sqrt(18.0), 2: math.pi / math.sqrt(12.0)}


@dataclasses.dataclass
class Compression:
    """The result of :func:`compression`.

    Attributes:
        state: the compressed state, at the time the target was reached, velocities at ``kT``.
        history: one row per segment of the growth (between two rescalings of the velocities): its
            end ``time``, ``packing_fraction``, the reduced ``pressure`` :math:`Z = PV/(NkT)` measured
            over it (from the collisions' virial and the time-averaged kinetic energy), and the
            ``collisions`` so far (a structured array with those fields).
        reached: ``"packing_fraction"`` or ``"pressure"``: the target that stopped the growth.

    Example:
        >>> import edmd
        >>> start = edmd.maxwell_boltzmann(edmd.random_packing(100, 0.1, seed=1), kT=1.0, seed=2)
        >>> run = edmd.compression(start, 0.3, rate=0.05)
        >>> run.reached, round(run.packing_fraction, 12), run.history.dtype.names
        ('packing_fraction', 0.3, ('time', 'packing_fraction', 'pressure', 'collisions'))
    """

    state: State
    history: np.ndarray
    reached: str

    @property
    def packing_fraction(self) -> float:
        """The final packing fraction (:math:`\\varphi_J` of a jammed packing)."""
        return self.state.packing_fraction

    @property
    def pressure(self) -> float:
        """The reduced pressure at the end: of the last segment, merged with the one before when a
        packing-fraction target cut it to fewer than half of that one's collisions (weighted by
        collisions); NaN without segments."""
        h = self.history
        if len(h) == 0:
            return math.nan
        done = np.diff(h["collisions"], prepend=0)
        if len(h) > 1 and done[-1] < 0.5 * done[-2]:
            return float(np.average(h["pressure"][-2:], weights=done[-2:]))
        return float(h["pressure"][-1])

    def contacts(self, gap: float = 1e-9) -> ContactNetwork:
        """The contact network of the final state (:class:`edmd.analysis.ContactNetwork`)."""
        return ContactNetwork(gap).compute(self.state)

    def plot(self, ax=None):
        r"""The reduced pressure against the packing fraction during the compression (log scale)."""
        from ..analysis._common import axes

        ax = axes(ax)
        h = self.history
        ax.semilogy(h["packing_fraction"], h["pressure"], ".-", ms=2, lw=0.8)
        ax.set_xlabel(r"packing fraction $\varphi$")
        ax.set_ylabel(r"reduced pressure $Z = PV/NkT$")
        ax.set_title(f"compression: final phi = {self.packing_fraction:.6f}")
        return ax


HISTORY = np.dtype([("time", float), ("packing_fraction", float), ("pressure", float), ("collisions", np.int64)])


def compression_time(state: State, packing_fraction: float, rate: float) -> float:
    r"""Time in which radii growing at ``rate`` take ``state`` to ``packing_fraction``:
    :math:`\eta(t) = \eta_0(1 + gt)^d`, so :math:`t = ((\eta/\eta_0)^{1/d} - 1)/g`.

    Example:
        >>> import edmd
        >>> round(compression_time(edmd.lattice(108, 0.1), 0.8, rate=0.5), 12)   # 8 = 2^3: the radii double
        2.0
    """
    return ((packing_fraction / state.packing_fraction) ** (1.0 / state.dim) - 1.0) / rate


def _check_targets(state: State, packing_fraction, pressure):
    if packing_fraction is None and pressure is None:
        raise StateError("compress: give a target packing_fraction, a target pressure, or both")
    if packing_fraction is not None:
        if not (isinstance(packing_fraction, int | float) and math.isfinite(packing_fraction)) or packing_fraction <= state.packing_fraction:
            raise StateError(f"compress: the target packing fraction {packing_fraction!r} must exceed the state's ({state.packing_fraction:.6g})")
        limit = CLOSE_PACKING[state.dim] if np.all(state.radius == state.radius[0]) else 1.0  # (mixtures pack denser)
        if packing_fraction >= limit:
            raise StateError(f"compress: a packing fraction of {packing_fraction:g} is beyond close packing ({limit:.4f} in {state.dim}D)")
    if pressure is not None and not (isinstance(pressure, int | float) and 1.0 < pressure <= MAX_PRESSURE):
        raise StateError(
            f"compress: the target reduced pressure must be a number above 1 (the ideal gas) and at most {MAX_PRESSURE:g} "
            f"(the gaps then reach the round-off of the positions), got {pressure!r}"
        )


#: the default slow-down of :func:`compression`: ``(pressure, factor)``: from reduced pressure 100 the
#: rate is a quarter of the start's, ..., from 1e5 an eightieth (mixed-rate protocol; docs/physics.md §1.7)
SLOWDOWN = ((1e2, 0.25), (1e3, 0.1), (1e4, 0.05), (1e5, 0.0125))


def compression(
    state: State,
    packing_fraction: float | None = None,
    pressure: float | None = None,
    rate: float = 0.02,
    kT: float = 1.0,
    slowdown: Sequence[tuple[float, float]] = SLOWDOWN,
    engine: dict | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> Compression:
    r"""Compress ``state`` by growing every radius at the same relative rate, until its packing
    fraction reaches ``packing_fraction`` or its reduced pressure reaches ``pressure``, whichever
    comes first; ``pressure=1e12`` (:data:`JAMMED`) compresses to jamming.

    Event-driven Lubachevsky–Stillinger growth (:class:`edmd.Growth`): elastic hard spheres or disks
    in a periodic box or between walls, exact pair and wall times with growing radii, velocities rescaled to ``kT`` at the end
    of every segment; size ratios are kept, so any radius distribution can be compressed. Slow rates
    (about 0.01-0.05 per unit time at :math:`kT = 1`, :math:`m = 1`) give equilibrium fluids; fast
    ones glasses. Near jamming the growth must slow down for the packing to find mechanical
    equilibrium (at a fixed rate the contact network freezes hypostatic): ``slowdown`` lists
    ``(pressure, factor)`` stages, from which on the rate is ``factor * rate`` (as the mixed-rate
    protocol of Skoge et al., PRE 74, 041127, 2006). A packing-fraction target is met exactly (to
    round-off); a pressure target at the end of the first segment whose pressure reaches it.

    Args:
        state: a start without overlaps (e.g. :func:`edmd.random_packing` at a low packing fraction).
        packing_fraction: the target packing fraction, above the state's and below close packing.
        pressure: the target reduced pressure :math:`Z = PV/(NkT)` (``1e12``: jammed).
        rate: :math:`g`: radii grow as :math:`R(t) = R(0)(1 + gt)` (until the first slow-down).
        kT: the temperature velocities are rescaled to (the start's velocities are rescaled first).
        slowdown: ``(pressure, factor)`` stages of the rate, pressures increasing (``()``: none).
        engine: engine options (:class:`~edmd.run.engine.EngineOptions` as a dict), e.g. ``{"debug": True}``.
        progress: called as ``progress(packing_fraction, pressure)`` after every few segments.

    Example:
        >>> import edmd
        >>> start = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, seed=1), kT=1.0, seed=2)
        >>> jammed = compression(start, pressure=1e12, rate=0.05)
        >>> net = jammed.contacts()
        >>> 0.62 < jammed.packing_fraction < 0.66, jammed.reached, round(net.mean_contact_number)   # isostatic: 2d
        (True, 'pressure', 6)
    """
    _check_targets(state, packing_fraction, pressure)
    stages = _stages(rate, JAMMED if pressure is None else pressure, slowdown)  # (a packing fraction beyond jamming stops there)
    current, rows = rescale_temperature(state.copy(), kT), []
    for stage_rate, stage_pressure in stages:
        current, segments = _grow(current, Growth(rate=stage_rate, kT=kT, packing_fraction=packing_fraction, pressure=stage_pressure), engine, progress)
        done = rows[-1][3] if rows else 0  # (each stage counts its collisions from 0)
        rows += [(t, phi, z, done + c) for t, phi, z, c in segments]
        if packing_fraction is not None and current.packing_fraction >= packing_fraction * (1.0 - 1e-12):
            return Compression(rescale_temperature(current, kT), np.array(rows, dtype=HISTORY), "packing_fraction")
    if pressure is None:
        raise StateError(
            f"compress: jammed (reduced pressure {rows[-1][2]:.3g}) at packing fraction {current.packing_fraction:.6g}, before "
            f"the target {packing_fraction:g}: a slower compression may pack denser (or crystallise), or choose a lower target"
        )
    return Compression(rescale_temperature(current, kT), np.array(rows, dtype=HISTORY), "pressure")


def _stages(rate: float, pressure: float, slowdown) -> list[tuple[float, float]]:
    """``(rate, stop pressure)`` of each stage of :func:`compression`."""
    bounds = [float(p) for p, _ in slowdown]
    if any(b <= a for a, b in zip(bounds, bounds[1:], strict=False)) or any(not (math.isfinite(f) and f > 0) for _, f in slowdown):
        raise StateError(f"compress: slowdown must be (pressure, factor) stages with increasing pressures and positive factors, got {slowdown!r}")
    rates = [rate] + [rate * f for p, f in slowdown if p < pressure]
    stops = bounds[: len(rates) - 1] + [pressure]
    return list(zip(rates, stops, strict=True))


def _grow(state: State, growth: Growth, engine, progress) -> tuple[State, list]:
    """``state`` grown until ``growth`` stops; the segments on the way."""
    sim = Simulation(state, growth=growth, engine=engine)
    chunk = max(20 * state.n, 100_000)
    while sim.engine.growing:
        sim.run(max_events=chunk, until_grown=True)
        if progress is not None and sim.engine.segments:
            progress(*sim.engine.segments[-1][1:3])
    return sim.state, sim.engine.segments


def compress(state: State, packing_fraction: float | None = None, pressure: float | None = None, **options) -> State:
    r"""``state`` compressed to ``packing_fraction`` (or to the reduced ``pressure``): the state of
    :func:`compression` (see there), its packing fraction exact to round-off (:math:`\sim 10^{-15}`)
    and its temperature ``kT``. ``options``: those of :func:`compression` (``rate``, ``kT``,
    ``slowdown``, ``engine``, ``progress``).

    Example:
        >>> import edmd
        >>> start = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), kT=1.0, seed=2)
        >>> dense = compress(start, 0.45, rate=0.05)
        >>> round(dense.packing_fraction, 12), dense.n
        (0.45, 500)
    """
    return compression(state, packing_fraction, pressure, **options).state


def at_radii(grown: State, radius: np.ndarray) -> State:
    """``grown`` scaled back to particles of radii ``radius`` (every radius grew by the same factor):
    the same packing fraction, positions and box shrunk by that factor, time 0.

    Example:
        >>> import edmd
        >>> s = edmd.lattice(27, 0.3)
        >>> big = edmd.State(position=2 * s.position, velocity=s.velocity, radius=2 * s.radius, mass=s.mass, box=2 * s.box)
        >>> back = at_radii(big, s.radius)
        >>> bool(np.allclose(back.position, s.position)), round(back.packing_fraction, 12)
        (True, 0.3)
    """
    shrink = float(np.mean(np.asarray(radius) / grown.radius))
    return State(
        position=grown.position * shrink, velocity=grown.velocity, radius=np.array(radius, float), mass=grown.mass, box=grown.box * shrink,
        image=grown.image, periodic=grown.periodic,
    )  # fmt: skip


def compress_film(
    state: State, separation: float, axis: str = "z", speed: float = 0.01, kT: float | None = None, bath_rate: float = 1.0, engine: dict | None = None
) -> State:
    r"""The film between the walls of ``axis`` squeezed to ``separation`` by its upper wall, moving
    into the box at constant ``speed`` (the other axes stay fixed): the state when the wall gets
    there, in a box whose length along ``axis`` is ``separation``.

    The wall is an exactly moving wall (:class:`edmd.VibratingWall`, a sawtooth ramp
    :math:`d(t) = vt`; docs/physics.md §1.6): collisions act in its frame and its work is energy
    input. The particles keep their size, collide by the state's default (elastic) rule, and heat
    up as the wall works on them unless ``kT`` holds them there by an Andersen bath of rate
    ``bath_rate``. Slow walls (``speed`` well below the thermal speed) compress quasi-statically.

    Args:
        state: particles between walls on ``axis`` (``periodic`` False there), no overlaps.
        separation: the final distance between the walls, above the largest diameter, below the box length.
        axis: ``"x"``, ``"y"`` or ``"z"`` (2D: ``"x"`` or ``"y"``).
        speed: the wall's speed :math:`v` (> 0).
        kT: hold this temperature (Andersen bath), or ``None``: no bath.
        bath_rate: the bath's rate per particle.
        engine: engine options as a dict, e.g. ``{"debug": True}``.

    Example:
        >>> import edmd
        >>> s = edmd.random_packing(200, 0.2, dim=2, seed=1, periodic=[True, False])
        >>> film = compress_film(edmd.maxwell_boltzmann(s, 1.0, seed=2), separation=0.5 * s.box[1], axis="y", speed=0.05, kT=1.0)
        >>> round(film.packing_fraction, 12), bool(film.box[1] == 0.5 * s.box[1])
        (0.4, True)
    """
    from ..physics.thermostats import Andersen
    from ..physics.vibration import VibratingWall

    k = "xyz".index(axis) if axis in ("x", "y", "z") else -1
    if not 0 <= k < state.dim or state.periodic[k]:
        raise StateError(f"compress_film: the axis {axis!r} must be one of the state's axes closed by walls (periodic False)")
    length = float(state.box[k])
    if not (isinstance(separation, int | float) and 2.0 * float(state.radius.max()) < separation < length):
        raise StateError(f"compress_film: the separation {separation!r} must lie between the largest diameter {2 * float(state.radius.max()):g} and the box length {length:g}")
    if not (isinstance(speed, int | float) and math.isfinite(speed) and speed > 0):
        raise StateError(f"compress_film: the wall speed must be a positive number, got {speed!r}")
    travel = length - separation
    amplitude = 0.5 * travel * (1.0 + 1e-6)  # (the ramp ends after the wall arrives, not at it)
    omega = math.pi * speed / amplitude  # a sawtooth rises by 2a in 2 pi / omega
    wall = VibratingWall(amplitude=amplitude, omega=omega, phase=-math.pi - omega * state.time, axis=axis, side="upper", wave="sawtooth")
    bath = None if kT is None else Andersen(kT=kT, rate=bath_rate)
    sim = Simulation(state, vibration=wall, thermostat=bath, engine=engine)
    sim.run(until_time=state.time + travel / speed)
    film = sim.state
    shift = np.zeros(state.dim)
    shift[k] = 0.5 * travel
    box = film.box.copy()
    box[k] = separation
    return dataclasses.replace(film, position=film.position + shift, box=box)
