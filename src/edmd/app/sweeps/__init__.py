"""Parameter sweeps: a base configuration times a grid of overrides, run on any executor, resumable.

See :mod:`edmd.app.sweeps.spec` (the sweep file), :mod:`edmd.app.sweeps.execute` (running it) and
:mod:`edmd.app.sweeps.table` (the results table); the layout of a sweep directory is in
:mod:`edmd.app.sweeps.files`.
"""

from .execute import SweepResult, dask_executor, run_point, sweep
from .spec import Point, RawPoint, SweepError, SweepSpec, replica_seed
from .table import TIMING, ResultsTable, sweep_summary

__all__ = [
    "TIMING",
    "Point",
    "RawPoint",
    "ResultsTable",
    "SweepError",
    "SweepResult",
    "SweepSpec",
    "dask_executor",
    "replica_seed",
    "run_point",
    "sweep",
    "sweep_summary",
]
