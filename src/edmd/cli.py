"""Command line: ``edmd run``, ``edmd init``, ``edmd tables build|check|info``."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.table import Table

from .config import EXAMPLE, Config, ConfigError, load_config
from .state import StateError

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Event-driven molecular dynamics of hard and soft spheres and disks.")
console = Console()
err_console = Console(stderr=True)


def _fail(msg: str):
    err_console.print(f"[bold red]error:[/] {msg}")
    raise typer.Exit(code=2)


@app.command()
def run(
    config: Path = typer.Argument(None, help="TOML configuration; without it a built-in default runs."),
    out: Path = typer.Option(Path("edmd-run"), "--out", "-o", help="Run directory for config, thermo, trajectory."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show a progress bar."),
):
    """Run a simulation and write its run directory."""
    from .engine import EngineError
    from .runner import run_directory

    try:
        cfg = load_config(config) if config is not None else Config()
        if config is None:
            console.print("[dim]no config given: running the built-in default (3D hard-sphere fluid, N = 4000, eta = 0.3)[/]")
        summary = run_directory(cfg, out, progress=progress and cfg.run.progress)
    except (ConfigError, StateError, ValueError, EngineError) as exc:
        _fail(str(exc))
    table = Table(title=f"edmd run -> {out}", show_header=False)
    for key in ("time", "collisions", "events", "temperature", "pressure_mean", "collisions_per_second", "particle_steps_per_second", "neighbours"):
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


tables_app = typer.Typer(no_args_is_help=True, help="Lookup tables of the matrix of restitution (soft contacts).")
app.add_typer(tables_app, name="tables")


@tables_app.command("build")
def tables_build(
    model: str = typer.Option(..., "--model", "-m", help="Contact model: dashpot or hertz."),
    ranges: str = typer.Option("", "--ranges", "-r", help="Box, e.g. 'damping=0:0.5,log10_softness=-6:-0.7,b=0:0.99' (missing keys: the model's default)."),
    shape: str = typer.Option("", "--shape", help="Nodes per axis, e.g. '17,41,49' (default: the model's default)."),
    workers: int = typer.Option(0, "--workers", "-j", help="Processes (0: all cores)."),
    out: Path = typer.Option(None, "--out", "-o", help="Output .npz file (default: restitution_MODEL.npz)."),
    check: int = typer.Option(2000, "--check", help="Random points to check against the direct solver afterwards (0: skip)."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show a progress bar."),
):
    """Build a table by direct solves spread over processes, save it and check its accuracy."""
    from .tables import Box, TableError, build_table, check_table

    try:
        box = Box.parse(ranges, model)
        dims = tuple(int(x) for x in shape.split(",")) if shape else None
        tab = build_table(model, box, dims, workers=workers or None, progress=progress)
    except (TableError, ValueError) as exc:
        _fail(str(exc))
    path = out or Path(f"restitution_{tab.model}.npz")
    tab.save(path)
    console.print(f"wrote {path}: {tab!r} in {tab.meta['build_seconds']:.3g} s")
    if check:
        _print_check(check_table(tab, check))


@tables_app.command("check")
def tables_check(
    path: Path = typer.Argument(..., help="A table file (.npz)."),
    points: int = typer.Option(10_000, "--points", "-n", help="Random points in the box."),
    sampling: str = typer.Option("log", "--sampling", help="Softness sampling: log or linear."),
    seed: int = typer.Option(0, "--seed"),
):
    """Largest relative error of a table against the direct solver at random points of its box."""
    from .tables import RestitutionTable, TableError, check_table

    try:
        _print_check(check_table(RestitutionTable.load(path), points, seed, sampling))
    except TableError as exc:
        _fail(str(exc))


@tables_app.command("info")
def tables_info(path: Path = typer.Argument(..., help="A table file (.npz).")):
    """Model, box, grid and provenance of a table file."""
    from .tables import RestitutionTable, TableError

    try:
        tab = RestitutionTable.load(path)
    except TableError as exc:
        _fail(str(exc))
    console.print(repr(tab))
    for key, value in sorted(tab.meta.items()):
        console.print(f"  {key}: {value}")


def _print_check(res: dict):
    table = Table(title=f"table vs direct solver, {res['points']} points ({res['sampling']} softness)", show_header=False)
    for key in ("Phi", "1-D", "tau_c", "eps_hat"):
        table.add_row(f"max relative error of {key}", f"{res[key]:.2e}")
    table.add_row("max relative error, all outputs", f"{res['max']:.2e}")
    table.add_row("worst point (damping, softness, b)", ", ".join(f"{x:.6g}" for x in res["worst_point"]))
    console.print(table)


def main():  # pragma: no cover
    app()
