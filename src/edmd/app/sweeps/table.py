"""The results table of a sweep: one row per point, rebuilt from the point directories.

A row holds the point's id (``point``), its swept parameters, ``status`` and ``error``, every
scalar of the point's ``summary.json`` (final numbers and counters, so counters added to the
summary appear here by themselves), from ``thermo.csv`` the final value of each cumulative
column (:data:`edmd.files.thermo.CUMULATIVE`) and the mean over the output intervals of every other
column (``<column>_mean``), and ``elapsed_seconds`` (the point's wall time, setup included).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
from pathlib import Path
from typing import Any

from ...files.thermo import CUMULATIVE, read_thermo
from .files import MANIFEST, POINT, POINTS, STATUS, SUMMARY, TABLE, THERMO, point_dir, read_json, write_atomic
from .spec import SweepError

TIMING = ("wall_seconds", "collisions_per_second", "elapsed_seconds")
"""Columns that differ between two runs of the same point (everything else is reproducible)."""


@dataclasses.dataclass
class ResultsTable:
    """The results of a sweep.

    Attributes:
        rows: one dict per point, in sweep order.
        columns: every column, in order (a row lacks the columns that do not apply to it).
        paths: the files written (``results.csv``, and ``results.parquet`` when pyarrow is installed).
    """

    rows: list[dict[str, Any]]
    columns: list[str]
    paths: list[Path]


def point_row(directory: Path) -> dict[str, Any]:
    """The results row of one point directory (status ``pending`` if it never started)."""
    meta = read_json(directory / POINT) or {}
    status = read_json(directory / STATUS) or {}
    row = {"point": directory.name, **meta.get("params", {})}
    row["status"] = status.get("status", "pending")
    row["error"] = " ".join(status["error"].split()) if status.get("error") else None
    if row["status"] == "done":
        summary = read_json(directory / SUMMARY) or {}
        row.update({k: v for k, v in summary.items() if v is None or isinstance(v, (int, float, str))})
        if (directory / THERMO).exists():
            row.update(thermo_columns(directory / THERMO, row))
    row["elapsed_seconds"] = status.get("elapsed_seconds")
    return row


def thermo_columns(path: Path, present: dict[str, Any]) -> dict[str, Any]:
    """Final values of the cumulative thermo columns and means of the others (rows after the first).

    Columns already in ``present`` (from ``summary.json``) are left out.
    """
    out = {}
    for column, values in read_thermo(path).items():
        name = column if column in CUMULATIVE else f"{column}_mean"
        if column == "time" or name in present:
            continue
        if column in CUMULATIVE:
            out[name] = float(values[-1])
        else:
            finite = [float(v) for v in values[1:] if not math.isnan(v)]
            out[name] = sum(finite) / len(finite) if finite else math.nan
    return out


def point_ids(out: Path) -> list[str]:
    """The points of sweep directory ``out`` in sweep order: from its manifest, else every point directory."""
    manifest = read_json(out / MANIFEST)
    if manifest is not None:
        return [p["id"] for p in manifest["points"]]
    if not (out / POINTS).is_dir():
        raise SweepError(f"{out} is not a sweep directory (no {MANIFEST}, no {POINTS}/)")
    dirs = [d for d in (out / POINTS).iterdir() if d.is_dir()]
    return [d.name for d in sorted(dirs, key=lambda d: ((read_json(d / POINT) or {}).get("index", math.inf), d.name))]


def sweep_summary(out: str | Path) -> ResultsTable:
    """Rebuild the results table of sweep directory ``out`` from its point directories.

    Writes ``results.csv`` (and ``results.parquet`` when pyarrow is installed) atomically; this is
    ``edmd sweep --summary OUT``, and it works while the sweep runs (unfinished points are
    ``pending`` or ``running``).

    Example:
        >>> import tempfile
        >>> out = Path(tempfile.mkdtemp())
        >>> (out / "points" / "abc").mkdir(parents=True)
        >>> sweep_summary(out).rows
        [{'point': 'abc', 'status': 'pending', 'error': None, 'elapsed_seconds': None}]
    """
    out = Path(out)
    rows = [point_row(point_dir(out, pid)) for pid in point_ids(out)]
    columns = list(dict.fromkeys(k for row in rows for k in row))
    paths = [out / f"{TABLE}.csv"]
    write_atomic(paths[0], _csv(rows, columns))
    parquet = _parquet(rows, columns)
    if parquet is not None:
        paths.append(out / f"{TABLE}.parquet")
        write_atomic(paths[1], parquet)
    return ResultsTable(rows, columns, paths)


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (dict, list)):
        return json.dumps(v)
    return str(v)


def _csv(rows: list[dict], columns: list[str]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(row.get(c)) for c in columns])
    return buf.getvalue()


def _parquet(rows: list[dict], columns: list[str]) -> bytes | None:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return None

    def column(values):
        if not any(isinstance(v, (dict, list)) for v in values):
            try:
                return pa.array(values)
            except (pa.ArrowInvalid, pa.ArrowTypeError):
                pass
        return pa.array([None if v is None else _cell(v) for v in values], type=pa.string())

    table = pa.table({c: column([row.get(c) for row in rows]) for c in columns})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()
