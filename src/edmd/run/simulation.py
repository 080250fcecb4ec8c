"""The user-facing simulation: a state, its physics, the event engine, and observers."""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
import sys
import time as _time
import warnings

import numpy as np

from ..physics import collide
from ..physics.contact import Hertz
from ..physics.emdstar import EMDStar
from .._core import layout as L
from .engine import Engine, EngineError, EngineOptions, Saved
from .observer import Observer, Totals
from ..state import State, StateView
from ..physics.thermostats import Andersen, WhiteNoise, driver_from_dict
from ..physics.vibration import VibratingWall
from ..physics.shear import Shear
from ..physics.growth import Growth
from ..physics.wells import SquareWell


class Simulation:
    r"""Event-driven molecular dynamics of one system.

    Args:
        state: the initial :class:`~edmd.state.State` (validated: no overlaps, positive radii...).
            Its non-periodic axes are closed by hard walls at :math:`\pm L/2`.
        collision: the collision rule (:mod:`edmd.physics.collide`); elastic smooth spheres by default.
        e_n: shortcut for ``collision=Inelastic(e_n)``.
        walls: restitution of the walls (:class:`edmd.physics.collide.Wall`), elastic and smooth by default.
        gravity: uniform acceleration (``d`` numbers) or ``None``.
        thermostat: a heat bath acting through events (:class:`edmd.Andersen`, or its dict) or ``None``.
        forcing: random kicks of every particle at fixed intervals (:class:`edmd.WhiteNoise`, or its dict) or ``None``.
        vibration: a wall that moves along its normal (:class:`edmd.VibratingWall`, or its dict) or ``None``.
        well: square-well attraction between the cores (:class:`edmd.SquareWell`, or its dict) or ``None``.
        growth: radii growing in time, Lubachevsky–Stillinger compression (:class:`edmd.Growth`, or
            its dict; see :func:`edmd.compress`) or ``None``.
        shear: Lees-Edwards boundaries, uniform shear flow along x with gradient along y
            (:class:`edmd.Shear`, or its dict) or ``None``.
        engine: :class:`~edmd.run.engine.EngineOptions` (or a dict of them).
        _saved: internal: a checkpoint's engine arrays (:func:`edmd.files.checkpoint.load_checkpoint`).

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(256, 0.3), kT=1.0, seed=2))
        >>> sim.run(until_time=2.0)
        >>> sim.time, sim.collisions > 1000
        (2.0, True)
    """

    def __init__(
        self,
        state: State,
        *,
        collision: collide.Rule | None = None,
        e_n: float | None = None,
        walls: collide.Wall | None = None,
        gravity=None,
        thermostat: Andersen | dict | None = None,
        forcing: WhiteNoise | dict | None = None,
        vibration: VibratingWall | dict | None = None,
        well: SquareWell | dict | None = None,
        growth: Growth | dict | None = None,
        shear: Shear | dict | None = None,
        engine: EngineOptions | dict | None = None,
        _saved: Saved | None = None,
    ):
        if e_n is not None:
            if collision is not None:
                raise ValueError("give either collision or the e_n shortcut, not both")
            collision = collide.Inelastic(e_n)
        if isinstance(engine, dict):
            engine = engine_options(engine)
        if isinstance(collision, dict):
            collision = collide.from_dict(collision)
        if isinstance(walls, dict):
            walls = collide.from_dict(walls)
        thermostat = _driver(thermostat, Andersen, "thermostat")
        forcing = _driver(forcing, WhiteNoise, "forcing")
        vibration = _driver(vibration, VibratingWall, "vibration")
        well = _driver(well, SquareWell, "well")
        growth = _driver(growth, Growth, "growth")
        shear = _driver(shear, Shear, "shear")
        if not isinstance(state, State):
            raise TypeError(f"Simulation needs an edmd.State, got {type(state).__name__}")
        state.check()  # (a State's fields may have been changed since it was made)
        self._soft = isinstance(collision, EMDStar)
        if self._hard_cores and not state.has_pending and _saved is None:  # (a checkpoint's state was checked when read)
            state.check_no_overlap()  # (before the engine's arrays exist: the check's grid is a transient)
        if walls is not None and walls != collide.Wall() and np.all(state.periodic):
            warnings.warn("walls= has no effect: the state's box is periodic on every axis (give the State periodic=[...] with False on the walled axes)", UserWarning, stacklevel=2)
        self._engine = self._build_engine(state, collision, walls, gravity, (thermostat, forcing, vibration, well, growth, shear), engine, _saved)
        #: uniform acceleration (``d`` components)
        self.gravity = self._engine.grav[: self._engine.dim].copy()
        self._time = float(state.time)
        self.observers: list[Observer] = []
        self.wall_seconds = 0.0

    def _build_engine(self, state, collision, walls, gravity, drivers, options, saved=None):
        """The engine of these physics, compiled; sets :attr:`params` (subclasses with another
        engine, e.g. :class:`~edmd.run.dem.DEMSimulation`, override this and nothing else of the
        set-up). ``saved``: a checkpoint's engine arrays (:class:`~edmd.run.engine.Saved`)."""
        thermostat, forcing, vibration, well, growth, shear = drivers
        engine = Engine(
            state, options, rule=collision, wall=walls, gravity=gravity, saved=saved, thermostat=thermostat, forcing=forcing, vibration=vibration,
            well=well, growth=growth, shear=shear,
        )  # fmt: skip
        engine.compile()  # once per machine (cached on disk); kept out of wall_seconds
        if saved is None:  # (a restart's run was warned when it started)
            _warn_viscoelastic_validity(state, engine.rule, engine.wall, engine.grav[: state.dim])
        #: the constructor's physics arguments (saved in checkpoints; new arguments belong here)
        self.params = {
            "collision": collide.to_dict(engine.rule),
            "walls": collide.to_dict(engine.wall),
            "gravity": None if gravity is None else [float(g) for g in gravity],
            "thermostat": None if thermostat is None else thermostat.to_dict(),
            "forcing": None if forcing is None else forcing.to_dict(),
            "vibration": None if vibration is None else vibration.to_dict(),
            "well": None if well is None else well.to_dict(),
            "growth": None if engine.growth is None else engine.growth.to_dict(),  # (start and segment resolved)
            "shear": None if shear is None else shear.to_dict(),
            "engine": dataclasses.asdict(engine.options),
        }
        return engine

    # ------------------------------------------------------------------ state
    @property
    def time(self) -> float:
        """Current simulation time."""
        return self._time

    @property
    def state(self) -> State:
        """A copy of the state at the current time (assign a State to replace it)."""
        return self._engine.snapshot(self._time)

    @state.setter
    def state(self, new: State):
        if not isinstance(new, State):
            raise TypeError(f"the state must be an edmd.State, got {type(new).__name__}")
        new.check()
        if self._hard_cores and not new.has_pending:  # partners of pending eMD* contacts overlap by design (as in State)
            new.check_no_overlap()
        self._engine.load(new)
        self._time = float(new.time)

    def state_view(self) -> StateView:
        """The state at the current time as a :class:`~edmd.state.StateView`: each per-particle
        field is made when read (a new array at every read), and none is copied before; readable
        until the simulation goes on. For reading a few fields of a large system without a copy
        of every particle (:attr:`state` makes one).

        Example:
            >>> import edmd
            >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(64, 0.2), 1.0, seed=1))
            >>> sim.run(until_time=1.0)
            >>> bool((sim.state_view().velocity == sim.state.velocity).all())
            True
        """
        return self._engine.view(self._time)

    @property
    def engine(self) -> Engine:
        """The underlying event engine (counters, neighbour mode, collision log)."""
        return self._engine

    @property
    def events(self) -> int:
        """Events processed so far."""
        return int(self._engine.cnt[L.C_EVENTS])

    @property
    def collisions(self) -> int:
        """Binary collisions so far."""
        return int(self._engine.cnt[L.C_COLL])

    def totals(self) -> Totals:
        """Cumulative counters and integrals at the current time."""
        e = self._engine
        acc = e.accumulators_at(self._time)
        return Totals(
            time=self._time,
            events=self.events,
            collisions=self.collisions,
            virial=float(acc[L.A_VIRIAL]),
            kinetic_integral=e.kinetic_integral(self._time),
            dissipated=float(acc[L.A_DISSIPATED]),
            wall_impulse=acc[L.A_WALL : L.A_WALL + 2 * e.dim].reshape(e.dim, 2).copy(),
            wall_collisions=int(e.cnt[L.C_WALL]),
            energy_input=float(acc[L.A_ENERGY_INPUT]),
            stress_integral=acc[L.A_KT_INT : L.A_KT_INT + 6] + acc[L.A_VT : L.A_VT + 6] if e.keeps_stress else None,
            energy_flux_integral=acc[L.A_JE_INT : L.A_JE_INT + 3] + acc[L.A_QV : L.A_QV + 3] if e.keeps_energy_current else None,
            shear_work=float(acc[L.A_SHEAR_WORK]),
        )

    @property
    def shear(self):
        """The Lees-Edwards boundaries (:class:`edmd.Shear`) of this run, or ``None``."""
        return getattr(self._engine, "shear", None)  # (the DEM has none)

    def peculiar_state(self, state: State) -> State:
        r"""``state`` with its velocities relative to the imposed flow: under :class:`edmd.Shear`,
        :math:`\mathbf v - \dot\gamma y\,\hat{\mathbf x}` (what temperatures, kinetic energies and
        momenta of a sheared system mean); ``state`` itself otherwise."""
        shear = self.shear
        if shear is None:
            return state
        return shear.peculiar_state(state)

    @property
    def well_energy(self) -> float:
        """Potential energy of the pair interactions: :math:`-\\varepsilon` per captured square-well
        pair (:class:`edmd.SquareWell`; 0 for hard particles). Gravity's is
        :meth:`edmd.State.potential_energy`."""
        return self._engine.well_energy

    @property
    def elastic_energy(self) -> float:
        """Elastic energy stored in contacts: none for hard particles (eMD* books a soft contact's
        energy through committed velocities); the DEM overrides it."""
        return 0.0

    @property
    def _hard_cores(self) -> bool:
        """Whether particles may not overlap: not with soft contacts (eMD*: residual overlaps of
        ended contacts; the DEM: contacts are overlaps)."""
        return not self.soft_contacts

    @property
    def soft_contacts(self) -> bool:
        """Whether pairs may be in a pending eMD* contact (states then carry pending velocities)."""
        return self._soft

    def emd_counters(self) -> dict[str, int]:
        """The eMD* counters by name (physics.md §4.8; empty without eMD*)."""
        return self._engine.emd_counters() if self.soft_contacts else {}

    @property
    def has_updaters(self) -> bool:
        """Whether an attached observer may change the state (then energy is not conserved alone)."""
        return any(o.changes_state for o in self.observers)

    @property
    def has_energy_input(self) -> bool:
        """Whether something puts energy in (updaters, a thermostat, forcing, a vibrating wall,
        growing particles: ``Totals.energy_input`` counts it; shear: ``Totals.shear_work``)."""
        e = self._engine
        return self.has_updaters or self.shear is not None or any(d is not None for d in (e.thermostat, e.forcing, e.vibration, e.growth))

    def apply_update(self, old: State, new: State):
        """Continue from ``new``, the system at ``old.time`` as an updater changed it.

        The change of mechanical energy (kinetic (peculiar under shear), rotational, gravitational and square wells') is booked as
        ``energy_input``, so that kinetic + rotational + potential + dissipated - input stays
        constant. The neighbour structures and the calendar are rebuilt (as at a resync).
        """
        if new.n != old.n or new.dim != old.dim or new.time != old.time:
            raise ValueError("an updater must return the same system at the same time")
        before = self._mechanical_energy(old)
        self._engine.replace(new)
        after = self._mechanical_energy(new)
        self._engine.acc[L.A_ENERGY_INPUT] += after - before

    def _mechanical_energy(self, state: State) -> float:
        """Kinetic (peculiar under shear), rotational, gravitational and square wells' energy."""
        state = self.peculiar_state(state)
        return state.kinetic_energy() + state.rotational_energy() + state.potential_energy(self.gravity) + self.well_energy

    @classmethod
    def from_checkpoint(cls, path, observers=()) -> Simulation:
        """The simulation saved in checkpoint ``path``, continuing exactly (see :mod:`edmd.files.checkpoint`).

        ``observers`` are attached and restored in order; they must match the checkpoint's.
        """
        from ..files.checkpoint import load_checkpoint

        return load_checkpoint(path, observers)

    # ------------------------------------------------------------------ observers
    def add(self, observer: Observer) -> Observer:
        """Attach an observer; it fires at its exact times during :meth:`run`. Two observers may
        not write the same file (``ValueError``: each would destroy the other's data)."""
        if not isinstance(observer, Observer):
            raise TypeError(f"add() takes an edmd Observer (Thermo, Trajectory, Checkpoint, Callback...), got {type(observer).__name__}")
        path = getattr(observer, "path", None)
        if path is not None:
            mine = os.path.abspath(path)
            clash = next((o for o in self.observers if getattr(o, "path", None) is not None and os.path.abspath(o.path) == mine), None)
            if clash is not None:
                raise ValueError(f"{type(observer).__name__} would write {path}, which the attached {type(clash).__name__} writes: give each observer its own file")
        observer.attach(self)
        self.observers.append(observer)
        return observer

    def _fire_due(self):
        due = sorted((o for o in self.observers if o.next_time <= self._time), key=lambda o: o.priority)
        if due:
            # one copy of the state for the observers that read it, dropped after the last of
            # them (a checkpoint, last, makes its own: two at once would double the peak); a
            # view instead if they all read it only while they fire
            readers = [k for k, o in enumerate(due) if o.needs_state]
            last_reader = max(readers, default=-1)
            take = self.state_view if all(due[k].reads_once for k in readers) else lambda: self.state
            state = take() if last_reader >= 0 else None
            totals = self.totals()
            for k, o in enumerate(due):
                if k > last_reader:
                    state = None
                o.fire(self, state, totals)
                if o.changes_state:  # the observers after it see the changed system
                    state = take() if k < last_reader else None
                    totals = self.totals()

    # ------------------------------------------------------------------ running
    def run(
        self,
        until_time: float | None = None,
        max_events: int | None = None,
        wall_time: float | None = None,
        progress: bool = False,
        until_grown: bool = False,
    ):
        """Advance the system.

        Stops at simulation time ``until_time`` (exactly: particles are streamed to it), after
        ``max_events`` events, or after ``wall_time`` seconds of computing, whichever comes first.
        Observers fire at their exact times on the way (particles streamed to those times).

        Args:
            until_time: absolute simulation time to stop at.
            max_events: event budget of this call.
            wall_time: budget in wall-clock seconds (checked between chunks of events).
            progress: show a progress bar (rich).
            until_grown: also stop when growing particles stop growing (:class:`edmd.Growth` ``end`` or
                ``pressure``; the run is then at the segment end that reached the target).
        """
        if until_grown and not self._engine.growing:
            raise ValueError("run(until_grown=True) needs particles that are growing (Simulation(growth=...))")
        if until_time is None and max_events is None and wall_time is None and not until_grown:
            raise ValueError("run() needs until_time, max_events, wall_time or until_grown")
        if until_time is not None and (not math.isfinite(until_time) or until_time < self._time):
            raise ValueError(f"until_time must be a finite time >= the current time {self._time}, got {until_time}")
        if max_events is not None and (isinstance(max_events, bool) or not float(max_events).is_integer() or max_events < 0):
            raise ValueError(f"max_events must be a whole number >= 0, got {max_events!r}")
        if wall_time is not None and not wall_time >= 0:
            raise ValueError(f"wall_time must be a number of seconds >= 0, got {wall_time!r}")
        target = math.inf if until_time is None else float(until_time)
        budget = math.inf if max_events is None else int(max_events)
        deadline = math.inf if wall_time is None else _time.perf_counter() + wall_time
        bar = _Progress(self._time, target, budget, self.events, wall_time) if progress else None
        started = _time.perf_counter()
        chunk = max(20 * self._engine.n, 100_000)
        try:
            self._fire_due()
            while budget > 0 and _time.perf_counter() < deadline:
                stop = min([target] + [o.next_time for o in self.observers])
                before = self.events
                try:
                    status = self._engine.advance(stop, min(budget, chunk))
                except EngineError:
                    self._time = max(self._time, self._engine.now)  # consistent: inspect sim.state
                    raise
                budget -= self.events - before
                if status in (L.ST_TIME, L.ST_IDLE) and math.isfinite(stop):
                    self._time = stop
                    self._fire_due()
                    if stop >= target:
                        break
                else:
                    self._time = max(self._time, self._engine.now)
                    if status == L.ST_IDLE or (status == L.ST_GROWN and until_grown):
                        break
                if bar:
                    bar.update(self)
        finally:
            self.wall_seconds += _time.perf_counter() - started
            if bar:
                bar.close(self)

    def close(self):
        """Close every observer (flush files)."""
        for o in self.observers:
            o.close()


def _driver(value, kind: type, name: str):
    """A thermostat, forcing, vibration, well, growth or shear argument: ``None``, a ``kind``, or its dict."""
    if isinstance(value, dict):
        value = driver_from_dict(value, kind)
    if value is not None and not isinstance(value, kind):
        raise TypeError(f"{name} must be an edmd.{kind.__name__} (or its dict), got {value!r}")
    return value


def engine_options(options: dict) -> EngineOptions:
    """:class:`EngineOptions` from a dict; an unknown key is a ``ValueError`` that names it.

    Example:
        >>> engine_options({"neighbors": "list"})
        Traceback (most recent call last):
        ...
        ValueError: engine option 'neighbors' does not exist (did you mean 'neighbours'?); the options are neighbours, skin, resync_every, events_per_bucket, auto_threshold, debug, debug_tolerance, cell_size
    """
    known = [f.name for f in dataclasses.fields(EngineOptions)]
    for key in options:
        if key not in known:
            hint = difflib.get_close_matches(str(key), known, n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise ValueError(f"engine option {key!r} does not exist{extra}; the options are {', '.join(known)}")
    return EngineOptions(**options)


def _warn_viscoelastic_validity(state: State, rule, wall, gravity):
    """Warn when impacts may reach delta > 1, outside the viscoelastic model (physics.md §2.2.2)."""
    material = collide.soft_contact(rule, wall)
    if isinstance(material, Hertz) and not isinstance(rule, EMDStar):  # (eMD*: its tables' range decides)
        speed = 2.0 * float(np.max(np.linalg.norm(state.velocity, axis=1)))
        speed += float(np.linalg.norm(gravity)) ** 0.5 * float(np.max(state.box)) ** 0.5 * 2.0
        mu = 0.5 * float(state.mass.min())
        delta = material.beta_v(mu, 0.5 * float(state.radius.min())) * speed**0.2
        if delta > 1.0:
            warnings.warn(
                f"viscoelastic impacts may reach delta = {delta:.3g} > 1 (impact speed up to ~{speed:.3g}), "
                "outside the validity of the viscoelastic model (dissipative force above the elastic one)",
                stacklevel=3,
            )


class _Progress:
    """Progress over simulation time (or events when no end time is set, or wall-clock time when
    only ``wall_time`` ends the run): a rich bar on a terminal; elsewhere (batch logs) a plain
    line every :attr:`STEP` of the run or every :attr:`EVERY` seconds, whichever comes first."""

    STEP = 0.05
    EVERY = 60.0

    def __init__(self, t0, target, budget, events0, wall_time=None, stream=None):
        self.t0, self.target, self.budget = t0, target, budget
        self.stream = sys.stdout if stream is None else stream
        self.total = (target - t0) if math.isfinite(target) else float(budget if math.isfinite(budget) else wall_time or 1)
        self.start = _time.perf_counter()
        self.events0 = events0
        self.bar = None if not self.stream.isatty() else self._rich_bar()
        self._printed = (-1.0, -math.inf, -1)  # fraction, clock and events of the last plain line

    def _rich_bar(self):
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        bar = Progress(
            TextColumn("[bold]edmd"),
            BarColumn(),
            TextColumn("{task.percentage:>5.1f}%"),
            TextColumn("t={task.fields[t]:.4g}  {task.fields[rate]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
        )
        self.task = bar.add_task("run", total=max(self.total, 1e-300), t=self.t0, rate="")
        bar.start()
        return bar

    def _done(self, sim, elapsed: float) -> float:
        if math.isfinite(self.target):
            return sim.time - self.t0
        return sim.events - self.events0 if math.isfinite(self.budget) else elapsed

    def update(self, sim, final: bool = False):
        elapsed = max(_time.perf_counter() - self.start, 1e-9)
        rate = f"{(sim.events - self.events0) / elapsed:.3g} events/s"
        done = self._done(sim, elapsed)
        if self.bar is not None:
            self.bar.update(self.task, completed=done, t=sim.time, rate=rate)
            return
        fraction = min(done / self.total, 1.0) if self.total > 0 else 1.0
        last_fraction, last_clock, last_events = self._printed
        if (final and sim.events != last_events) or fraction >= last_fraction + self.STEP or elapsed >= last_clock + self.EVERY:
            print(f"edmd: {100 * fraction:5.1f}%  t = {sim.time:.6g}  events = {sim.events}  {rate}  {elapsed:.0f} s", file=self.stream, flush=True)
            self._printed = (fraction, elapsed, sim.events)

    def close(self, sim):
        self.update(sim, final=True)
        if self.bar is not None:
            self.bar.stop()
