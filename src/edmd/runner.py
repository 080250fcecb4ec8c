"""From a validated :class:`~edmd.config.Config` to a finished run directory, and restarts."""

from __future__ import annotations

import json
import math
import platform
import tomllib
from pathlib import Path

from ._io import write_text
from .checkpoint import Checkpoint, CheckpointError, load_checkpoint, read_checkpoint
from .config import Config, ConfigError, dump_config, parse_config
from .engine import EngineOptions
from .initial import lattice, maxwell_boltzmann, random_packing
from .simulation import Observer, Simulation
from .state import State
from .thermo import Thermo
from .trajectory import Trajectory, read_state

#: files a run writes into its directory (removed when a new run starts there)
RUN_FILES = ("thermo.csv", "trajectory.gsd", "checkpoint.gsd", "summary.json")


def build_state(cfg: Config) -> State:
    """The initial state described by ``[system]`` (or read from ``system.from_file``)."""
    s = cfg.system
    if s.from_file is not None:
        soft = cfg.integrator.kind == "dem" or cfg.collision.rule == "emdstar"  # soft particles may overlap
        return read_state(s.from_file, s.from_frame, check_overlaps=not soft)
    radius = s.radius if isinstance(s.radius, float) else s.radius.as_dict()
    periodic = [axis not in cfg.walls.axes for axis in "xyz"[: s.dim]]
    common = dict(
        n=s.n, packing_fraction=s.packing_fraction, dim=s.dim, radius=radius, mass=s.mass, density=s.density, seed=s.seed, periodic=periodic
    )
    if s.init == "lattice":
        state = lattice(kind=s.lattice, **common)
    else:
        state = random_packing(aspect=s.aspect, **common)
    return maxwell_boltzmann(state, s.kT, seed=s.seed + 1)


def build_simulation(cfg: Config, state: State | None = None) -> Simulation:
    """A :class:`Simulation` for ``cfg`` (from ``state`` if given, else from ``[system]``).

    With ``[integrator] kind = "dem"`` it is a :class:`~edmd.dem.DEMSimulation` with the
    ``[contact]`` law.
    """
    state = build_state(cfg) if state is None else state
    if cfg.integrator.kind == "dem":
        from .dem import DEMSimulation

        i = cfg.integrator
        contact = cfg.contact.build(float(state.mass.mean()))
        return DEMSimulation(
            state, contact, dt=i.dt, steps_per_contact=i.steps_per_contact, impact_speed=i.impact_speed, gravity=cfg.system.gravity, skin=i.skin
        )
    e = cfg.engine
    options = EngineOptions(neighbours=e.neighbours, skin=e.skin, resync_every=e.resync_every, events_per_bucket=e.events_per_bucket)
    rule = cfg.collision.build(float(state.mass.mean()))
    walls = cfg.walls.build(cfg.collision.material(), getattr(rule, "contact", None))
    return Simulation(state, collision=rule, walls=walls, gravity=cfg.system.gravity, engine=options)


def make_observers(cfg: Config, out: Path) -> list[Observer]:
    """The observers ``[output]`` asks for, writing into ``out`` (same list for runs and restarts)."""
    interval = cfg.run.output_interval
    o = cfg.output
    observers: list[Observer] = []
    if o.thermo:
        observers.append(Thermo(interval, path=out / "thermo.csv"))
    if o.trajectory:
        observers.append(Trajectory(out / "trajectory.gsd", o.trajectory_interval or interval))
    if o.checkpoint and cfg.integrator.kind != "dem":  # the DEM has no checkpoints (yet)
        meta = {"config": dump_config(cfg)}
        observers.append(Checkpoint(out / "checkpoint.gsd", o.checkpoint_interval or interval, o.checkpoint_wall_interval, metadata=meta))
    return observers


def run_directory(cfg: Config, out: str | Path, progress: bool | None = None) -> dict:
    """Run ``cfg`` writing ``config.toml``, ``thermo.csv``, ``trajectory.gsd``, ``checkpoint.gsd``,
    plots and ``summary.json`` into ``out`` (files of an earlier run there are replaced).

    Returns the summary (also written as ``summary.json``).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sim = build_simulation(cfg)
    write_text(out / "config.toml", dump_config(cfg))
    for name in RUN_FILES:
        (out / name).unlink(missing_ok=True)
    for observer in make_observers(cfg, out):
        sim.add(observer)
    return _execute(sim, cfg, out, progress)


def restart_config(out: str | Path) -> Config:
    """The configuration stored in the checkpoint of run directory ``out``."""
    out = Path(out)
    if not out.is_dir():
        raise CheckpointError(f"no run directory {out}")
    data = read_checkpoint(out / "checkpoint.gsd")
    text = data.metadata.get("config")
    if text is None:
        raise CheckpointError(f"{out / 'checkpoint.gsd'} was not written by `edmd run` (no configuration inside)")
    try:
        return parse_config(tomllib.loads(text))
    except (tomllib.TOMLDecodeError, ConfigError) as exc:
        raise CheckpointError(f"{out / 'checkpoint.gsd'}: the stored configuration is damaged: {exc}") from None


def restart_directory(out: str | Path, until_time: float | None = None, progress: bool | None = None) -> dict:
    """Continue the run in directory ``out`` from its checkpoint, bit for bit (optionally to a new end time).

    Rows and frames the interrupted run wrote after its last checkpoint are dropped and
    written again, identically. Budgets (``run.max_events``, ``run.wall_time``) apply afresh.
    """
    out = Path(out)
    cfg = restart_config(out)
    if until_time is not None:
        try:
            cfg.run.until_time = until_time
        except ValueError as exc:
            raise ConfigError(f"until_time: {exc}") from None
    sim = load_checkpoint(out / "checkpoint.gsd", make_observers(cfg, out))
    write_text(out / "config.toml", dump_config(cfg))
    return _execute(sim, cfg, out, progress)


def _execute(sim: Simulation, cfg: Config, out: Path, progress: bool | None) -> dict:
    show = cfg.run.progress if progress is None else progress
    until = max(cfg.run.until_time, sim.time)
    try:
        sim.run(until_time=until, max_events=cfg.run.max_events, wall_time=cfg.run.wall_time, progress=show)
    finally:
        sim.close()
    summary = summarize(sim, next((o for o in sim.observers if isinstance(o, Thermo)), None))
    if cfg.output.plots:
        from .plots import plot_run

        summary["plots"] = [p.name for p in plot_run(out)]
    write_text(out / "summary.json", json.dumps(summary, indent=2))
    return summary


def summarize(sim: Simulation, thermo: Thermo | None) -> dict:
    """Final numbers of a run: counters, speed, last thermo row and machine info."""
    st = sim.state
    summary = {
        "time": sim.time,
        "n": st.n,
        "dim": st.dim,
        "events": sim.events,
        "collisions": sim.collisions,
        "wall_seconds": sim.wall_seconds,
        "collisions_per_second": sim.collisions / sim.wall_seconds if sim.wall_seconds > 0 else math.nan,
        "temperature": st.temperature(),
        "kinetic_energy": st.kinetic_energy(),
        "neighbours": sim.engine.mode,
        "machine": platform.platform(),
    }
    if sim.engine.emd_rule is not None:
        summary.update(sim.engine.emd_counters())
    if sim.engine.mode == "dem":
        summary["dt"] = sim.dt
        summary["particle_steps_per_second"] = st.n * sim.events / sim.wall_seconds if sim.wall_seconds > 0 else math.nan
    written = [o.last_written for o in sim.observers if isinstance(o, Checkpoint) and o.last_written is not None]
    if written:
        summary["checkpoint_time"] = written[-1]
    if thermo is not None and thermo.rows:
        rows = [r for r in thermo.rows if not math.isnan(r["pressure"])]
        if rows:
            summary["pressure_last"] = rows[-1]["pressure"]
            summary["pressure_mean"] = sum(r["pressure"] for r in rows) / len(rows)
    return summary
