"""Checkpoints: one GSD file holding everything needed to continue a run bit for bit.

**Why restarts are exact.** The engine is deterministic given its arrays right after a
*resync* (every particle streamed to one instant, clock re-based, particles re-sorted,
neighbour lists and calendar rebuilt: exactly what loading a State does). A checkpoint is
therefore taken *at* a resync: at each checkpoint time ``start + k * interval`` the run
resyncs the engine to that exact time and saves the State together with the engine's
counters and accumulators, the list capacity and every observer's state. Loading it rebuilds
the same arrays, so the continued run and the uninterrupted run are the same sequence of
floating-point operations: identical trajectory and thermo files.

The resyncs at checkpoint times are part of the run: a run with checkpoints every ``Δt`` is
bit-for-bit reproducible with the same ``Δt`` (interrupted or not), and statistically, not
bitwise, identical to a run without checkpoints. A wall-clock interval therefore never decides
*where* the run resyncs, only *whether* a resync point is also written to disk: with
``wall_interval``, the checkpoint at a grid point is written only if that much wall-clock time
has passed since the last write (the first grid point and the final one are always written).

File layout (GSD 5, one frame, double precision): the State as in a trajectory frame
(:func:`edmd.files.trajectory.state_chunks`), plus under ``log/checkpoint/``: ``counters``,
``accumulators``, ``list_capacity``, ``fp``/``ip`` (physics parameters, checked on load), the
JSON document ``meta`` (format version, the names of the entries of ``counters``,
``accumulators``, ``fp`` and ``ip`` (``layout``), the Simulation's constructor parameters,
wall-clock seconds, observers' schedules and scalars, user metadata such as the run's
configuration) and
the observers' arrays ``observer/<k>/<name>``. It is written to a temporary file and renamed,
so a checkpoint on disk is always complete.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time as _time
from pathlib import Path

import gsd.fl
import numpy as np

from .._core import layout as L
from .._core.contact import MODEL_HERTZ
from .atomic import atomic_path
from ..run.observer import Observer, Totals
from ..run.engine import Saved
from ..run.simulation import Simulation
from ..state import State, StateError
from .frames import FrameReader, FrameWriter, copy_frames
from .trajectory import read_frame, state_chunks

FORMAT = 2
#: formats this edmd reads: format 1 stored the engine arrays without names (see :func:`engine_arrays`)
READABLE_FORMATS = (1, 2)
_PREFIX = "checkpoint/"


class CheckpointError(ValueError):
    """A checkpoint that cannot be read or does not fit the simulation it should continue."""


@dataclasses.dataclass
class CheckpointData:
    """The contents of a checkpoint file.

    Attributes:
        state: the State at the checkpoint time.
        meta: the JSON document (``params``, ``observers``, ``metadata``, ``wall_seconds``...).
        arrays: the engine's and observers' arrays by name (``counters``, ``accumulators``...).
        final: the state where the run ended, if it ended after the checkpoint point (``edmd
            run`` always saves its end); a restart continues from ``state`` all the same.
            ``None`` also when not read (``read_checkpoint(..., final=False)``).
        final_events: the event count at the run's end (``None`` if the file has no final state).
        final_time: the time of the run's end (``None`` if the file has no final state).
    """

    state: State
    meta: dict
    arrays: dict[str, np.ndarray]
    final: State | None = None
    final_events: int | None = None
    final_time: float | None = None

    @property
    def time(self) -> float:
        """Simulation time of the checkpoint."""
        return self.state.time

    @property
    def events(self) -> int:
        """Events processed up to the checkpoint."""
        return int(self.arrays["counters"][L.C_EVENTS])

    @property
    def metadata(self) -> dict:
        """User metadata given to :class:`Checkpoint` (the runner stores its configuration here)."""
        return self.meta.get("metadata", {})


def _split(data: dict) -> tuple[dict, dict[str, np.ndarray]]:
    """JSON values and numpy arrays of an observer's checkpoint data."""
    scalars = {k: v for k, v in data.items() if not isinstance(v, np.ndarray)}
    arrays = {k: v for k, v in data.items() if isinstance(v, np.ndarray)}
    return scalars, arrays


def save_checkpoint(sim: Simulation, path: str | os.PathLike, metadata: dict | None = None, resync: bool = True):
    """Write a checkpoint of ``sim`` at its current time (atomically).

    The engine is resynced to ``sim.time`` first (``resync=False`` when it just was), which is
    what makes the saved arrays complete. The resync is part of the trajectory: a run continued
    from this checkpoint equals a run that resyncs at this time (see the module documentation).
    """
    engine = sim.engine
    if resync:
        engine.resync(sim.time)
    for obs in sim.observers:  # (their rows and frames on disk before a checkpoint counts them)
        obs.sync()
    chunks = state_chunks(sim.state_view(), sim.totals())  # (each particle array made as it is written)
    observers = []
    for k, obs in enumerate(sim.observers):
        scalars, arrays = _split(obs.checkpoint_data())
        observers.append({"class": type(obs).__name__, "data": scalars})
        for name, arr in arrays.items():
            chunks[f"log/{_PREFIX}observer/{k}/{name}"] = arr
    meta = {
        "format": FORMAT,
        "layout": {key: list(names) for key, names in L.LAYOUT.items()},
        "params": sim.params,
        "wall_seconds": sim.wall_seconds,
        "observers": observers,
        "metadata": metadata or {},
    }
    chunks[f"log/{_PREFIX}meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)
    chunks[f"log/{_PREFIX}counters"] = engine.cnt.copy()
    chunks[f"log/{_PREFIX}accumulators"] = engine.acc.copy()
    chunks[f"log/{_PREFIX}list_capacity"] = np.array([engine.list_capacity], np.int64)
    chunks[f"log/{_PREFIX}fp"] = engine.fp.copy()
    chunks[f"log/{_PREFIX}ip"] = engine.ip.copy()
    with atomic_path(path) as tmp:
        with FrameWriter(tmp) as f:
            f.append(chunks)


def read_checkpoint(path: str | os.PathLike, final: bool = True) -> CheckpointData:
    """Read a checkpoint file; :class:`CheckpointError` says what is wrong with a bad one.

    ``final=False`` leaves the final state unread (its time and event count are read): a
    restart does not need a second copy of the particles.
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint file at {path}")
    try:
        with FrameReader(path) as f:
            if len(f) not in (1, 2):
                raise CheckpointError(f"{path} holds {len(f)} frames; a checkpoint holds one (and the final state)")
            logged = {name: f.chunk(0, name) for name in f.names(f"log/{_PREFIX}")}
            missing = [k for k in ("meta", "counters", "accumulators", "list_capacity", "fp", "ip") if f"log/{_PREFIX}{k}" not in logged]
            if missing:
                raise CheckpointError(f"{path} is a GSD file but not an edmd checkpoint (missing {', '.join(missing)})")
            meta = _meta(path, logged.pop(f"log/{_PREFIX}meta"))
            soft = meta.get("params", {}).get("collision", {}).get("type") == "EMDStar"  # pairs overlap after contacts
            arrays = {k[len(_PREFIX) + 4 :]: v for k, v in logged.items()}
            state = _checkpoint_state(path, f, 0, soft, "")
            ended = len(f) == 2
            end_state = _checkpoint_state(path, f, 1, soft, " final") if ended and final else None
            end_events, end_time = (f.chunk(1, "log/events"), f.chunk(1, "log/time")) if ended else (None, None)
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        if isinstance(exc, CheckpointError):
            raise
        raise CheckpointError(f"{path} is not a readable checkpoint (corrupt or not a GSD file): {exc}") from None
    return CheckpointData(
        state=state,
        meta=meta,
        arrays=arrays,
        final=end_state,
        final_events=None if end_events is None else int(end_events[0]),
        final_time=None if end_time is None else float(end_time[0]),
    )


def _meta(path, raw: np.ndarray) -> dict:
    """The JSON document of a checkpoint, checked to be of a format this edmd reads."""
    try:
        meta = json.loads(bytes(np.asarray(raw, np.uint8)).decode())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CheckpointError(f"{path}: damaged checkpoint metadata ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") not in READABLE_FORMATS:
        got = meta.get("format") if isinstance(meta, dict) else None
        raise CheckpointError(f"{path} has checkpoint format {got!r}; this edmd reads formats {', '.join(map(str, READABLE_FORMATS))}")
    return meta


def _checkpoint_state(path, reader: FrameReader, frame: int, soft: bool, which: str) -> State:
    """The State of a checkpoint's frame (soft contacts may overlap), its problems named."""
    try:
        return read_frame(reader, frame, check_overlaps=not soft)
    except StateError as exc:
        raise CheckpointError(f"{path}: the saved{which} state is invalid: {exc}") from None


def save_final_state(path: str | os.PathLike, state: State, totals: Totals):
    """Add ``state``, where a run ended off its checkpoint points, to checkpoint ``path`` as its
    second frame (atomically). A restart still continues from the checkpoint point (frame 0) and
    recomputes the rest exactly; the final state is :attr:`CheckpointData.final`.
    """
    with gsd.fl.open(str(path), "r") as f:
        point_pending = f.chunk_exists(0, "log/particles/pending_partner")
    # GSD reads a chunk missing from frame 1 from frame 0: write the pending eMD* fields
    # whenever the point has them, or the final state would inherit the point's contacts
    with atomic_path(path) as tmp:
        with FrameWriter(tmp) as out:
            copy_frames(path, out, 1)
            out.append(state_chunks(state, totals, pending=True if point_pending else None))


def load_checkpoint(path: str | os.PathLike, observers=(), data: CheckpointData | None = None, take_state: bool = False) -> Simulation:
    """A :class:`Simulation` continuing exactly from checkpoint ``path``.

    ``observers`` (new, unattached instances configured like the original ones: same classes,
    intervals and files, in the same order) are attached and restored: a Thermo's CSV is cut
    back to the rows it had at the checkpoint and the Thermo gets its rows back from it (one
    without a file, from the checkpoint), a Trajectory file is cut back to the frames it had at
    the checkpoint, a Checkpoint continues its schedule. ``data``: the file's contents if
    already read (:func:`read_checkpoint`). ``take_state``: hand ``data.state`` over to the
    Simulation (its positions, velocities and images are dropped as the engine takes them, so
    a restart holds one copy of the particles); always so for a file read here.

    Example:
        >>> import edmd, tempfile, os
        >>> d = tempfile.mkdtemp()
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), 1.0, seed=3))
        >>> _ = sim.add(Checkpoint(os.path.join(d, "c.gsd"), interval=1.0))
        >>> sim.run(until_time=2.0)
        >>> again = load_checkpoint(os.path.join(d, "c.gsd"), [Checkpoint(os.path.join(d, "c.gsd"), 1.0)])
        >>> again.time, again.collisions == sim.collisions
        (2.0, True)
    """
    take_state = take_state or data is None
    data = read_checkpoint(path, final=False) if data is None else data
    a = engine_arrays(data, path)
    saved = Saved(a["counters"], a["accumulators"], int(data.arrays["list_capacity"][0]), take_state)
    try:
        sim = Simulation(data.state, **data.meta["params"], _saved=saved)
    except (TypeError, ValueError) as exc:
        raise CheckpointError(f"{path}: cannot rebuild the simulation from the saved parameters: {exc}") from None
    for name, names in (("fp", L.FPARAMS), ("ip", L.IPARAMS)):
        differ = [n for n, new, old in zip(names, getattr(sim.engine, name), a[name]) if not new == old and n not in L.OUTPUT_PARAMS]
        if differ:
            raise CheckpointError(f"{path}: the rebuilt engine's physics parameters differ from the saved ones ({', '.join(differ)})")
    sim.wall_seconds = float(data.meta.get("wall_seconds", 0.0))
    _restore_observers(sim, path, data, list(observers))
    return sim


def engine_arrays(data: CheckpointData, path="checkpoint") -> dict[str, np.ndarray]:
    """The engine arrays of a checkpoint (``counters``, ``accumulators``, ``fp``, ``ip``) in this
    edmd's layout, matched by name (:data:`edmd._core.layout.LAYOUT`).

    An entry this edmd has but the file lacks (a parameter or counter added since) loads as 0,
    its "off" value; an entry of a newer edmd that this one does not know is an error unless it
    is 0. Format-1 files stored no names: theirs are :data:`~edmd._core.layout.FORMAT1_LAYOUT`.

    Example:
        >>> import edmd, tempfile, os
        >>> path = os.path.join(tempfile.mkdtemp(), "c.gsd")
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), 1.0, seed=3))
        >>> _ = sim.add(Checkpoint(path, interval=1.0))
        >>> sim.run(until_time=1.0)
        >>> int(engine_arrays(read_checkpoint(path))["counters"][L.C_COLL]) == sim.collisions
        True
    """
    saved_layout = L.FORMAT1_LAYOUT if data.meta.get("format") == 1 else data.meta.get("layout")
    if not isinstance(saved_layout, dict) or any(not isinstance(saved_layout.get(k), list | tuple) for k in L.LAYOUT):
        raise CheckpointError(f"{path}: damaged checkpoint metadata (no names of the engine arrays)")
    out = {}
    for key, names in L.LAYOUT.items():
        values, saved = np.asarray(data.arrays[key]), saved_layout[key]
        if values.ndim != 1 or len(values) < len(saved):
            raise CheckpointError(f"{path}: damaged checkpoint: {key} has {values.size} entries for {len(saved)} names")
        here = {name: k for k, name in enumerate(names)}
        out[key] = np.zeros(len(names), values.dtype)
        for name, value in zip(saved, values):
            if name in here:
                out[key][here[name]] = value
            elif value != 0:
                raise CheckpointError(f"{path} was written by a newer edmd: {key} entry {name!r} = {value} is unknown to this one")
    _migrate_viscoelastic(out["fp"], out["ip"])
    return out


def _migrate_viscoelastic(fp: np.ndarray, ip: np.ndarray):
    """The retired ``NORMAL_VISCO`` law of older checkpoints as the Hertz law it is: ``NORMAL_SOFT``
    with ``soft_a = K`` and ``soft_b = 3A/2`` (the values :meth:`edmd.physics.contact.Hertz.constants`
    packs, bit for bit)."""
    slots = [k for k in (L.IP_NORMAL, L.IP_WALL_NORMAL) if ip[k] == L.NORMAL_VISCO]
    if not slots:
        return
    for k in slots:
        ip[k] = L.NORMAL_SOFT
    ip[L.IP_EMD_MODEL] = MODEL_HERTZ
    fp[L.FP_SOFT_A], fp[L.FP_SOFT_B] = fp[L.FP_VISCO_K], 1.5 * fp[L.FP_VISCO_A]
    fp[L.FP_VISCO_K] = fp[L.FP_VISCO_A] = 0.0


def _restore_observers(sim: Simulation, path, data: CheckpointData, observers: list[Observer]):
    saved = data.meta["observers"]
    got = [type(o).__name__ for o in observers]
    want = [s["class"] for s in saved]
    if got != want:
        raise CheckpointError(f"{path} was saved with observers {want}; got {got}")
    for k, (obs, rec) in enumerate(zip(observers, saved)):
        prefix = f"observer/{k}/"
        arrays = {name[len(prefix) :]: arr for name, arr in data.arrays.items() if name.startswith(prefix)}
        sim.add(obs)
        try:
            obs.restore_data({**rec["data"], **arrays})
        except (KeyError, ValueError) as exc:
            raise CheckpointError(f"{path}: observer {k} ({want[k]}) cannot be restored: {exc}") from None


class Checkpoint(Observer):
    """Resync the engine and save a checkpoint at ``start + k * interval`` (simulation time).

    Args:
        path: the checkpoint file (replaced atomically at every write).
        interval: simulation time between checkpoint points; every point resyncs the engine
            (cheap, like a maintenance resync) so that the run can be continued exactly there.
        wall_interval: if given, a point is written to disk only when this many wall-clock
            seconds have passed since the last write (the first point always, and the last
            one when the run ends on it: see :meth:`close`). Wall-clock time decides only what
            is written, never the trajectory.
        start: first checkpoint time (default: the simulation's time when attached).
        metadata: JSON-serialisable data stored with every checkpoint (the runner stores the
            run's configuration).

    Example:
        >>> import edmd, tempfile, os
        >>> p = os.path.join(tempfile.mkdtemp(), "checkpoint.gsd")
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), 1.0))
        >>> ck = sim.add(Checkpoint(p, interval=0.5))
        >>> sim.run(until_time=1.0)
        >>> ck.writes, read_checkpoint(p).time
        (3, 1.0)
    """

    priority = 1  # after every other observer due at the same time
    needs_state = False  # (it resyncs and takes its own)

    def __init__(
        self,
        path: str | os.PathLike,
        interval: float,
        wall_interval: float | None = None,
        start: float | None = None,
        metadata: dict | None = None,
    ):
        super().__init__(interval, start)
        if wall_interval is not None and not (wall_interval > 0 and math.isfinite(wall_interval)):
            raise ValueError(f"wall_interval must be a positive number of seconds, got {wall_interval}")
        self.path = Path(path)
        self.wall_interval = wall_interval
        self.metadata = metadata or {}
        self.writes = 0
        #: simulation time of the last checkpoint this observer wrote (``None`` before the first)
        self.last_written: float | None = None
        self._sim: Simulation | None = None
        self._last_write = -math.inf
        self._pending: tuple[float, int] | None = None

    def attach(self, sim: Simulation):
        super().attach(sim)
        self._sim = sim

    def observe(self, sim: Simulation, state: State, totals: Totals):
        sim.engine.resync(sim.time)
        due = self.wall_interval is None or _time.monotonic() - self._last_write >= self.wall_interval
        if due:
            self.write()
        else:
            self._pending = (sim.time, sim.events)

    def write(self):
        """Save the attached simulation, which sits at the checkpoint point just resynced."""
        save_checkpoint(self._sim, self.path, self.metadata, resync=False)
        self.writes += 1
        self.last_written = self._sim.time
        self._last_write = _time.monotonic()
        self._pending = None

    def close(self):
        """Write the last checkpoint point if it was skipped (wall-clock mode) and the run still sits on it."""
        sim = self._sim
        if self._pending is not None and sim is not None and self._pending == (sim.time, sim.events):
            self.write()
        self._pending = None
