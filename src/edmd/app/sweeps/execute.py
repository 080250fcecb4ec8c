"""Running a sweep on any :class:`concurrent.futures.Executor`, resumably."""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import os
import socket
import time
import tomllib
import traceback
from collections.abc import Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from ...cores import usable_cores
from ..config import parse_config
from ..runner import RUN_FILES, run_directory
from .files import CONFIG, ERROR, MANIFEST, POINT, STATUS, SUMMARY, point_dir, read_json, write_atomic, write_json
from .spec import Point, SweepError, SweepSpec
from .table import ResultsTable, sweep_summary


@dataclasses.dataclass
class SweepResult:
    """What :func:`sweep` did.

    Attributes:
        directory: the sweep directory.
        table: the results table (rows in sweep order, the files written).
        ran: points run now.
        skipped: points finished by an earlier run of the sweep (not run again).
        failed: rows of the points that failed (their ``error`` says why; ``error.txt`` has the traceback).
    """

    directory: Path
    table: ResultsTable
    ran: int
    skipped: int
    failed: list[dict[str, Any]]


def run_point(config_text: str, directory: str) -> dict[str, Any]:
    """Run one point: ``edmd run`` of ``config_text`` into ``directory``; runs on a worker.

    Never raises for a failing run: the failure is recorded in ``status.json`` (and the traceback
    in ``error.txt``) and returned. The point is ``running`` while it runs, so an interrupted
    sweep leaves it unfinished and the next run of the sweep retries it.
    """
    directory = Path(directory)
    started = time.perf_counter()
    info = {"host": socket.gethostname(), "pid": os.getpid(), "started": _now()}
    write_json(directory / STATUS, {"status": "running", **info})
    (directory / SUMMARY).unlink(missing_ok=True)
    try:
        run_directory(parse_config(tomllib.loads(config_text)), directory, progress=False, force=True)
    except Exception as exc:
        status = _failure(directory, exc, traceback.format_exc())
    else:
        (directory / ERROR).unlink(missing_ok=True)
        status = {"status": "done"}
    status.update(info, finished=_now(), elapsed_seconds=time.perf_counter() - started)
    write_json(directory / STATUS, status)
    return status


def sweep(
    spec: SweepSpec | str | Path,
    out: str | Path,
    *,
    executor: Executor | None = None,
    workers: int | None = None,
    progress: bool = False,
) -> SweepResult:
    """Run every point of a sweep that is not finished yet, then write the results table.

    Each point runs in ``out/points/<id>``, ``<id>`` a hash of its fully resolved configuration
    (stored there as ``config.toml``): ``edmd run`` on that file gives the same run bit for bit.
    Finished points are skipped, failed and interrupted ones run again; a failing point is
    recorded and never stops the others.

    Args:
        spec: a :class:`SweepSpec` or the path of a sweep file.
        out: the sweep directory (created if needed). With a cluster, it must be on a file
            system the workers share: they write the point directories.
        executor: where the points run: any :class:`concurrent.futures.Executor` (e.g.
            ``dask.distributed.Client.get_executor()``, see :func:`dask_executor`). Default: a
            local process pool, shut down afterwards.
        workers: size of the default process pool (default: the cores this process may use,
            :func:`edmd.cores.usable_cores`).
        progress: show a progress bar counting points.

    Returns:
        A :class:`SweepResult`; the table is also in ``out/results.csv`` (and ``.parquet``).

    Example:
        >>> import edmd, tempfile
        >>> spec = edmd.SweepSpec.from_dict({
        ...     "base": {"system": {"dim": 2, "n": 16}, "run": {"until_time": 0.5}},
        ...     "grid": {"system.packing_fraction": [0.05, 0.1]},
        ... })
        >>> result = edmd.sweep(spec, tempfile.mkdtemp(), workers=1)
        >>> result.ran, [row["status"] for row in result.table.rows]
        (2, ['done', 'done'])
    """
    if executor is not None and workers is not None:
        raise SweepError("workers sizes the default process pool; with an executor, size the executor")
    spec = spec if isinstance(spec, SweepSpec) else SweepSpec.load(spec)
    out = Path(out).resolve()
    _check_sweep_directory(out)
    points = spec.resolve()
    _prepare(out, spec, points)
    todo = [p for p in points if (read_json(point_dir(out, p.id) / STATUS) or {}).get("status") != "done"]
    for p in todo:
        write_atomic(point_dir(out, p.id) / CONFIG, p.text)
    _run_all(todo, out, executor, workers, lambda: _progress_bar(progress, len(points), len(points) - len(todo)))
    table = sweep_summary(out)
    failed = [row for row in table.rows if row["status"] == "failed"]
    return SweepResult(out, table, ran=len(todo), skipped=len(points) - len(todo), failed=failed)


@contextlib.contextmanager
def dask_executor(scheduler: str | None = None, workers: int | None = None) -> Iterator[Executor]:
    """An executor on a ``dask.distributed`` cluster (needs ``pip install 'edmd[dask]'``).

    Args:
        scheduler: address of a running scheduler (``tcp://host:8786``); without it a local
            cluster of ``workers`` single-threaded worker processes is started and stopped.
        workers: local cluster size (default: one per usable core); not used with ``scheduler``.

    Example:
        >>> import edmd
        >>> with dask_executor(workers=2) as ex:          # doctest: +SKIP
        ...     edmd.sweep("sweep.toml", "out", executor=ex)
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise SweepError("dask is not installed: pip install 'edmd[dask]'") from None
    if scheduler is not None:
        if workers is not None:
            raise SweepError("workers sets the size of a local cluster; a scheduler's cluster has its own workers")
        try:
            client = Client(scheduler)
        except (OSError, TimeoutError) as exc:
            raise SweepError(f"cannot reach the dask scheduler at {scheduler}: {exc}") from None
        with client:
            yield client.get_executor(pure=False)
        return
    with LocalCluster(n_workers=workers or usable_cores(), threads_per_worker=1, processes=True) as cluster, Client(cluster) as client:
        yield client.get_executor(pure=False)


# ---------------------------------------------------------------------- steps
def _check_sweep_directory(out: Path):
    """A sweep directory is a folder that holds no run of ``edmd run`` (its points are in ``points/``)."""
    if out.exists() and not out.is_dir():
        raise SweepError(f"{out} exists and is not a directory: give --out a folder for the sweep")
    run = [name for name in RUN_FILES if (out / name).exists()]
    if run:
        raise SweepError(f"{out} holds a run of `edmd run` ({', '.join(run)}): choose another folder for the sweep")


def _prepare(out: Path, spec: SweepSpec, points: list[Point]):
    """Write the manifest and each point's ``point.json``."""
    for p in points:
        directory = point_dir(out, p.id)
        directory.mkdir(parents=True, exist_ok=True)
        write_json(directory / POINT, {"id": p.id, "index": p.index, "params": p.params})
    write_json(out / MANIFEST, {"sweep": spec.to_dict(), "points": [{"id": p.id, "params": p.params} for p in points]})


def _run_all(todo: list[Point], out: Path, executor: Executor | None, workers: int | None, progress_bar):
    """Submit every point, then collect the outcomes as they come (the bar starts after the workers)."""
    if not todo:
        return
    own = executor is None
    if own:
        executor = ProcessPoolExecutor(max_workers=min(workers or usable_cores(), len(todo)))
    futures: dict[Future, Point] = {}
    try:
        futures = {executor.submit(run_point, p.text, str(point_dir(out, p.id))): p for p in todo}
        with progress_bar() as advance:
            for future in as_completed(futures):
                advance(_outcome(future, point_dir(out, futures[future].id)))
    except BaseException:  # interrupted: unfinished points stay unfinished, the next run retries them
        for future in futures:
            future.cancel()
        if own:
            _terminate(executor)
        raise
    if own:
        executor.shutdown()


def _terminate(pool: ProcessPoolExecutor):
    """Stop our own pool now: queued points never start, running ones are ended (not waited for)."""
    if hasattr(pool, "terminate_workers"):  # Python >= 3.14
        pool.terminate_workers()
        return
    for process in list(pool._processes.values()):  # the same, by hand, before 3.14
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def _outcome(future: Future, directory: Path) -> dict[str, Any]:
    """The status a point's future returned, or a failure recorded here if the worker itself failed."""
    try:
        return future.result()
    except Exception as exc:  # the worker died, or the executor could not run the task
        status = _failure(directory, exc, "".join(traceback.format_exception(exc)))
        write_json(directory / STATUS, status)
        return status


def _failure(directory: Path, exc: BaseException, trace: str) -> dict[str, Any]:
    write_atomic(directory / ERROR, trace)
    return {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}


@contextlib.contextmanager
def _progress_bar(show: bool, total: int, done: int):
    """A context giving ``advance(status)``; with ``show`` a rich bar counting points (and failures)."""
    if not show:
        yield lambda status: None
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    bar = Progress(
        TextColumn("[bold]sweep"), BarColumn(), MofNCompleteColumn(), TextColumn("points  {task.fields[failed]}"), TimeElapsedColumn(), TimeRemainingColumn()
    )
    task = bar.add_task("sweep", total=total, completed=done, failed="")
    failed = 0

    def advance(status):
        nonlocal failed
        failed += status.get("status") == "failed"
        bar.update(task, advance=1, failed=f"[red]{failed} failed[/]" if failed else "")

    with bar:
        yield advance


def _now() -> str:
    return datetime.datetime.now().astimezone().isoformat(timespec="seconds")
