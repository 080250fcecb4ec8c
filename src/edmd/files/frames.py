"""GSD frames written one chunk at a time, each chunk that equals frame 0's written once.

The files are HOOMD-schema GSD files (double precision) that ``gsd.hoomd`` reads as before: a
chunk missing from a frame is read from frame 0, or is the schema's default if frame 0 lacks it
too. HOOMD's own writer (``gsd.hoomd.HOOMDTrajectory.append``) takes a frame whose arrays all
exist at once, copies each again while writing, and keeps all of frame 0 in memory to compare
with: at N = 1e6 a trajectory output peaked at ~570 B per particle above the run
(benchmarks/README.md, "Memory"). Here a frame is a mapping of chunk names to arrays or to
functions that make them: each is made, written and dropped in turn, and frame 0 is kept as
a fingerprint per chunk (:class:`_Fingerprint`: its dtype, shape and 16-byte digest, BLAKE2b of
its bytes, or its one value if all its elements hold it; read back from the file at the second
frame, so one-frame files such as checkpoints never take them). A later chunk equal to frame 0's
is not written (the reader takes frame 0's, which is identical); every other one is, log entries
included.

Chunks are written in sorted name order, so copying a file's frames (:func:`copy_frames`, used
to cut a trajectory back to a checkpoint) gives the same bytes as writing them did.

Reading is chunk by chunk too (:class:`FrameReader`): ``gsd.hoomd`` reads every chunk of a frame
at once, fills the schema's defaults for every particle (orientations, type ids, charges,
bodies...) and keeps a deep copy of frame 0; restarting a run of 1e6 spheres from a checkpoint
so peaked at 584 B per particle while reading the file.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping

import gsd.fl
import gsd.version
import numpy as np

#: what ``gsd.hoomd`` writes and expects
SCHEMA, SCHEMA_VERSION = "hoomd", [2, 0]

#: a frame: chunk names and their data, or functions that make it when it is written
Chunks = Mapping[str, "np.ndarray | Callable[[], np.ndarray]"]


def _digest(data: np.ndarray) -> bytes:
    h = hashlib.blake2b(f"{data.dtype.str}{data.shape}".encode(), digest_size=16)
    h.update(data)
    return h.digest()


#: elements of a chunk compared before its digest is taken (:class:`_Fingerprint`)
SAMPLES = 16


def _sample(data: np.ndarray) -> bytes:
    """The bytes of :data:`SAMPLES` elements of ``data`` spread over it (all of a small chunk)."""
    flat = data.reshape(-1)
    if flat.size > SAMPLES:
        flat = flat[np.linspace(0, flat.size - 1, SAMPLES).astype(np.int64)]
    return flat.tobytes()


def _uniform(data: np.ndarray) -> bytes | None:
    """The bytes of the one value of ``data`` when all its elements hold them (bit for bit), else
    ``None``. A broadcast constant (:func:`edmd.state.filled`) is not read beyond its value."""
    if data.size == 0:
        return None
    first = data[(0,) * data.ndim].tobytes()
    if not any(data.strides):
        return first
    if data.dtype.itemsize not in (1, 2, 4, 8):
        return None
    bits = np.ascontiguousarray(data).reshape(-1).view(f"u{data.dtype.itemsize}")
    return first if bool((bits == bits[0]).all()) else None


class _Fingerprint:
    """What a later chunk is compared with instead of frame 0's data: its dtype and shape, and its
    one value if it is uniform (:func:`_uniform`: no digest needed), else :data:`SAMPLES` of its
    elements and its digest. A chunk that differs from frame 0's at the samples (positions,
    velocities) is not digested: the digests were half the time of writing a frame."""

    def __init__(self, data: np.ndarray):
        self.kind = (data.dtype.str, data.shape)
        self.uniform = _uniform(data)
        self.sample = self.digest = None
        if self.uniform is None:
            self.sample, self.digest = _sample(data), _digest(data)

    def matches(self, data: np.ndarray) -> bool:
        """Whether ``data`` equals the chunk, bit for bit."""
        if (data.dtype.str, data.shape) != self.kind:
            return False
        if self.uniform is not None:
            return _uniform(data) == self.uniform
        return _sample(data) == self.sample and _digest(np.ascontiguousarray(data)) == self.digest


class _GSDFile:
    """An open GSD file (``_file``), closed by :meth:`close` or at the end of a ``with`` block."""

    _file: gsd.fl.GSDFile

    def close(self):
        self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class FrameWriter(_GSDFile):
    """Append frames to a HOOMD-schema GSD file, chunk by chunk (see the module documentation).

    ``mode`` is ``"w"`` (a new file) or ``"a"`` (append; created if missing). Every frame is
    flushed when complete.

    Example:
        >>> import numpy as np, tempfile, os, gsd.hoomd
        >>> p = os.path.join(tempfile.mkdtemp(), "f.gsd")
        >>> with FrameWriter(p) as w:
        ...     for t in (0.0, 1.0):
        ...         w.append({"particles/N": np.array([2], np.uint32), "particles/position": lambda: np.full((2, 3), t),
        ...                   "log/radius": np.array([0.5, 0.5])})
        >>> with gsd.hoomd.open(p) as f:
        ...     f[1].particles.position[0].tolist(), f[1].log["radius"].tolist()  # (frame 1 has no radius chunk: frame 0's)
        ([1.0, 1.0, 1.0], [0.5, 0.5])
    """

    def __init__(self, path: str | os.PathLike, mode: str = "w"):
        self.path = str(path)
        self._file = gsd.fl.open(self.path, mode, application=f"edmd (gsd {gsd.version.version})", schema=SCHEMA, schema_version=SCHEMA_VERSION)
        self._first: dict[str, _Fingerprint] | None = None  # (frame 0's: taken at the second frame, read back)

    def __len__(self) -> int:
        return self._file.nframes

    def append(self, chunks: Chunks):
        """Write one frame (chunks in sorted name order; each made only when it is written)."""
        first = self._file.nframes == 0
        if not first and self._first is None:  # (one-frame files, e.g. checkpoints, never digest)
            f = self._file
            self._first = {name: _Fingerprint(f.read_chunk(0, name)) for name in f.find_matching_chunk_names("") if f.chunk_exists(0, name)}
        for name in sorted(chunks):
            data = chunks[name]
            data = np.asarray(data() if callable(data) else data)
            if first or name not in self._first or not self._first[name].matches(data):
                self._file.write_chunk(name, np.ascontiguousarray(data))
            del data
        self._file.end_frame()
        self._file.flush()


class FrameReader(_GSDFile):
    """Read the chunks of a GSD file one at a time, as ``gsd.hoomd`` reads them: a chunk missing
    from a frame is frame 0's (a per-particle chunk only when frame 0 has as many particles).

    Frame indices may be negative (counted from the end).

    Example:
        >>> import numpy as np, tempfile, os
        >>> p = os.path.join(tempfile.mkdtemp(), "f.gsd")
        >>> with FrameWriter(p) as w:
        ...     for t in (0.0, 1.0):
        ...         w.append({"particles/N": np.array([2], np.uint32), "log/time": np.array([t]), "log/radius": np.array([0.5, 0.5])})
        >>> with FrameReader(p) as r:
        ...     len(r), r.chunk(-1, "log/time").tolist(), r.chunk(1, "log/radius").tolist(), r.chunk(1, "particles/mass")
        (2, [1.0], [0.5, 0.5], None)
    """

    def __init__(self, path: str | os.PathLike):
        self._file = gsd.fl.open(str(path), "r")

    def __len__(self) -> int:
        return self._file.nframes

    def _index(self, frame: int) -> int:
        return range(self._file.nframes)[frame]  # (IndexError outside the file)

    def count(self, frame: int, group: str = "particles") -> int:
        """``group/N`` of ``frame`` (frame 0's if the frame has none; 0 if neither has one)."""
        f, frame = self._file, self._index(frame)
        for k in (frame, 0):
            if f.chunk_exists(k, f"{group}/N"):
                return int(f.read_chunk(k, f"{group}/N")[0])
        return 0

    def chunk(self, frame: int, name: str) -> np.ndarray | None:
        """Chunk ``name`` of ``frame`` (``None``: neither the frame nor frame 0 has it)."""
        f, frame = self._file, self._index(frame)
        if f.chunk_exists(frame, name):
            return f.read_chunk(frame, name)
        group = name.split("/", 1)[0]
        per_particle = group in ("particles", "bonds", "angles", "dihedrals", "impropers", "constraints", "pairs") and not name.endswith("/N")
        if frame != 0 and f.chunk_exists(0, name) and (not per_particle or self.count(frame, group) == self.count(0, group)):
            return f.read_chunk(0, name)
        return None

    def names(self, prefix: str) -> list[str]:
        """The names of the file's chunks that start with ``prefix``, sorted."""
        return sorted(self._file.find_matching_chunk_names(prefix))


def copy_frames(src: str | os.PathLike, dst: FrameWriter, frames: int):
    """Append the first ``frames`` frames of the GSD file ``src`` to the empty ``dst`` chunk for
    chunk: frames that a :class:`FrameWriter` wrote come out byte for byte the same."""
    with gsd.fl.open(str(src), "r") as f:
        names = sorted(f.find_matching_chunk_names(""))
        for k in range(frames):
            dst.append({name: (lambda name=name: f.read_chunk(k, name)) for name in names if f.chunk_exists(k, name)})
