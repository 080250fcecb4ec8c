"""Atomic file writes: a temporary file in the same folder, flushed to disk, then renamed.

A reader (or a run killed mid-write) sees either the old file or the complete new one, never
a half-written file: :func:`os.replace` is atomic on POSIX and Windows within one file system.
"""

from __future__ import annotations

import contextlib
import errno
import os
import threading
from collections.abc import Iterator
from pathlib import Path


def temp_path(path: str | os.PathLike) -> Path:
    """The temporary sibling used while writing ``path``: hidden, unique to this process and
    thread (concurrent writers of one file never share it), with ``path``'s suffix (writers that
    choose a format by the suffix, e.g. movies, see the right one)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.{os.getpid()}-{threading.get_ident()}.partial{path.suffix}")


def _fsync(path: Path):
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_existing(path: str | os.PathLike | None):
    """Force the data written to ``path`` onto the disk (nothing if there is no such file): what
    an appending observer does before a checkpoint counts its rows or frames (:meth:`.Observer.sync`)."""
    if path is not None and os.path.exists(path):
        _fsync(Path(path))


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces ``path`` atomically.

    Example:
        >>> import tempfile
        >>> p = Path(tempfile.mkdtemp()) / "a.txt"
        >>> with atomic_path(p) as tmp:
        ...     _ = tmp.write_text("complete")
        >>> p.read_text()
        'complete'
    """
    path = Path(path)
    if not path.parent.is_dir():  # (the error would name the temporary file)
        raise FileNotFoundError(errno.ENOENT, f"cannot write {path}: there is no folder {path.parent}")
    tmp = temp_path(path)
    tmp.unlink(missing_ok=True)
    try:
        yield tmp
        _fsync(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_atomic(path: str | os.PathLike, data: str | bytes):
    """Write ``data`` (text or bytes) to ``path`` atomically.

    Example:
        >>> import tempfile
        >>> p = Path(tempfile.mkdtemp()) / "x.txt"
        >>> write_atomic(p, "hello"); p.read_text()
        'hello'
    """
    with atomic_path(path) as tmp:
        tmp.write_bytes(data.encode() if isinstance(data, str) else data)
