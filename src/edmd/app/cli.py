"""Command line: ``edmd run``, ``edmd compress``, ``edmd init``, ``edmd sweep``, ``edmd export``, ``edmd plot``, ``edmd steady``, ``edmd transport``, ``edmd movie``, ``edmd tables``, ``edmd compile``."""

from __future__ import annotations

import collections
import contextlib
import logging
import warnings
from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from .config import EXAMPLE, ConfigError, default_job, load_config
from ..state import StateError

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Event-driven molecular dynamics of hard and soft spheres and disks.")
console = Console(soft_wrap=True)  # (messages name paths: the terminal wraps them, rich would break them mid-name)
err_console = Console(stderr=True, soft_wrap=True)
FRAME_OF_FROM = typer.Option(-1, "--frame", help="Frame of --from (negative counts from the end).")


def _warn(message, category, filename, lineno, file=None, line=None):
    """Warnings of a command as one readable line (not Python's file:line prefix)."""
    err_console.print(f"[bold yellow]warning:[/] {escape(str(message))}", soft_wrap=True)


def _check_output(path: Path, force: bool):
    """Stop (exit 2) before any work if ``path`` cannot be written: its folder is missing, or it
    exists and ``force`` is not given (a file of the user's, or of a run, is never replaced silently)."""
    if not path.parent.is_dir():
        _fail(f"cannot write {path}: there is no folder {path.parent}")
    if path.exists() and not force:
        _fail(f"{path} exists; use --force to overwrite it")


def _fail(msg: str):
    err_console.print(f"[bold red]error:[/] {escape(msg)}", soft_wrap=True)  # unbroken lines: paths stay greppable
    raise typer.Exit(code=2)


def _load_job(config: Path | None, start_from: Path | None, frame: int):
    """The configuration of a new run: a file or the built-in showcase, optionally started from a GSD frame."""
    if start_from is None and frame != -1:
        raise ConfigError(f"--frame {frame} picks a frame of --from FILE: give --from too")
    if config is not None:
        cfg = load_config(config)
    else:
        cfg = default_job()
        s, c = cfg.system, cfg.collision
        console.print(
            f"[dim]no config given: running the built-in showcase, a cooling granular gas "
            f"({s.dim}D, N = {s.n}, eta = {s.packing_fraction}, e_n = {c.e_n}, until t = {cfg.run.until_time:g})[/]"
        )
    if start_from is not None:
        if not start_from.is_file():
            raise StateError(f"--from: no file {start_from}")
        cfg.system.from_file = str(start_from.resolve())
        cfg.system.from_frame = frame
        console.print(f"[dim]initial state: frame {frame} of {start_from} (\\[system] settings are ignored)[/]")
    return cfg


@app.command()
def run(
    config: Path = typer.Argument(None, help="TOML configuration; without it the built-in showcase runs."),
    out: Path = typer.Option(None, "--out", "-o", help="Run directory for config, thermo, trajectory, checkpoint, plots [default: edmd-run]."),
    start_from: Path = typer.Option(None, "--from", help="Start from a frame of this GSD file (the \\[system] settings are then ignored)."),
    frame: int = FRAME_OF_FROM,
    restart: Path = typer.Option(None, "--restart", help="Continue the run in this directory from its checkpoint."),
    until_time: float = typer.Option(None, "--until-time", help="With --restart: new end time (simulation time)."),
    force: bool = typer.Option(False, "--force", help="Replace a run already in --out (all its files are removed first)."),
    max_memory: str = typer.Option(None, "--max-memory", help="Refuse to start above this estimated memory, e.g. 8G (default: the memory available)."),
    debug: bool = typer.Option(False, "--debug", help="Check every collision for overlaps (slow; sets \\[engine] debug)."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress (a bar on a terminal, a line every few percent otherwise)."),
):
    """Run a simulation and write its run directory (or continue one with --restart)."""
    from ..files.checkpoint import CheckpointError
    from ..run.engine import EngineError
    from .runner import restart_directory, run_directory

    try:
        with warnings.catch_warnings(), _announce_compiles():
            warnings.showwarning = _warn  # restored on exit (the CLI may run inside another program)
            if restart is not None:
                given = [name for name, x in (("CONFIG", config), ("--from", start_from), ("--frame", frame != -1 or None), ("--out", out),
                                              ("--force", force or None), ("--max-memory", max_memory), ("--debug", debug or None)) if x is not None]  # fmt: skip
                if given:
                    raise ConfigError(f"--restart continues a run directory in place with its own configuration: give no {', '.join(given)}")
                out = restart
                summary = restart_directory(restart, until_time=until_time, progress=None if progress else False)
            else:
                if until_time is not None:
                    raise ConfigError("--until-time goes with --restart; set [run] until_time in the configuration")
                out = Path("edmd-run") if out is None else out
                cfg = _load_job(config, start_from, frame)
                if debug:
                    cfg.engine.debug = True
                summary = run_directory(cfg, out, progress=progress and cfg.run.progress, force=force, max_memory=max_memory)
    except (ConfigError, StateError, CheckpointError, ValueError, OSError, EngineError) as exc:
        _fail(str(exc))
    except KeyboardInterrupt:
        err_console.print(f"[bold yellow]interrupted:[/] continue with `edmd run --restart {out}`")
        raise typer.Exit(code=130) from None
    table = Table(title=f"edmd run -> {out}", show_header=False)
    keys = ("time", "collisions", "events", "temperature", "collisions_per_second", "particle_steps_per_second", "neighbours", "checkpoint_time")
    pressures = [k for k in summary if k.endswith("pressure_mean")]
    for key in keys[:4] + tuple(pressures) + keys[4:]:
        if key in summary:
            v = summary[key]
            table.add_row(key, f"{v:.6g}" if isinstance(v, float) else str(v))
    console.print(table)


@app.command()
def compress(
    config: Path = typer.Argument(..., help="TOML configuration: its [system] gives the particles (and the target packing fraction)."),
    out: Path = typer.Option(Path("edmd-packing"), "--out", "-o", help="Directory for packing.gsd, compression.csv, summary.json and figures."),
    to: float = typer.Option(None, "--to", help="Target packing fraction (default: system.packing_fraction, unless --pressure or --jam)."),
    pressure: float = typer.Option(None, "--pressure", help="Target reduced pressure Z = PV/(NkT)."),
    jam: bool = typer.Option(False, "--jam", help="Compress to jamming: --pressure 1e12, contacts and rattlers reported."),
    rate: float = typer.Option(None, "--rate", help="Growth rate g, R(t) = R(0)(1 + g t) (default: system.compress_rate)."),
    gap: float = typer.Option(None, "--gap", help="With --pressure or --jam: contacts are pairs whose relative gap r/sigma - 1 is below this (default 1e-9)."),
    film: str = typer.Option(None, "--film", help="Squeeze a film between the walls of this axis (in [walls] axes) to --to, by a wall moving in."),
    speed: float = typer.Option(None, "--speed", help="With --film: the wall's speed (default 0.05)."),
    start_from: Path = typer.Option(None, "--from", help="Compress a frame of this GSD file instead of a random start (kT and the default target still come from \\[system])."),
    frame: int = FRAME_OF_FROM,
    force: bool = typer.Option(False, "--force", help="Replace a packing already in --out."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show a progress bar on the packing fraction."),
):
    """Compress particles by Lubachevsky-Stillinger growth to a packing fraction, a pressure or jamming
    (or squeeze a film between walls, --film)."""
    from ..run.compress import JAMMED
    from ..run.engine import EngineError
    from .packings import compress_directory
    from .runner import RunDirectoryError

    if jam:
        if pressure is not None:
            _fail("give --jam or --pressure, not both (--jam is --pressure 1e12)")
        pressure = JAMMED
    conflicts = (
        (gap is not None and pressure is None, "--gap goes with --pressure or --jam"),
        (speed is not None and film is None, "--speed goes with --film"),
        (rate is not None and film is not None, "--rate is the growth rate: a film keeps its particles' size (its wall moves at --speed)"),
    )
    for bad, message in conflicts:
        if bad:
            _fail(message)
    try:
        cfg = _load_job(config, start_from, frame)
        with _compression_bar(to or (cfg.system.packing_fraction if pressure is None else None), pressure, progress and film is None) as bar:
            summary = compress_directory(
                cfg, out, packing_fraction=to, pressure=pressure, rate=rate, gap=1e-9 if gap is None else gap, force=force, progress=bar, film=film,
                speed=0.05 if speed is None else speed,
            )
    except (ConfigError, StateError, RunDirectoryError, ValueError, OSError, EngineError) as exc:
        _fail(str(exc))
    table = Table(title=f"edmd compress -> {out}", show_header=False)
    for key, value in summary.items():
        table.add_row(key, f"{value:.6g}" if isinstance(value, float) else str(value))
    console.print(table)


@contextlib.contextmanager
def _compression_bar(packing_fraction: float | None, pressure: float | None, show: bool):
    """A rich progress bar on the packing fraction (towards a pressure target: on log Z); yields its update callback."""
    if not show:
        yield None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(), console=err_console, transient=True) as bar:
        total = packing_fraction if packing_fraction is not None else float(np.log10(pressure))
        task = bar.add_task("compressing", total=total)

        def update(phi: float, z: float):
            done = phi if packing_fraction is not None else float(np.log10(max(z, 1.0)))
            bar.update(task, completed=min(done, total), description=f"phi = {phi:.6f}  Z = {z:.4g}")

        yield update


@app.command()
def export(
    source: Path = typer.Argument(..., help="A GSD file or a run directory (its trajectory.gsd)."),
    output: Path = typer.Argument(..., help="Output file: .xyz (extended XYZ: ASE, OVITO) or .csv."),
    frame: int = typer.Option(-1, "--frame", help="Frame to export (negative counts from the end)."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
):
    """Export one frame as extended XYZ or CSV."""
    from ..files.export import export_frame

    _check_output(output, force)
    try:
        state = export_frame(source, output, frame)
    except (StateError, ValueError, OSError) as exc:
        _fail(str(exc))
    console.print(f"wrote {output} (t = {state.time:g}, N = {state.n})")


@app.command()
def plot(
    run_dir: Path = typer.Argument(Path("edmd-run"), help="A run directory written by `edmd run`."),
    color: str = typer.Option("speed", "--color", help="Snapshot colouring: 'speed' or 'spin'."),
):
    """Write the standard figures (PNG) of a run directory into it."""
    from .plots import plot_run

    try:
        files = plot_run(run_dir, color_by=color)
    except (StateError, ValueError, OSError) as exc:
        _fail(str(exc))
    for f in files:
        console.print(f"wrote {f}")


@app.command()
def steady(
    run_dir: Path = typer.Argument(Path("edmd-run"), help="A run directory written by `edmd run`."),
    settle: float = typer.Option(0.0, "--settle", help="Ignore the approach: rows and frames before this time."),
    columns: list[str] = typer.Option(["temperature", "pressure"], "--column", "-c", help="thermo.csv columns to average (repeat the option)."),
    profile: str = typer.Option(None, "--profile", help="Also write density, temperature and velocity profiles along this axis (x, y or z) from the trajectory (CSV and PNG)."),
    bins: int = typer.Option(20, "--bins", min=1, help="Bins of the profile."),
    impacts: bool = typer.Option(False, "--impacts", help="Also the vibrating wall's phase at impact (wall_impacts.csv of [output] wall_impacts)."),
):
    """Steady-state averages with blocking error bars (thermo.csv), profiles along an axis, and
    the impact phases at a vibrating wall."""
    from ..analysis.steady import Profile, SteadyState
    from ..files.atomic import atomic_path
    from .plots import plot_profile, save
    from ..files.trajectory import iter_states

    try:
        table = Table(title=f"steady state of {run_dir} (t >= {settle:g})")
        for name in ("column", "mean", "error", "samples", "converged"):
            table.add_column(name)
        for column in columns:
            s = SteadyState(settle=settle).compute(run_dir / "thermo.csv", column)
            table.add_row(column, f"{s.mean:.6g}", f"{s.error:.2g}", str(s.samples), "yes" if s.converged else "no: longer run")
        console.print(table)
        if profile is not None:
            frames = (st for st in iter_states(run_dir / "trajectory.gsd", check_overlaps=False) if st.time >= settle)
            p = Profile(profile, bins=bins).compute(frames)
            dim = p.velocity.shape[1]
            head = ",".join([profile, "density", "temperature", *(f"velocity_{a}" for a in "xyz"[:dim])])
            out = run_dir / f"profile_{profile}.csv"
            with atomic_path(out) as tmp:
                np.savetxt(tmp, np.column_stack([p.centres, p.density, p.temperature, p.velocity]), fmt="%.17g", delimiter=",", header=head, comments="")
            figure = save(plot_profile(p), out.with_suffix(".png"))
            console.print(f"wrote {out} and {figure.name} ({p.frames} frames)")
        if impacts:
            imp = _impact_phases(run_dir, settle)
            figure = save(imp.plot(), run_dir / "impact_phases.png")
            console.print(
                f"{imp.times.size} impacts on the vibrating wall: {imp.rate:.6g} per unit time, mean impact speed "
                f"{imp.mean_speed:.6g}, most frequent phase {0.5 * (imp.phase_edges[imp.phase_pdf.argmax()] + imp.phase_edges[imp.phase_pdf.argmax() + 1]):.4g} rad; wrote {figure.name}"
            )
    except (StateError, ValueError, OSError) as exc:
        _fail(str(exc))


@app.command()
def transport(
    run_dir: Path = typer.Argument(Path("edmd-run"), help="A run directory written by `edmd run` (an equilibrium run)."),
    settle: float = typer.Option(0.0, "--settle", help="Ignore rows and frames before this time (equilibration)."),
    lag_max: float = typer.Option(4.0, "--lag-max", help="Longest lag (time) of the Helfand moment and the MSD."),
    fit_from: float = typer.Option(None, "--fit-from", help="Shortest fitted lag (default: half of --lag-max)."),
    blocks: int = typer.Option(5, "--blocks", min=2, help="Parts of the run for the error bars."),
):
    """Shear viscosity and thermal conductivity (Einstein-Helfand, thermo.csv's pressure tensor and
    energy flux) and self-diffusion (MSD of trajectory.gsd) with block error bars, beside Enskog's
    values; writes viscosity.png and conductivity.png."""
    from ..analysis.transport import SelfDiffusion, ShearViscosity, ThermalConductivity
    from ..files.trajectory import iter_states, read_state
    from .plots import save

    try:
        path = run_dir / "trajectory.gsd"
        if not path.exists():
            raise ValueError(f"{path} does not exist: the transport coefficients need the run's trajectory")
        state = read_state(path, check_overlaps=False)
        table = Table(title=f"transport coefficients of {run_dir} (t > {settle:g}, T = {state.temperature():.6g})")
        for name in ("coefficient", "value", "error", "Enskog", "ratio"):
            table.add_column(name)
        options = {"t_min": settle, "lag_max": lag_max, "fit_from": fit_from, "blocks": blocks}
        frames = [s for s in iter_states(path, check_overlaps=False) if s.time > settle]
        if len(frames) > 2 and not np.isclose(frames[-1].time - frames[-2].time, frames[1].time - frames[0].time, rtol=1e-9):
            frames.pop()  # (the final frame a run always writes, off the grid of the others)
    except (StateError, ValueError, OSError) as exc:
        _fail(str(exc))
    coefficients = (
        ("shear viscosity", "viscosity", lambda: ShearViscosity(**options).compute(run_dir / "thermo.csv", state)),
        ("thermal conductivity", "conductivity", lambda: ThermalConductivity(**options).compute(run_dir / "thermo.csv", state)),
        ("self-diffusion", "diffusion", lambda: SelfDiffusion(**options).compute(frames)),
    )
    problems, written = [], []
    for name, attribute, compute in coefficients:  # each on its own: one that does not apply leaves the others
        try:
            a = compute()
        except (StateError, ValueError, OSError) as exc:
            problems.append(f"{name}: {exc}")
            table.add_row(name, "-", "-", "-", "-")
            continue
        value = getattr(a, attribute)
        table.add_row(name, f"{value:.6g}", f"{a.error:.2g}", f"{a.enskog:.6g}", f"{value / a.enskog:.4g}")
        if attribute != "diffusion":
            written.append(save(a.plot(), run_dir / f"{attribute}.png").name)
    console.print(table)
    if written:
        console.print(f"wrote {' and '.join(written)}")
    if problems:
        _fail("; ".join(problems))


@app.command()
def shear(
    run_dir: Path = typer.Argument(Path("edmd-run"), help="A run directory of a sheared run (`edmd run` with [shear])."),
    settle: float = typer.Option(0.0, "--settle", help="Ignore rows and frames before this time (the approach to the steady state)."),
    bins: int = typer.Option(10, "--bins", min=2, help="Bins of the velocity profile along y."),
):
    """Steady uniform shear flow: temperature, pressure tensor, viscosity -P_xy / rate and the reduced
    shear rate a* from thermo.csv, beside the kinetic theory of the steady state (constant e_n);
    the velocity profile from trajectory.gsd. Writes shear_stress.png and shear_profile.png."""
    from ..analysis.shear import ShearFlow
    from ..analysis.steady import Profile
    from ..files.trajectory import iter_states, read_state
    from .plots import save

    try:
        cfg = load_config(run_dir / "config.toml")
        if cfg.shear is None:
            raise ValueError(f"{run_dir} is not a sheared run (no [shear] in its config.toml)")
        rate = cfg.shear.rate
        state = read_state(run_dir / "trajectory.gsd", check_overlaps=False)
        flow = ShearFlow(rate, settle=settle).compute(run_dir / "thermo.csv", state)
        frames = [s for s in iter_states(run_dir / "trajectory.gsd", check_overlaps=False) if s.time >= settle]
        profile = Profile("y", bins=bins).compute(frames)
    except (StateError, ValueError, OSError, ConfigError) as exc:
        _fail(str(exc))
    table = Table(title=f"uniform shear flow of {run_dir} (rate {rate:g}, t >= {settle:g})")
    for name in ("quantity", "value", "error", "reduced (/ n k_B T)"):
        table.add_column(name)
    table.add_row("temperature", f"{flow.temperature:.6g}", f"{flow.temperature_error:.2g}", "")
    for name, value in flow.pressure.items():
        table.add_row(f"P_{name}", f"{value:.6g}", f"{flow.pressure_error[name]:.2g}", f"{flow.reduced_pressure[name]:.5g}")
    table.add_row("viscosity -P_xy / rate", f"{flow.viscosity:.6g}", f"{flow.viscosity_error:.2g}", "")
    table.add_row("reduced shear rate a*", f"{flow.reduced_rate:.5g}", "", "")
    for name, value in _usf_theory(cfg, state, flow):
        table.add_row(name, f"{value:.5g}", "", "")
    console.print(table)
    slope = np.polyfit(profile.centres, profile.velocity[:, 0], 1)[0]
    console.print(f"velocity profile: d<v_x>/dy = {slope:.5g} (rate {rate:g}) over {profile.frames} frames")
    written = [save(flow.plot(), run_dir / "shear_stress.png").name, save(_profile_plot(profile, rate), run_dir / "shear_profile.png").name]
    console.print(f"wrote {' and '.join(written)}")


def _usf_theory(cfg, state, flow) -> list[tuple[str, float]]:
    """Rows of the kinetic-theory references of a sheared run: Grad's steady uniform shear flow
    for smooth particles of constant restitution (monodisperse), Enskog's viscosity for elastic ones."""
    from ..analysis.shear import usf_grad, usf_temperature
    from ..analysis.transport import enskog_viscosity
    from .plots import usf_restitution

    e_n = usf_restitution(cfg, state)
    if e_n is None:
        return []
    sigma, m = 2.0 * float(state.radius[0]), float(state.mass[0])
    if e_n == 1.0:
        enskog = enskog_viscosity(state.packing_fraction, state.dim, sigma, m, flow.temperature)
        return [("Enskog viscosity", enskog), ("viscosity / Enskog", flow.viscosity / enskog)]
    grad = usf_grad(e_n, state.dim)
    return [
        ("Grad theory a*", grad["a"]),
        ("Grad theory P*_xy", grad["xy"]),
        ("Grad theory temperature", usf_temperature(cfg.shear.rate, state.packing_fraction, e_n, state.dim, sigma, m)),
    ]


def _profile_plot(profile, rate: float):
    """The mean v_x against y with the imposed profile rate * y."""
    from ..analysis._common import axes

    ax = axes(None)
    ax.plot(profile.centres, profile.velocity[:, 0], "o", label=r"$\langle v_x\rangle$")
    ax.plot(profile.centres, rate * profile.centres, "k-", lw=1, label=rf"$\dot\gamma y$, $\dot\gamma = {rate:g}$")
    ax.set_xlabel("y")
    ax.set_ylabel(r"mean $v_x$")
    ax.legend(fontsize="small")
    return ax


def _impact_phases(run_dir: Path, settle: float):
    """:class:`edmd.analysis.ImpactPhases` of a run directory's wall_impacts.csv after ``settle``."""
    from ..analysis.collisions import ImpactPhases
    from ..files.impacts import read_wall_impacts
    from .config import load_config

    cfg = load_config(run_dir / "config.toml")
    if cfg.vibration is None:
        raise ValueError(f"{run_dir} has no vibrating wall ([vibration] in its config.toml)")
    path = run_dir / "wall_impacts.csv"
    if not path.exists():
        raise ValueError(f"{path} does not exist: run with [output] wall_impacts = true")
    rows = read_wall_impacts(path)
    rows = rows[rows[:, 0] >= settle]
    log = np.column_stack([rows[:, 0], rows[:, 1], -1.0 - rows[:, 2], rows[:, 3], rows[:, 4]])
    return ImpactPhases().compute(log, cfg.vibration.build())


@app.command()
def movie(
    source: Path = typer.Argument(Path("edmd-run"), help="A run directory (its trajectory.gsd) or a GSD file."),
    out: Path = typer.Option(None, "--out", "-o", help="Movie file: .gif, or .mp4 (needs ffmpeg). Default: movie.gif in the run directory."),
    color: str = typer.Option("speed", "--color", help="Colouring: 'speed' (|v| / rms speed) or 'density' (local packing fraction)."),
    fps: int = typer.Option(10, "--fps", min=1, help="Frames per second."),
    frames: int = typer.Option(None, "--frames", min=1, help="At most this many frames (every k-th trajectory frame)."),
    max_particles: int = typer.Option(20_000, "--max-particles", min=1, help="Draw at most this many particles (a fixed random subset)."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing --out file (the default movie.gif of a run is always replaced)."),
):
    """Make a movie of a 2D run or of the z = 0 slab of a 3D run, coloured by speed or local density."""
    from .movie import make_movie

    if out is not None:
        _check_output(out, force)
    try:
        path = make_movie(source, out, color_by=color, fps=fps, frames=frames, max_particles=max_particles)
    except (StateError, ValueError, OSError) as exc:
        _fail(str(exc))
    console.print(f"wrote {path}")


class _CompileNotice(logging.Handler):
    """Prints the engine's notice that a run compiles its loop variant (``edmd.compile`` logger)."""

    def emit(self, record):
        console.print(f"[dim]{escape(record.getMessage())}[/]", soft_wrap=True)


@contextlib.contextmanager
def _announce_compiles():
    """Print compile notices while the command runs (removed after: the CLI may run inside another program)."""
    logger = logging.getLogger("edmd.compile")
    level = logger.level
    handler = _CompileNotice()
    logger.setLevel(logging.INFO)
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


@app.command("compile")
def compile_(
    features: list[str] = typer.Argument(None, help="Feature sets, e.g. plain walls+rough emdstar (default: plain)."),
    all_: bool = typer.Option(False, "--all", help="Every feature set (142 variants with both neighbour structures, an hour or more)."),
    neighbours: str = typer.Option("both", "--neighbours", help="cells, list or both (what neighbours='auto' may pick)."),
):
    """Compile the event loop ahead of time for these feature sets (for a cluster image, sweep workers or CI).

    Features: plain, or walls, rough, soft (viscoelastic), emdstar, bath, noise, vibration, well, grow,
    shear joined by '+'; each with the neighbour structures asked for (well and grow: lists only).
    Debug mode needs no variant of its own.
    """
    from .precompile import LISTS_ONLY, FeatureError, all_feature_sets, compile_features, neighbour_structures, parse_features

    try:
        sets = all_feature_sets() if all_ else [parse_features(f) for f in (features or ["plain"])]
        jobs = [(found, mode) for found in sets for mode in neighbour_structures(found, neighbours)]
    except FeatureError as exc:
        _fail(str(exc))
    if not jobs:
        _fail(f"no variant to compile: {', '.join(sorted(LISTS_ONLY))} run with lists only")
    for found, mode in jobs:
        with console.status(f"compiling {'+'.join(sorted(found)) or 'plain'} ({mode}) ..."):
            name, seconds, cached = compile_features(found, mode)
        console.print(f"{name}: {'already cached' if cached else 'compiled'} ({seconds:.1f} s)")


@app.command()
def init(
    path: Path = typer.Argument(Path("edmd.toml"), help="Where to write the example configuration."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing file."),
):
    """Write a commented example configuration."""
    _check_output(path, force)
    path.write_text(EXAMPLE)
    console.print(f"wrote {path}")


@app.command()
def sweep(
    sweep_file: Path = typer.Argument(None, help="Sweep file (TOML): a base configuration and a \\[grid] and/or \\[\\[points]] of overrides."),
    out: Path = typer.Option(None, "--out", "-o", help="Sweep directory (default: <sweep file name>-sweep)."),
    workers: int = typer.Option(None, "--workers", "-w", min=1, help="Local worker processes, or the --dask cluster size (default: one per core this process may use)."),
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


tables_app = typer.Typer(no_args_is_help=True, help="Lookup tables of the matrix of restitution (soft contacts).")
app.add_typer(tables_app, name="tables")


@tables_app.command("build")
def tables_build(
    model: str = typer.Option(..., "--model", "-m", help="Contact model: dashpot or hertz."),
    ranges: str = typer.Option("", "--ranges", "-r", help="Box, e.g. 'damping=0:0.5,log10_softness=-6:-0.7,b=0:0.99' (missing keys: the model's default)."),
    shape: str = typer.Option("", "--shape", help="Nodes per axis, e.g. '17,41,49' (default: the model's default)."),
    workers: int = typer.Option(0, "--workers", "-j", help="Processes (0: one per core this process may use)."),
    out: Path = typer.Option(None, "--out", "-o", help="Output .npz file (default: restitution_MODEL.npz)."),
    check: int = typer.Option(2000, "--check", min=0, help="Random points to check against the direct solver afterwards (0: skip)."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show a progress bar."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
):
    """Build a table by direct solves spread over processes, save it and check its accuracy."""
    from ..physics.tables import Box, TableError, build_table, check_table

    _check_output(out or Path(f"restitution_{model}.npz"), force)  # (before the build: it takes minutes)
    try:
        box = Box.parse(ranges, model)
        try:
            dims = tuple(int(x) for x in shape.split(",")) if shape else None
        except ValueError:
            raise ValueError(f"--shape must be whole numbers of nodes per axis separated by commas, e.g. '17,41,49', got {shape!r}") from None
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
    points: int = typer.Option(10_000, "--points", "-n", min=1, help="Random points in the box."),
    sampling: str = typer.Option("log", "--sampling", help="Softness sampling: log or linear."),
    seed: int = typer.Option(0, "--seed"),
):
    """Largest relative error of a table against the direct solver at random points of its box."""
    from ..physics.tables import RestitutionTable, TableError, check_table

    try:
        _print_check(check_table(RestitutionTable.load(path), points, seed, sampling))
    except TableError as exc:
        _fail(str(exc))


@tables_app.command("info")
def tables_info(path: Path = typer.Argument(..., help="A table file (.npz).")):
    """Model, box, grid and provenance of a table file."""
    from ..physics.tables import RestitutionTable, TableError

    try:
        tab = RestitutionTable.load(path)
    except TableError as exc:
        _fail(str(exc))
    console.print(repr(tab))
    for key, value in sorted(tab.meta.items()):
        console.print(f"  {key}: {value}")


@tables_app.command("plot")
def tables_plot(
    path: Path = typer.Argument(None, help="A table file (.npz); or --model for a default table."),
    model: str = typer.Option(None, "--model", "-m", help="Draw the default table of this contact model: dashpot or hertz."),
    out: Path = typer.Option(None, "--out", "-o", help="Output PNG (default: restitution_MODEL.png, or the table file's name with .png)."),
    damping: str = typer.Option("", "--damping", "-d", help="Damping values, one row each, e.g. '0,0.1,0.3' (default: low, middle, high end of the table)."),
):
    """Draw Phi, eps_hat, D and tau_c of a table against softness and eccentricity, one row per damping."""
    from .tableplot import plot_table
    from ..physics.tables import TableError, default_table

    if (path is None) == (model is None):
        _fail("give a table file or --model dashpot|hertz (not both)")
    out = out or (path.with_suffix(".png") if path is not None else Path(f"restitution_{model}.png"))
    try:
        values = [float(x) for x in damping.split(",")] if damping else None
    except ValueError:
        _fail(f"--damping must be numbers separated by commas, got {damping!r}")
    try:
        plot_table(path if path is not None else default_table(model), damping=values, out=out)
    except (TableError, OSError) as exc:
        _fail(str(exc))
    console.print(f"wrote {out}")


def _print_check(res: dict):
    table = Table(title=f"table vs direct solver, {res['points']} points ({res['sampling']} softness)", show_header=False)
    for key in ("Phi", "1-D", "tau_c", "eps_hat"):
        table.add_row(f"max relative error of {key}", f"{res[key]:.2e}")
    table.add_row("max relative error, all outputs", f"{res['max']:.2e}")
    table.add_row("worst point (damping, softness, b)", ", ".join(f"{x:.6g}" for x in res["worst_point"]))
    console.print(table)


def main():  # pragma: no cover
    app()
