"""The layout of a sweep directory and atomic writes (an interrupted sweep never leaves half a file).

::

    OUT/
      sweep.json            the sweep (base inlined) and its point ids in order
      results.csv           one row per point (and results.parquet with pyarrow)
      points/<id>/          one directory per point, <id> = hash of its resolved config
        config.toml         the fully resolved configuration (``edmd run`` on it gives the same run)
        point.json          the point's index and swept parameters
        status.json         {"status": "running" | "done" | "failed", "error", "elapsed_seconds", ...}
        error.txt           the traceback of a failed point
        thermo.csv, trajectory.gsd, summary.json   as written by ``edmd run``
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ...files.atomic import write_atomic
from .spec import SweepError

MANIFEST = "sweep.json"
POINTS = "points"
CONFIG = "config.toml"
POINT = "point.json"
STATUS = "status.json"
ERROR = "error.txt"
SUMMARY = "summary.json"
THERMO = "thermo.csv"
TABLE = "results"


def point_dir(out: str | Path, pid: str) -> Path:
    """The directory of point ``pid`` in sweep directory ``out``."""
    return Path(out) / POINTS / pid


def write_json(path: Path, data: Any):
    """Write ``data`` as indented JSON, atomically."""
    write_atomic(path, json.dumps(data, indent=2, default=str) + "\n")


def read_json(path: Path) -> Any:
    """The JSON in ``path``, or ``None`` if there is no such file.

    Raises:
        SweepError: the file exists but cannot be read or is not valid JSON (the message names it).

    Example:
        >>> import tempfile
        >>> d = Path(tempfile.mkdtemp())
        >>> write_json(d / "a.json", {"status": "done"})
        >>> read_json(d / "a.json"), read_json(d / "missing.json")
        ({'status': 'done'}, None)
    """
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise SweepError(f"cannot read {path}: {exc.strerror or exc}") from None
    try:
        return json.loads(data)
    except ValueError as exc:  # UnicodeDecodeError included
        raise SweepError(f"{path} is corrupt (not valid JSON: {exc})") from None
