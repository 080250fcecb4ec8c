"""Command line: ``edmd run``, ``edmd init``, ``edmd sweep``."""

from __future__ import annotations

import collections
import contextlib
from pathlib import Path

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from .config import EXAMPLE, Config, ConfigError, load_config
from .state import StateError

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Event-driven molecular dynamics of hard and soft spheres and disks.")
console = Console()
err_console = Console(stderr=True)


def _fail(msg: str):
    err_console.print(f"[bold red]error:[/] {escape(msg)}")
    raise typer.Exit(code=2)


@app.command()
def run(
    config: Path = typer.Argument(None, help="TOML configuration; without it a built-in default runs."),
    out: Path = typer.Option(Path("edmd-run"), "--out", "-o", help="Run directory for config, thermo, trajectory."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show a progress bar."),
):
    """Run a simulation and write its run directory."""
    from .runner import run_directory

    try:
        cfg = load_config(config) if config is not None else Config()
        if config is None:
            console.print("[dim]no config given: running the built-in default (3D hard-sphere fluid, N = 4000, eta = 0.3)[/]")
        summary = run_directory(cfg, out, progress=progress and cfg.run.progress)
    except (ConfigError, StateError, ValueError) as exc:
        _fail(str(exc))
    table = Table(title=f"edmd run -> {out}", show_header=False)
    for key in ("time", "collisions", "events", "temperature", "pressure_mean", "collisions_per_second", "neighbours"):
        if key in summary:
            v = summary[key]
            table.add_row(key, f"{v:.6g}" if isinstance(v, float) else str(v))
    console.print(table)


@app.command()
def init(
    path: Path = typer.Argument(Path("edmd.toml"), help="Where to write the example configuration."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing file."),
):
    """Write a commented example configuration."""
    if path.exists() and not force:
        _fail(f"{path} exists; use --force to overwrite")
    path.write_text(EXAMPLE)
    console.print(f"wrote {path}")


@app.command()
def sweep(
    sweep_file: Path = typer.Argument(None, help="Sweep file (TOML): a base configuration and a \\[grid] and/or \\[\\[points]] of overrides."),
    out: Path = typer.Option(None, "--out", "-o", help="Sweep directory (default: <sweep file name>-sweep)."),
    workers: int = typer.Option(None, "--workers", "-w", min=1, help="Local worker processes, or the --dask cluster size (default: one per CPU)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Run on the dask.distributed cluster of this scheduler (tcp://host:8786)."),
    dask: bool = typer.Option(False, "--dask", help="Run on a local dask.distributed cluster (pip install 'edmd\\[dask]')."),
    summary: Path = typer.Option(None, "--summary", help="Only rebuild the results table of this sweep directory."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show a progress bar counting points."),
):
    """Run a parameter sweep (resumable: finished points are skipped), or rebuild its results table."""
    from .sweeps import SweepError, dask_executor, sweep_summary
    from .sweeps import sweep as run_sweep

    if (sweep_file is None) == (summary is None):
        _fail("give a sweep file, or --summary DIR to rebuild the results table of a sweep directory")
    try:
        if summary is not None:
            _report_summary(summary, sweep_summary(summary))
            return
        out = out if out is not None else Path(f"{sweep_file.stem}-sweep")
        with contextlib.ExitStack() as stack:
            executor = stack.enter_context(dask_executor(scheduler, workers)) if (dask or scheduler) else None
            result = run_sweep(sweep_file, out, executor=executor, workers=None if executor else workers, progress=progress)
    except (SweepError, ConfigError) as exc:
        _fail(str(exc))
    _report_summary(result.directory, result.table, f"ran {result.ran}, skipped {result.skipped} finished before; ")
    if result.failed:
        raise typer.Exit(code=1)


def _report_summary(directory: Path, table, head: str = ""):
    counts = collections.Counter(row["status"] for row in table.rows)
    console.print(f"sweep {escape(str(directory))}: {len(table.rows)} points; {head}" + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())), soft_wrap=True)
    failed = [row for row in table.rows if row["status"] == "failed"]
    if failed:
        listing = Table("point", "error", title="failed points (traceback in points/<point>/error.txt)")
        for row in failed[:10]:
            listing.add_row(row["point"], escape(row["error"]))
        if len(failed) > 10:
            listing.add_row("...", f"and {len(failed) - 10} more (edmd sweep --summary {directory})")
        err_console.print(listing)
    console.print("results: " + escape(", ".join(str(p) for p in table.paths)), soft_wrap=True)


def main():  # pragma: no cover
    app()
