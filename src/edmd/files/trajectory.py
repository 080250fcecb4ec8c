"""Trajectories in GSD 5, double precision (readable by HOOMD-blue, OVITO, freud, MDAnalysis).

Standard chunks: positions, velocities, diameters, masses, moments of inertia, images, box,
dimensions, step, orientations (identity quaternions: spheres have no orientation) and angular
momenta in HOOMD's convention (``particles/angmom``, see :func:`angmom`). Under ``log/``: the
continuous ``time``, the ``events`` and ``collisions`` counters, the exact double-precision box
(``log/configuration/box``), the periodic flags, the Lees-Edwards image offset
(``log/configuration/shear_offset``; the box itself is written without tilt, since positions stay in the
rectangular box), the radii and ``log/particles/angular_velocity``.

``configuration/step`` is the cumulative event count (``log/events``): it grows with time, at no
fixed rate. A frame's time is ``log/time``; trajectories space frames evenly, ``start + k *
interval``. ``configuration/box`` is the box rounded to single precision (gsd.hoomd casts the
box to float32 even in double-precision files): the exact box is ``log/configuration/box``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import gsd.fl
import gsd.hoomd
import numpy as np

from .atomic import atomic_path, fsync_existing
from .frames import FrameReader, FrameWriter, copy_frames
from ..run.observer import Observer, Totals
from ..run.simulation import Simulation
from ..state import State, StateError, _is_filled, one_if_equal


def angmom(state: State) -> np.ndarray:
    r"""Angular momenta as HOOMD-blue quaternions, ``(N, 4)``.

    HOOMD stores the angular momentum as the quaternion conjugate to the orientation ``q``,
    :math:`\mathbf P = 2\,\mathbf q \otimes (0, \mathbf S)` with :math:`\mathbf S` the angular
    momentum in the particle's principal frame. Spheres and disks keep the identity orientation
    ``q = (1, 0, 0, 0)``, so :math:`\mathbf P = (0, 2 I \boldsymbol\omega)`; a disk spins about
    ``z`` only: :math:`\mathbf P = (0, 0, 0, 2 I \omega_z)`.

    Example:
        >>> s = State(position=[[0.0, 0.0]], velocity=[[0.0, 0.0]], radius=0.5, mass=1.0, box=[4.0, 4.0],
        ...           angular_velocity=[3.0])
        >>> angmom(s).tolist()
        [[0.0, 0.0, 0.0, 0.75]]
    """
    p = np.zeros((state.n, 4))
    if state.dim == 3:
        p[:, 1:] = 2.0 * state.inertia[:, None] * state.angular_velocity
    else:
        p[:, 3] = 2.0 * state.inertia * state.angular_velocity
    return p


def _three_columns(a: np.ndarray, d: int) -> np.ndarray:
    """``(N, d)`` values as GSD's ``(N, 3)``: the array itself in 3D, padded with zeros in 2D."""
    if d == 3:
        return a
    out = np.zeros((len(a), 3), a.dtype)
    out[:, :d] = a
    return out


def state_chunks(state: State, totals: Totals | None = None, pending: bool | None = None) -> dict:
    """The GSD chunks of a frame holding every field of ``state`` (and the counters of
    ``totals``), as functions that make each array when :class:`.frames.FrameWriter` writes it
    (one particle array at a time).

    Pending eMD* contacts go under ``log/particles/pending_*`` when ``pending`` is true (default:
    when the state has any). GSD reads a chunk missing from a frame from frame 0, so a file
    either has them in every frame or in none: trajectories of eMD* runs pass ``pending=True``.
    Orientations are the schema's default (identity quaternions) and are not written; angular
    momenta only for spinning particles.

    Example:
        >>> s = State(position=[[0.0, 0.0]], velocity=[[1.0, 0.0]], radius=0.5, mass=1.0, box=[4.0, 4.0])
        >>> chunks = state_chunks(s)
        >>> chunks["particles/velocity"]().tolist(), "particles/angmom" in chunks
        ([[1.0, 0.0, 0.0]], False)
    """
    n, d = state.n, state.dim

    def box():  # what GSD stores: float32 values (the exact box is log/configuration/box; no tilt for sheared states)
        out = np.zeros(6, np.float32)
        out[:d] = state.box
        return out.astype(np.float64)

    def inertia():
        moments = state.inertia  # (before the chunk: a view makes them of masses and radii it makes)
        out = np.zeros((n, 3))
        if d == 3:
            out[:] = moments[:, None]
        else:
            out[:, 2] = moments
        return out

    chunks = {
        "configuration/step": np.array([0 if totals is None else totals.events], np.uint64),
        "configuration/dimensions": np.array([d], np.uint8),
        "configuration/box": box,
        "particles/N": np.array([n], np.uint32),
        "particles/position": lambda: _three_columns(np.asarray(state.position, np.float64), d),
        "particles/velocity": lambda: _three_columns(np.asarray(state.velocity, np.float64), d),
        "particles/diameter": lambda: 2.0 * state.radius,
        "particles/mass": lambda: np.asarray(state.mass, np.float64),
        "particles/moment_inertia": inertia,
        "particles/image": lambda: _three_columns(state.image.astype(np.int32, copy=False), d),  # (a view's are int32 already)
        "log/time": np.array([state.time], np.float64),
        "log/configuration/box": np.asarray(state.box, np.float64),
        "log/configuration/periodic": state.periodic.astype(np.uint8),
        "log/configuration/shear_offset": np.array([state.shear_offset], np.float64),
        "log/particles/angular_velocity": lambda: np.asarray(state.angular_velocity, np.float64),
        "log/particles/radius": lambda: np.asarray(state.radius, np.float64),
        "log/particles/last_collision": lambda: np.asarray(state.last_collision, np.float64),
        "log/particles/riding": lambda: np.asarray(state.riding, np.uint8),
    }
    if not _is_filled(state.angular_velocity) or np.any(state.angular_velocity):  # (a run with spins: in every frame)
        chunks["particles/angmom"] = lambda: angmom(state)
    if state.has_pending if pending is None else pending:
        chunks["log/particles/pending_velocity"] = lambda: np.asarray(state.pending_velocity, np.float64)
        chunks["log/particles/pending_until"] = lambda: np.asarray(state.pending_until, np.float64)
        chunks["log/particles/pending_partner"] = lambda: np.asarray(state.pending_partner, np.int64)
    if state.captured_pairs is not None:  # (square-well runs: in every frame, even when empty)
        chunks["log/state/captured_pairs"] = state.captured_pairs.ravel().astype(np.int64)
    if totals is not None:
        chunks["log/events"] = np.array([totals.events], np.int64)
        chunks["log/collisions"] = np.array([totals.collisions], np.int64)
    return chunks


def frame_to_state(frame: gsd.hoomd.Frame, check_overlaps: bool = True) -> State:
    """Rebuild a :class:`State` from a ``gsd.hoomd`` frame (exact for frames written by edmd).

    Frames from other programs work too: the box then comes from the (single precision)
    configuration chunk, radii from diameters (default 1), masses default to 1.
    ``check_overlaps=False`` accepts overlapping particles (soft-sphere frames, :mod:`edmd.run.dem`).
    Files are read chunk by chunk instead (:func:`read_state`, :func:`iter_states`).
    """

    def get(name):
        if name.startswith("log/"):
            return frame.log.get(name[4:])
        group, field = name.split("/", 1)
        return getattr(getattr(frame, group), field, None)

    return _state_from(get, check_overlaps)


def read_frame(reader: FrameReader, frame: int, check_overlaps: bool = True) -> State:
    """The :class:`State` of frame ``frame`` of an open file, read chunk by chunk (only the
    chunks a State needs, each converted as it is read; see :func:`frame_to_state`).

    Example:
        >>> import edmd, tempfile, os
        >>> p = os.path.join(tempfile.mkdtemp(), "s.gsd")
        >>> write_state(p, edmd.lattice(32, 0.2))
        >>> with FrameReader(p) as r:
        ...     read_frame(r, 0).n
        32
    """
    return _state_from(lambda name: reader.chunk(frame, name), check_overlaps)


def _unless_all(values: np.ndarray | None, value) -> np.ndarray | None:
    """``values``, or ``None`` where every entry is ``value`` (the State's default then costs no memory)."""
    return None if values is None or np.all(values == value) else values


def _state_from(get, check_overlaps: bool) -> State:
    """A :class:`State` from the chunks of one frame: ``get(name)`` is chunk ``name`` (``None``:
    not there). Each array is read when it is converted, one at a time; fields at their
    defaults (no spins, images, last collisions, riders or pending contacts) are left out."""
    d = int(_first(get("configuration/dimensions"), 3) or 3)
    n = int(_first(get("particles/N"), 0))
    if n == 0:
        raise StateError("the GSD frame holds no particles")
    gsd_box = np.asarray(_first_n(get("configuration/box"), 6), np.float64)
    if np.any(gsd_box[3:] != 0.0):  # (edmd's sheared states keep a rectangular box: log/configuration/shear_offset)
        raise StateError(f"the GSD frame's box is tilted (tilt factors xy, xz, yz = {gsd_box[3:].tolist()}): edmd simulates rectangular boxes only")
    box = get("log/configuration/box")
    box = gsd_box[:d] if box is None else np.asarray(box, np.float64)
    pos = _columns(get("particles/position"), d, "particles/position")
    vel = get("particles/velocity")
    vel = np.zeros((n, d)) if vel is None else _columns(vel, d)
    radius = get("log/particles/radius")
    if radius is None:
        diam = get("particles/diameter")
        radius = 0.5 * (np.ones(1) if diam is None else np.asarray(diam, np.float64))
    mass = get("particles/mass")
    mass = np.ones(1) if mass is None else np.asarray(mass, np.float64)
    inertia = get("particles/moment_inertia")
    inertia = np.ascontiguousarray(np.asarray(inertia, np.float64)[:, 2 if d == 2 else 0]) if inertia is not None and np.any(np.asarray(inertia) > 0) else None
    radius, mass, inertia = (a if a is None or a.size != n else one_if_equal(a) for a in (radius, mass, inertia))  # (one value: in no memory)
    image = _unless_all(get("particles/image"), 0)
    image = None if image is None else _columns(image, d, dtype=np.int64)
    spin = get("log/particles/angular_velocity")
    if spin is None and inertia is not None:
        spin = _spin_from_angmom(get("particles/angmom"), get("particles/orientation"), inertia, d)
    spin = _unless_all(spin, 0.0)
    pending = [get(f"log/particles/pending_{k}") for k in ("velocity", "until", "partner")]
    if pending[2] is not None and np.all(pending[2] == -1) and np.all(pending[1] == np.inf) and not np.any(pending[0]):
        pending = [None, None, None]  # (none pending)
    captured = get("log/state/captured_pairs")
    periodic = get("log/configuration/periodic")
    offset = get("log/configuration/shear_offset")
    return State(
        position=pos,
        velocity=vel,
        radius=radius,
        mass=mass,
        box=box,
        time=float(_first(get("log/time"), 0.0)),
        angular_velocity=None if spin is None else np.asarray(spin, np.float64),
        inertia=inertia,
        image=image,
        periodic=None if periodic is None else np.asarray(periodic, bool),
        last_collision=_unless_all(get("log/particles/last_collision"), -np.inf),
        pending_velocity=pending[0],
        pending_until=pending[1],
        pending_partner=pending[2],
        captured_pairs=None if captured is None else np.asarray(captured, np.int64).reshape(-1, 2),
        riding=_unless_all(get("log/particles/riding"), 0),
        shear_offset=float(_first(offset, 0.0)),
        check_overlaps=check_overlaps,
    )


def _first(value, default):
    """The first entry of a chunk (a scalar of a ``gsd.hoomd`` frame as is), or ``default``."""
    return default if value is None else np.asarray(value).reshape(-1)[0]


def _first_n(value, k: int) -> np.ndarray:
    """The first ``k`` entries of a chunk, zeros where it has fewer (or none)."""
    out = np.zeros(k)
    if value is not None:
        value = np.asarray(value, np.float64).reshape(-1)[:k]
        out[: len(value)] = value
    return out


def _columns(values: np.ndarray | None, d: int, name: str = "", dtype=np.float64) -> np.ndarray:
    """The first ``d`` columns of a per-particle chunk of 3 as ``dtype`` (the chunk itself when it is that already)."""
    if values is None:
        raise StateError(f"the GSD frame has no {name}")
    values = np.asarray(values)
    if values.ndim != 2 or values.shape[1] < d:
        raise StateError(f"the GSD frame's {name or 'per-particle chunk'} has shape {values.shape}, expected (N, 3)")
    return values[:, :d].astype(dtype, copy=False) if d == values.shape[1] else np.ascontiguousarray(values[:, :d], dtype=dtype)


def _spin_from_angmom(p, q, inertia: np.ndarray, d: int) -> np.ndarray | None:
    """Angular velocities from HOOMD angular momenta ``p`` (frames of other programs; orientations ``q`` must be the identity)."""
    if p is None or not np.any(p):
        return None
    if q is not None and not np.allclose(q, [1.0, 0.0, 0.0, 0.0]):
        raise StateError("the GSD frame has non-identity orientations: cannot convert angmom to angular velocities")
    p = np.asarray(p, np.float64)
    return p[:, 1:] / (2.0 * inertia[:, None]) if d == 3 else p[:, 3] / (2.0 * inertia)


def _open_error(path, exc: Exception) -> StateError:
    return exc if isinstance(exc, StateError) else StateError(f"cannot read a state from {path}: {exc}")


def frame_count(path: str | os.PathLike) -> int:
    """Number of frames in a GSD file (0 if it does not exist)."""
    if not os.path.exists(path):
        return 0
    try:
        with FrameReader(path) as traj:
            return len(traj)
    except (OSError, RuntimeError, ValueError) as exc:
        raise _open_error(path, exc) from exc


def iter_states(path: str | os.PathLike, start: int = 0, stop: int | None = None, step: int = 1, check_overlaps: bool = True) -> Iterator[State]:
    """The States of frames ``start:stop:step`` of a GSD file, one at a time.

    ``check_overlaps=False`` reads frames of soft particles in contact (:mod:`edmd.run.dem`).

    Example:
        >>> import edmd, tempfile, os
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(32, 0.2), 1.0))
        >>> p = os.path.join(tempfile.mkdtemp(), "t.gsd")
        >>> _ = sim.add(Trajectory(p, interval=0.5)); sim.run(until_time=1.0); sim.close()
        >>> [s.time for s in iter_states(p)]
        [0.0, 0.5, 1.0]
    """
    try:
        with FrameReader(path) as traj:
            for k in range(*slice(start, stop, step).indices(len(traj))):
                yield read_frame(traj, k, check_overlaps)
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        raise _open_error(path, exc) from exc


def truncate_frames(path: str | os.PathLike, frames: int, size: int | None = None):
    """Keep only the first ``frames`` frames of a GSD file (rewritten atomically).

    Used on restart: frames written after the checkpoint by the interrupted run are dropped. The
    frames are copied chunk for chunk (:func:`.frames.copy_frames`), so the file is byte for byte
    the one a run that stopped after ``frames`` frames leaves. A file that still has the ``size``
    in bytes it had at the checkpoint and ``frames`` frames is that file already (a writer only
    appends): it is kept as it is (a run extended from its final checkpoint copies nothing).
    """
    have = frame_count(path)
    if have < frames:
        raise StateError(f"{path} has {have} frames, fewer than the {frames} the checkpoint expects")
    if not os.path.exists(path):  # (none expected: the first frame is after the checkpoint)
        return
    if have == frames and size is not None and os.path.getsize(path) == size:
        return
    # rewritten even when no frame is dropped: a run killed while writing a frame leaves its
    # partial data after the last complete frame, which appending would keep
    with atomic_path(path) as tmp:
        with FrameWriter(tmp) as dst:
            copy_frames(path, dst, frames)


def read_state(path: str | os.PathLike, frame: int = -1, check_overlaps: bool = True) -> State:
    """The :class:`State` stored in frame ``frame`` of a GSD file (default: the last).

    ``check_overlaps=False`` reads frames of soft particles in contact (:mod:`edmd.run.dem`).

    Example:
        >>> import edmd, tempfile, os
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(32, 0.2), 1.0)
        >>> p = os.path.join(tempfile.mkdtemp(), "s.gsd")
        >>> write_state(p, s)
        >>> bool(np.array_equal(read_state(p).velocity, s.velocity))
        True
    """
    try:
        with FrameReader(path) as traj:
            if len(traj) == 0:
                raise StateError(f"{path} holds no frames")
            if not -len(traj) <= frame < len(traj):
                raise StateError(f"{path} has {len(traj)} frames, there is no frame {frame}")
            return read_frame(traj, frame, check_overlaps)
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        raise _open_error(path, exc) from exc


def frame_size(path: str | os.PathLike, frame: int = -1) -> int | None:
    """The number of particles in frame ``frame`` of a GSD file, read without loading the frame;
    ``None`` if the file cannot tell (:func:`read_state` then names the problem).

    Example:
        >>> import edmd, tempfile, os
        >>> p = os.path.join(tempfile.mkdtemp(), "s.gsd")
        >>> write_state(p, edmd.lattice(32, 0.2))
        >>> frame_size(p)
        32
    """
    try:
        with FrameReader(path) as f:
            return f.count(frame) or None if -len(f) <= frame < len(f) else None
    except (OSError, RuntimeError, ValueError, KeyError):
        return None


def write_state(path: str | os.PathLike, state: State, totals: Totals | None = None):
    """Write ``state`` as the only frame of a new GSD file."""
    with FrameWriter(path) as traj:
        traj.append(state_chunks(state, totals))


#: the log entry holding the identity of the run that wrote a trajectory
RUN_ID = "edmd/run_id"


def trajectory_run_id(path: str | os.PathLike) -> str | None:
    """The run identity stored in frame 0 of a trajectory (``None`` if it has none or no frames).

    Example:
        >>> import edmd, tempfile, os
        >>> p = os.path.join(tempfile.mkdtemp(), "t.gsd")
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(32, 0.2), 1.0))
        >>> _ = sim.add(Trajectory(p, 1.0, run_id="abc123"))
        >>> sim.run(until_time=1.0); sim.close()
        >>> trajectory_run_id(p)
        'abc123'
    """
    try:
        with gsd.fl.open(str(path), "r") as f:
            if f.nframes == 0 or not f.chunk_exists(0, "log/" + RUN_ID):
                return None
            return bytes(f.read_chunk(0, "log/" + RUN_ID)).decode()
    except (OSError, RuntimeError, ValueError, UnicodeDecodeError) as exc:
        raise _open_error(path, exc) from exc


class Trajectory(Observer):
    """Append a GSD frame (double precision) at every interval.

    The file is opened at the first frame (mode ``"w"`` truncates, ``"a"`` appends). In a
    checkpoint it records how many frames the file holds; on restart the file is cut back to
    that many (frames written after the checkpoint by an interrupted run are dropped).
    ``run_id``, if given, is stored in every frame as ``log/edmd/run_id`` (see
    :func:`trajectory_run_id`): ``edmd run`` marks its files with the run's identity. Frames
    appended to a file whose frames have no run id get none either (GSD needs a log entry in
    every frame or in none).

    Example:
        >>> import edmd, tempfile, os, gsd.hoomd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(64, 0.2), 1.0))
        >>> p = os.path.join(tempfile.mkdtemp(), "traj.gsd")
        >>> _ = sim.add(Trajectory(p, interval=0.5))
        >>> sim.run(until_time=1.0); sim.close()
        >>> len(gsd.hoomd.open(p))
        3
    """

    reads_once = True  # (its frame is written while it fires, one array at a time)

    def __init__(self, path: str | os.PathLike, interval: float, start: float | None = None, mode: str = "w", run_id: str | None = None):
        if mode not in ("w", "a"):
            raise ValueError(f"mode must be 'w' or 'a', got {mode!r}")
        super().__init__(interval, start)
        self.path = str(path)
        self.mode = mode
        self.run_id = run_id
        self._file = None

    @property
    def frames(self) -> int:
        """Frames in the file (those of an appended-to file included)."""
        if self._file is not None:
            return len(self._file)
        return frame_count(self.path) if self.mode == "a" else 0

    def observe(self, sim: Simulation, state: State, totals: Totals):
        if self._file is None:
            if self.mode == "a" and self.run_id is not None and frame_count(self.path) and trajectory_run_id(self.path) is None:
                # frames without a run id (an older edmd): GSD reads a log entry missing from a
                # frame from frame 0, so new entries in later frames would make the old ones unreadable
                self.run_id = None
            self._file = FrameWriter(self.path, self.mode)
        chunks = state_chunks(state, totals, pending=sim.soft_contacts)
        if self.run_id is not None:
            chunks["log/" + RUN_ID] = np.frombuffer(self.run_id.encode(), np.uint8)
        self._file.append(chunks)

    def checkpoint_data(self) -> dict:
        size = os.path.getsize(self.path) if os.path.exists(self.path) else 0  # (synced before, Observer.sync)
        return {**super().checkpoint_data(), "frames": self.frames, "bytes": size}

    def restore_data(self, data: dict):
        super().restore_data(data)
        self.close()
        truncate_frames(self.path, int(data["frames"]), None if "bytes" not in data else int(data["bytes"]))  # (older checkpoints: no size)
        self.mode = "a"

    def sync(self):
        fsync_existing(self.path)

    def close(self):
        if self._file is not None:
            self._file.close()
            self._file = None
