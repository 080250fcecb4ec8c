"""From a validated :class:`~edmd.config.Config` to a finished run directory."""

from __future__ import annotations

import json
import math
import platform
from pathlib import Path

from .config import Config, dump_config
from .engine import EngineOptions
from .initial import lattice, maxwell_boltzmann, random_packing
from .simulation import Simulation
from .state import State
from .thermo import Thermo
from .trajectory import Trajectory


def build_state(cfg: Config) -> State:
    """The initial state described by ``[system]``."""
    s = cfg.system
    radius = s.radius if isinstance(s.radius, float) else s.radius.as_dict()
    common = dict(n=s.n, packing_fraction=s.packing_fraction, dim=s.dim, radius=radius, mass=s.mass, density=s.density, seed=s.seed)
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
        return DEMSimulation(state, contact, dt=i.dt, steps_per_contact=i.steps_per_contact, impact_speed=i.impact_speed, skin=i.skin)
    e = cfg.engine
    options = EngineOptions(neighbours=e.neighbours, skin=e.skin, resync_every=e.resync_every, events_per_bucket=e.events_per_bucket)
    return Simulation(state, e_n=cfg.collision.e_n, engine=options)


def run_directory(cfg: Config, out: str | Path, progress: bool | None = None) -> dict:
    """Run ``cfg`` writing ``config.toml``, ``thermo.csv``, ``trajectory.gsd`` and ``summary.json`` into ``out``.

    Returns the summary (also written as ``summary.json``).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.toml").write_text(dump_config(cfg))
    sim = build_simulation(cfg)
    interval = cfg.run.output_interval
    thermo = None
    for name in ("thermo.csv", "trajectory.gsd"):
        (out / name).unlink(missing_ok=True)
    if cfg.output.thermo:
        thermo = sim.add(Thermo(interval, path=out / "thermo.csv"))
    if cfg.output.trajectory:
        sim.add(Trajectory(out / "trajectory.gsd", cfg.output.trajectory_interval or interval))
    show = cfg.run.progress if progress is None else progress
    try:
        sim.run(until_time=cfg.run.until_time, max_events=cfg.run.max_events, wall_time=cfg.run.wall_time, progress=show)
    finally:
        sim.close()
    summary = summarize(sim, thermo)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
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
    if sim.engine.mode == "dem":
        summary["dt"] = sim.dt
        summary["particle_steps_per_second"] = st.n * sim.events / sim.wall_seconds if sim.wall_seconds > 0 else math.nan
    if thermo is not None and thermo.rows:
        rows = [r for r in thermo.rows if not math.isnan(r["pressure"])]
        if rows:
            summary["pressure_last"] = rows[-1]["pressure"]
            summary["pressure_mean"] = sum(r["pressure"] for r in rows) / len(rows)
    return summary
