"""Command line: ``edmd run``, ``edmd init``."""

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


def main():  # pragma: no cover
    app()
