"""Wall impacts of a run as a CSV file (``[output] wall_impacts``): one row per impact on a wall.

The rows come from the engine's collision log (``enable_log(walls=True)``): ``time``, the
``particle``, the ``wall`` (``2 axis + face``, face 0 the lower wall) and the impact speeds
``v_n``, ``v_t`` relative to the wall. :class:`edmd.analysis.ImpactPhases` turns the rows of a
vibrating wall into the distribution of its phase at impact (``edmd steady RUN --impacts``).
"""

from __future__ import annotations

import csv
import os

import numpy as np

from ..run.observer import Observer
from .atomic import fsync_existing, write_atomic

COLUMNS = ("time", "particle", "wall", "v_n", "v_t")


class WallImpacts(Observer):
    """Append the wall impacts logged since the last firing to ``path``.

    Checkpoints record how many rows the file holds (the log is flushed into it first), and a
    restart cuts the file back to them, so a restarted run writes it byte for byte again.

    Example:
        >>> import edmd, numpy as np, tempfile, pathlib
        >>> ball = edmd.State(np.zeros((1, 2)), np.array([[0.0, -1.0]]), np.array([0.1]), np.array([1.0]),
        ...                   box=np.ones(2), periodic=np.array([True, False]))
        >>> sim = edmd.Simulation(ball)
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "wall_impacts.csv"
        >>> _ = sim.add(WallImpacts(0.5, path)); sim.run(until_time=1.5); sim.close()
        >>> read_wall_impacts(path)[:, 2:4].tolist()   # the lower wall of y, then the upper one
        [[2.0, 1.0], [3.0, 1.0]]
    """

    def __init__(self, interval: float, path: str | os.PathLike, start: float | None = None):
        super().__init__(interval, start)
        self.path = path
        self.rows = 0
        self._sim = None

    def attach(self, sim):
        super().attach(sim)
        self._sim = sim
        sim.engine.enable_log(walls=True)

    def observe(self, sim, state, totals):
        self._flush()

    def _flush(self):
        if self._sim is None:
            return
        log = self._sim.engine.take_log()
        rows = log[log[:, 2] < 0]
        if not len(rows) and os.path.exists(self.path):
            return
        new = not os.path.exists(self.path) or os.path.getsize(self.path) == 0
        with open(self.path, "a", newline="") as f:
            writer = csv.writer(f)
            if new:
                writer.writerow(COLUMNS)
            for t, i, j, vn, vt in rows:
                writer.writerow((repr(float(t)), int(i), int(-1 - j), repr(float(vn)), repr(float(vt))))
        self.rows += len(rows)

    def checkpoint_data(self) -> dict:
        """Schedule and the number of rows in the file (after flushing the log into it)."""
        self._flush()
        return {**super().checkpoint_data(), "rows": self.rows}

    def restore_data(self, data: dict):
        """Continue from a checkpoint: the file is cut back to its rows then (atomically)."""
        super().restore_data(data)
        self.rows = int(data["rows"])
        lines = []
        if os.path.exists(self.path):
            with open(self.path, newline="") as f:
                lines = f.read().splitlines(keepends=True)
        if len(lines) < self.rows + 1 and self.rows:
            raise ValueError(f"{self.path} holds {max(len(lines) - 1, 0)} wall impacts, fewer than the checkpoint's {self.rows}")
        write_atomic(self.path, "".join(lines[: self.rows + 1]) if lines else ",".join(COLUMNS) + "\r\n")

    def sync(self):
        fsync_existing(self.path)

    def close(self):
        self._flush()


def read_wall_impacts(path: str | os.PathLike) -> np.ndarray:
    """The rows of a wall-impact file as a ``(k, 5)`` array (see :data:`COLUMNS`)."""
    with open(path, newline="") as f:
        header = next(csv.reader(f), [])
    if tuple(header) != COLUMNS:
        raise ValueError(f"{path} is not a wall-impact file (its header is {header}, expected {list(COLUMNS)})")
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2).reshape(-1, len(COLUMNS))
