"""From a validated :class:`~edmd.app.config.Config` to a finished run directory, and restarts."""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import math
import os
import platform
import tomllib
import warnings
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no advisory locks, directories are not guarded
    fcntl = None

import numpy as np
from pydantic import ValidationError

from ..files.atomic import atomic_path, write_atomic
from ..files.checkpoint import Checkpoint, CheckpointData, CheckpointError, load_checkpoint, read_checkpoint, save_final_state
from .config import Config, ConfigError, dump_config, format_errors, ignored_keys, parse_config
from ..run.engine import EngineError, EngineOptions
from ..run.memory import check_memory
from ..initial import lattice, maxwell_boltzmann, random_packing, replicate
from ..run.observer import Observer
from ..run.compress import at_radii, compress
from ..run.simulation import Simulation
from ..state import State
from ..files.thermo import Thermo, read_thermo
from ..files.impacts import WallImpacts
from ..files.trajectory import Trajectory, frame_size, read_state, trajectory_run_id, write_state

#: files a run writes into its directory
RUN_FILES = ("config.toml", "thermo.csv", "trajectory.gsd", "checkpoint.gsd", "summary.json", "error_state.gsd", "wall_impacts.csv")
#: the figures, movies and analysis tables edmd writes into a run directory (``edmd plot``,
#: ``movie``, ``steady``, ``transport``, ``shear``); other files there are the user's: they neither
#: make the directory a run nor are removed with it
RUN_FIGURES = (
    tuple(
        f"{stem}.png"
        for stem in ("temperature", "pressure", "emd_exceptions", "height", "energy", "velocity_distribution", "rdf", "msd", "snapshot", "impact_phases")
        + ("viscosity", "conductivity", "shear_stress", "shear_profile")
        + tuple(f"profile_{axis}" for axis in "xyz")
    )
    + tuple(f"profile_{axis}.csv" for axis in "xyz")
    + ("movie.gif", "movie.mp4")
)
#: the lock a run or restart holds on its directory while it writes there (never removed: removing
#: it would let a second process lock a new file while a third still holds the old one)
LOCK_FILE = ".edmd.lock"
#: configuration keys that may change when a run is continued (they do not change its physics)
RESTART_MUTABLE = ("run.until_time", "run.max_events", "run.wall_time", "run.progress", "output.plots")
_ID_LINE = "# edmd run id: "


class RunDirectoryError(ValueError):
    """A run directory that cannot be written or continued as asked (the message says why and what to do)."""


def build_state(cfg: Config) -> State:
    """The initial state described by ``[system]`` (or read from ``system.from_file``)."""
    s = cfg.system
    if s.from_file is not None:
        soft = cfg.integrator.kind == "dem" or cfg.collision.rule == "emdstar"  # soft particles may overlap
        return read_state(s.from_file, s.from_frame, check_overlaps=not soft)
    if s.replicate is not None:
        copies = math.prod(s.replicate)
        base = cfg.model_copy(update={"system": s.model_copy(update={"n": s.n // copies, "replicate": None})})
        return maxwell_boltzmann(replicate(build_state(base), s.replicate), s.kT, seed=s.seed + 2)
    if s.init == "lattice":
        return maxwell_boltzmann(lattice(s.n, s.packing_fraction, kind=s.lattice, **_particles(cfg)), s.kT, seed=s.seed + 1)
    if s.init == "compress":
        return compressed_start(cfg)
    return random_start(cfg, s.packing_fraction)


def _particles(cfg: Config) -> dict:
    """The keywords of ``[system]`` (and ``[walls]``) that every initial state takes."""
    s = cfg.system
    if s.density is not None and s.mass != type(s).model_fields["mass"].default:  # (refused here, for new states only: configs stored by older runs hold both, and density won)
        raise ConfigError(f"system: mass = {s.mass!r} and density = {s.density!r} both set the mass: give one (density: mass = density * particle volume)")
    radius = s.radius if isinstance(s.radius, float) else s.radius.as_dict()
    periodic = [axis not in cfg.walls.axes for axis in "xyz"[: s.dim]]
    return dict(dim=s.dim, radius=radius, mass=s.mass, density=s.density, seed=s.seed, periodic=periodic)


def random_start(cfg: Config, packing_fraction: float, aspect=None) -> State:
    """The particles of ``[system]`` at random at ``packing_fraction`` in a box of ``aspect`` (default
    ``system.aspect``; walls on the ``[walls]`` axes), velocities at ``kT``."""
    s = cfg.system
    start = random_packing(s.n, packing_fraction, aspect=s.aspect if aspect is None else aspect, **_particles(cfg))
    return maxwell_boltzmann(start, s.kT, seed=s.seed + 1)


def dilute_fraction(target: float | None) -> float:
    """Where a compression to ``target`` starts: a tenth, or half the target if lower.

    Example:
        >>> dilute_fraction(0.5), dilute_fraction(0.15), dilute_fraction(None)
        (0.1, 0.075, 0.1)
    """
    return 0.1 if target is None else min(0.1, 0.5 * target)


def compressed_start(cfg: Config) -> State:
    """``init = "compress"``: a random start at a low packing fraction, grown to the target by
    :func:`edmd.compress` and scaled back to the configured radii (same packing fraction, smaller box)."""
    s = cfg.system
    start = random_start(cfg, dilute_fraction(s.packing_fraction))
    return at_radii(compress(start, s.packing_fraction, rate=s.compress_rate, kT=s.kT), start.radius)


def _check_walls(cfg: Config, state: State):
    """The walls of ``[walls]`` must be those of the state (one read from a file keeps its own)."""
    closed = ["xyz"[k] for k in np.flatnonzero(~state.periodic)]
    if sorted(closed) != sorted(cfg.walls.axes):
        source = f"the state of {cfg.system.from_file}" if cfg.system.from_file is not None else "the initial state"
        raise ConfigError(
            f"{source} has walls on the axes {closed or 'none'}, but walls.axes = {list(cfg.walls.axes)}: "
            "a state keeps its box; set walls.axes to its walled axes"
        )


def build_simulation(cfg: Config, state: State | None = None) -> Simulation:
    """A :class:`Simulation` for ``cfg`` (from ``state`` if given, else from ``[system]``).

    With ``[integrator] kind = "dem"`` it is a :class:`~edmd.run.dem.DEMSimulation` with the
    ``[contact]`` law.
    """
    shear = None if cfg.shear is None else cfg.shear.build()
    if state is None:
        state = build_state(cfg)
        if shear is not None and cfg.shear.profile and cfg.system.from_file is None:
            state = shear.with_profile(state)
    _check_walls(cfg, state)
    if cfg.integrator.kind == "dem":
        from ..run.dem import DEMSimulation

        i = cfg.integrator
        contact = cfg.contact.build(float(state.mass.mean()))
        friction = None if cfg.friction is None else cfg.friction.build()
        return DEMSimulation(
            state, contact, dt=i.dt, steps_per_contact=i.steps_per_contact, impact_speed=i.impact_speed, gravity=cfg.system.gravity, skin=i.skin,
            friction=friction,
        )  # fmt: skip
    options = EngineOptions(**cfg.engine.model_dump())  # (every [engine] key is an option of the same name)
    rule = cfg.collision.build(float(state.mass.mean()), None if cfg.friction is None else cfg.friction.build())
    walls = cfg.walls.build(cfg.collision.material(), getattr(rule, "contact", None)) if cfg.walls.axes else None  # (keys without walls: IgnoredKeyWarning)
    bath = None if cfg.thermostat is None else cfg.thermostat.build()
    kicks = None if cfg.forcing is None else cfg.forcing.build()
    shaker = None if cfg.vibration is None else cfg.vibration.build()
    well = None if cfg.well is None else cfg.well.build()
    return Simulation(
        state, collision=rule, walls=walls, gravity=cfg.system.gravity, thermostat=bath, forcing=kicks, vibration=shaker, well=well, shear=shear,
        engine=options,
    )  # fmt: skip


def make_observers(cfg: Config, out: Path, run_id: str | None = None) -> list[Observer]:
    """The observers ``[output]`` asks for, writing into ``out`` (same list for runs and restarts).

    ``run_id`` is the identity of the run, stored in its checkpoints (see :func:`run_directory`).
    """
    interval = cfg.run.output_interval
    o = cfg.output
    observers: list[Observer] = []
    if o.thermo:
        observers.append(Thermo(interval, path=out / "thermo.csv"))
    if o.trajectory:
        observers.append(Trajectory(out / "trajectory.gsd", o.trajectory_interval or interval, run_id=run_id))
    if o.wall_impacts:
        observers.append(WallImpacts(interval, out / "wall_impacts.csv"))
    rescale = None if cfg.thermostat is None else cfg.thermostat.updater()
    if rescale is not None:
        observers.append(rescale)
    if o.checkpoint and cfg.integrator.kind != "dem":  # the DEM has no checkpoints (yet)
        meta = {"config": dump_config(cfg), "run_id": run_id}
        observers.append(Checkpoint(out / "checkpoint.gsd", o.checkpoint_interval or interval, o.checkpoint_wall_interval, metadata=meta))
    return observers


@contextlib.contextmanager
def directory_lock(out: Path):
    """Hold an exclusive lock on run directory ``out`` (created if missing) while a run or restart
    writes there: a second edmd process asking for it is refused at once, so two runs never
    write into one directory. The lock is the operating system's (``flock``): a killed run
    releases it.

    Example:
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     with directory_lock(Path(d)):
        ...         try:
        ...             with directory_lock(Path(d)):
        ...                 pass
        ...         except RunDirectoryError as e:
        ...             print(str(e)[-40:])
        another edmd process is writing into it
    """
    if out.exists() and not out.is_dir():
        raise RunDirectoryError(f"{out} exists and is not a directory")
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    path = out / LOCK_FILE
    with open(path, "a") as handle:
        _lock(handle, path, out)  # (refused: nothing to clean up, the directory is another run's)
        try:
            yield
        except BaseException:
            if created and {p.name for p in out.iterdir()} <= {LOCK_FILE}:  # a run that failed before
                with contextlib.suppress(OSError):  # writing leaves no directory (removed while locked)
                    path.unlink()
                    out.rmdir()
            raise


#: errors of ``flock`` on file systems without locks (Lustre's default, some NFS mounts)
NO_LOCKS = (errno.ENOSYS, errno.ENOLCK, errno.EOPNOTSUPP)


def _lock(handle, path: Path, out: Path):
    """Lock the open lock file ``handle`` (at ``path``) for good or refuse with the reason; on a file
    system without locks, warn and go on unguarded."""
    if fcntl is None:  # pragma: no cover
        return
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise RunDirectoryError(f"{out} is in use: another edmd process is writing into it") from None
    except OSError as exc:
        if exc.errno not in NO_LOCKS:
            raise
        warnings.warn(f"{out}: this file system has no file locks ({exc.strerror}): nothing stops a second run from writing into it", stacklevel=4)
        return
    try:  # the file locked is still the directory's (not one a failed run removed meanwhile)
        current = os.stat(path).st_ino == os.fstat(handle.fileno()).st_ino
    except FileNotFoundError:
        current = False
    if not current:
        raise RunDirectoryError(f"{out} is in use: another edmd process is writing into it")


def run_files(out: Path) -> list[Path]:
    """The files of a run in directory ``out`` (its data, figures and movies)."""
    return [out / name for name in RUN_FILES + RUN_FIGURES if (out / name).exists()]


def _claim(out: Path, force: bool):
    """Refuse a directory holding another run's files, unless ``force`` (nothing is created then);
    with ``force``, create the directory and remove them all."""
    refuse_foreign(out, ("packing.gsd", "compression.csv"), "a packing of `edmd compress`", "a run")
    refusal = "already holds a run ({names}): continue it with `edmd run --restart {out}`, choose another --out, or replace it with --force"
    claim_directory(out, run_files(out) if out.is_dir() else [], force, refusal)


def refuse_foreign(out: Path, names, holds: str, writes: str):
    """Refuse ``out`` (even with --force) if it holds any of the files ``names`` of another kind of
    output (``holds``): replacing only the files of ``writes`` would leave the two mixed."""
    found = [name for name in names if (out / name).exists()]
    if found:
        raise RunDirectoryError(f"{out} holds {holds} ({', '.join(found)}); this command writes {writes}: choose another --out")


def claim_directory(out: Path, old: list[Path], force: bool, refusal: str):
    """Refuse directory ``out`` if it holds the files ``old`` (``refusal``: the rest of the message,
    with ``{names}`` and ``{out}``), unless ``force``; with ``force``, create it and remove them."""
    if out.exists() and not out.is_dir():
        raise RunDirectoryError(f"{out} exists and is not a directory")
    if not force:
        if old:
            names = ", ".join(p.name for p in old[:6]) + (", ..." if len(old) > 6 else "")
            raise RunDirectoryError(f"{out} " + refusal.format(names=names, out=out))
        return
    out.mkdir(parents=True, exist_ok=True)
    for path in old:
        path.unlink(missing_ok=True)


def run_identity(cfg: Config, state: State) -> str:
    """The identity of a run: a hash of its configuration (less the keys a restart may change) and
    of its initial state. Equal identities mean the same trajectory, bit for bit, so the files of a
    run continued after an interruption stay byte-identical to those of an uninterrupted run.

    Example:
        >>> from edmd.app.config import parse_config
        >>> cfg = parse_config({"system": {"dim": 2, "n": 16}})
        >>> a = run_identity(cfg, build_state(cfg))
        >>> cfg.run.until_time = 99.0                  # the end time does not change the run
        >>> run_identity(cfg, build_state(cfg)) == a, len(a)
        (True, 32)
    """
    fixed = cfg.model_copy(deep=True)
    defaults = Config()
    for key in RESTART_MUTABLE:
        section, name = key.split(".")
        setattr(getattr(fixed, section), name, getattr(getattr(defaults, section), name))
    digest = hashlib.sha256(dump_config(fixed).encode())
    for arr in (state.position, state.velocity, state.radius, state.mass, state.box, state.angular_velocity):
        digest.update(np.ascontiguousarray(arr).tobytes())
    return digest.hexdigest()[:32]


def config_text(cfg: Config, run_id: str, notes: list[str] = ()) -> str:
    """``config.toml`` of a run: its identity line, any notes (restart changes), the resolved configuration."""
    return _ID_LINE + run_id + "\n" + "".join(f"# {line}\n" for line in notes) + dump_config(cfg)


def run_directory(cfg: Config, out: str | Path, progress: bool | None = None, *, force: bool = False, max_memory=None) -> dict:
    """Run ``cfg`` writing ``config.toml``, ``thermo.csv``, ``trajectory.gsd``, ``checkpoint.gsd``,
    plots and ``summary.json`` into ``out``.

    A directory that already holds a run is refused unless ``force``, which removes every file
    of the old run first (figures included). The run gets an identity (:func:`run_identity`)
    written into ``config.toml``, every checkpoint and every trajectory frame, so that a
    restart can tell a foreign file. The
    end of the run, wherever it stops (``until_time`` off the output grid, ``max_events``,
    ``wall_time``), always writes a last trajectory frame and the final state into the
    checkpoint (a restart continues from the checkpoint point before it, exactly). If the engine fails
    (inelastic collapse, a failed debug check), the state at that moment is saved to
    ``error_state.gsd`` and the error to ``summary.json`` before the error is raised.

    Args:
        cfg: the validated configuration.
        out: the run directory (created).
        progress: show a progress bar (default: ``cfg.run.progress``).
        force: replace a run already in ``out``.
        max_memory: refuse to start if the estimated memory exceeds this size (bytes or
            ``"8G"``; default: the memory available, :func:`edmd.run.memory.check_memory`).

    Returns the summary (also written as ``summary.json``).
    """
    out = Path(out)
    n = cfg.system.n if cfg.system.from_file is None else frame_size(cfg.system.from_file, cfg.system.from_frame)
    if n is not None:
        check_memory(n, max_memory)
    if not force:
        _claim(out, force=False)
    with directory_lock(out):
        if not force:  # (again, holding the lock: a run may have finished there meanwhile)
            _claim(out, force=False)
        sim = build_simulation(cfg)
        if sim.time >= cfg.run.until_time:  # a state read from a file has its own time
            raise ConfigError(
                f"run.until_time = {cfg.run.until_time!r} is not after the initial time {sim.time!r} (frame "
                f"{cfg.system.from_frame} of {cfg.system.from_file}): until_time is absolute, set it later than {sim.time!r}"
            )
        _warn_trajectory_size(cfg, sim.engine.n, sim.time)  # not sim.state: a full snapshot copy
        _warn_ignored_keys(cfg)
        _claim(out, force=True)
        run_id = run_identity(cfg, sim.state)
        write_atomic(out / "config.toml", config_text(cfg, run_id))
        for observer in make_observers(cfg, out, run_id):
            sim.add(observer)
        return _execute(sim, cfg, out, progress)


#: bytes per particle of one trajectory frame (double precision: positions, velocities, angular
#: momenta, images, radii, masses, inertia, type ids; measured: 100 MB per frame at N = 1e6)
FRAME_BYTES_PER_PARTICLE = 100
#: a trajectory expected to exceed this many bytes is announced with a warning
TRAJECTORY_WARN_BYTES = 10**9


class TrajectorySizeWarning(UserWarning):
    """The trajectory of a run will be large (the message gives the estimate and the remedy)."""


def _warn_trajectory_size(cfg: Config, n: int, start: float):
    """Warn with the estimated size when the trajectory will exceed :data:`TRAJECTORY_WARN_BYTES`."""
    interval = cfg.output.trajectory_interval or cfg.run.output_interval
    if not cfg.output.trajectory or math.isinf(cfg.run.until_time):
        return
    frames = math.floor((cfg.run.until_time - start) / interval + 1e-9) + 2  # the grid and the final frame
    size = frames * n * FRAME_BYTES_PER_PARTICLE
    if size > TRAJECTORY_WARN_BYTES:
        warnings.warn(
            f"trajectory.gsd will take about {size / 1e9:.3g} GB ({frames} frames of {n} particles): set a larger "
            "[output] trajectory_interval, or trajectory = false",
            TrajectorySizeWarning,
            stacklevel=3,
        )


class IgnoredKeyWarning(UserWarning):
    """A configuration sets keys that its run does not use (:func:`edmd.app.config.ignored_keys`)."""


def _warn_ignored_keys(cfg: Config):
    """Warn once about the keys of ``cfg`` that the run would not use (when a new run starts; its
    restarts do not repeat it)."""
    notes = ignored_keys(cfg)
    if notes:
        warnings.warn(f"{len(notes)} key(s) of the configuration have no effect on this run: " + "; ".join(notes), IgnoredKeyWarning, stacklevel=3)


def _stored_config(path: Path, text: str | None) -> Config:
    if text is None:
        raise CheckpointError(f"{path} was not written by `edmd run` (no configuration inside)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CheckpointError(f"{path}: the stored configuration is damaged: {exc}") from None
    try:
        return parse_config(data)
    except ConfigError as exc:
        raise CheckpointError(
            f"{path}: the stored configuration is not valid for this edmd (an older one accepted it): {exc}\n"
            "The run cannot be continued as it is; start a new run from its last frame with "
            "`edmd run FIXED.toml --from trajectory.gsd`"
        ) from None


def restart_config(out: str | Path) -> Config:
    """The configuration stored in the checkpoint of run directory ``out``."""
    out = Path(out)
    if not out.is_dir():
        raise CheckpointError(f"no run directory {out}")
    path = out / "checkpoint.gsd"
    return _stored_config(path, read_checkpoint(path).metadata.get("config"))


def _read_run_config(path: Path) -> tuple[str | None, Config | None]:
    """The run id and configuration in a run's ``config.toml`` (``None, None`` if there is none)."""
    if not path.is_file():
        return None, None
    text = path.read_text()
    first = text.split("\n", 1)[0]
    run_id = first[len(_ID_LINE) :].strip() if first.startswith(_ID_LINE) else None
    try:
        return run_id, parse_config(tomllib.loads(text))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path} is not valid TOML: {exc}") from None
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def _flat(cfg: Config) -> dict[str, object]:
    return {f"{section}.{key}": value for section, model in cfg.model_dump().items() if model for key, value in model.items()}


def config_changes(old: Config, new: Config) -> dict[str, tuple]:
    """``{"section.key": (old, new)}`` for every key whose value differs."""
    a, b = _flat(old), _flat(new)
    return {k: (a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}


def set_key(cfg: Config, key: str, value):
    """Set ``cfg.<section>.<key>`` with validation; :class:`ConfigError` names the key."""
    section, name = key.split(".")
    try:
        setattr(getattr(cfg, section), name, value)
    except ValidationError as exc:
        raise ConfigError(format_errors(exc, prefix=(section,))) from None


def _check_identity(out: Path, data: CheckpointData, disk_id: str | None):
    saved_id = data.metadata.get("run_id")
    if saved_id is not None and disk_id is not None and saved_id != disk_id:
        raise RunDirectoryError(
            f"{out / 'checkpoint.gsd'} belongs to run {saved_id}, but {out / 'config.toml'} to run {disk_id}: "
            "the checkpoint was copied in from another run; restore this run's checkpoint, or start a new run"
        )
    trajectory = out / "trajectory.gsd"
    traj_id = trajectory_run_id(trajectory) if trajectory.is_file() else None
    if saved_id is not None and traj_id is not None and traj_id != saved_id:
        raise RunDirectoryError(
            f"{trajectory} was written by run {traj_id}, but {out / 'checkpoint.gsd'} by run {saved_id}: the files "
            "come from different runs; restore this run's files, or start a new run"
        )
    thermo = out / "thermo.csv"
    saved = next((o for o in data.meta["observers"] if o["class"] == "Thermo"), None)
    if saved is None or not thermo.is_file():
        return
    rows = data.arrays.get(f"observer/{data.meta['observers'].index(saved)}/rows")
    on_disk = read_thermo(thermo)
    if rows is None:  # (the rows are in the file: its row at the checkpoint must be the saved last one)
        at, last = saved["data"].get("file_rows", 0) - 1, saved["data"]["last"]
        for c in ("time", "collisions") if 0 <= at < len(on_disk.get("time", ())) else ():
            if c not in on_disk or on_disk[c][at] != last[c]:
                raise _foreign_thermo(thermo, out, c)
        return
    columns = list(saved["data"]["columns"])
    k = min(len(rows), len(on_disk.get("time", ())))
    for c in ("time", "collisions"):
        if c not in on_disk or not np.array_equal(on_disk[c][:k], rows[:k, columns.index(c)]):
            raise _foreign_thermo(thermo, out, c)


def _foreign_thermo(thermo: Path, out: Path, column: str) -> RunDirectoryError:
    return RunDirectoryError(
        f"{thermo} does not continue into {out / 'checkpoint.gsd'} (column {column} differs): the files come "
        "from different runs; restore this run's files, or start a new run"
    )


def restart_directory(out: str | Path, until_time: float | None = None, progress: bool | None = None) -> dict:
    """Continue the run in directory ``out`` from its checkpoint, bit for bit (optionally to a new end time).

    Rows and frames the interrupted run wrote after its last checkpoint are dropped and
    written again, identically. Budgets apply afresh: ``run.wall_time`` from the checkpoint
    point, ``run.max_events`` from where the run ended (the events recomputed up to there do
    not count, so a run of ``max_events`` steps always advances).
    The checkpoint, ``config.toml`` and ``thermo.csv`` must belong to the same run. Edits to
    ``config.toml`` since the run started are taken if they are in :data:`RESTART_MUTABLE`
    (and recorded in ``config.toml`` and ``summary.json``); any other edit is an error naming
    the keys, since the checkpoint fixes the run's physics and output cadence.
    """
    out = Path(out)
    if not out.is_dir():
        raise CheckpointError(f"no run directory {out}")
    with directory_lock(out):
        path = out / "checkpoint.gsd"
        disk_id, disk_cfg = _read_run_config(out / "config.toml")
        if not path.is_file() and disk_cfg is not None and (disk_cfg.integrator.kind == "dem" or not disk_cfg.output.checkpoint):
            why = "DEM runs write no checkpoint" if disk_cfg.integrator.kind == "dem" else "it ran with [output] checkpoint = false"
            raise CheckpointError(f"{out} cannot be continued: {why}; start a new run from its last frame with `edmd run CONFIG --from {out / 'trajectory.gsd'}`")
        data = read_checkpoint(path, final=False)
        cfg = _stored_config(path, data.metadata.get("config"))
        _check_identity(out, data, disk_id)
        changes = {} if disk_cfg is None else config_changes(cfg, disk_cfg)
        fixed = [k for k in changes if k not in RESTART_MUTABLE]
        if fixed:
            listing = "; ".join(f"{k}: {changes[k][0]!r} -> {changes[k][1]!r}" for k in fixed)
            raise ConfigError(
                f"{out / 'config.toml'} was edited after the run started ({listing}). A restart continues the "
                f"checkpoint's physics and output: only {', '.join(RESTART_MUTABLE)} may change. Undo the edits, "
                "or start a new run with the edited file"
            )
        for key in changes:
            set_key(cfg, key, changes[key][1])
        if until_time is not None:
            if until_time <= data.time:
                raise ConfigError(f"--until-time {until_time!r} is not after the checkpoint time {data.time!r}: nothing to continue")
            changes["run.until_time"] = (cfg.run.until_time, until_time)
            set_key(cfg, "run.until_time", until_time)
        _check_end(cfg.run.until_time, data, "--until-time" if until_time is not None else "run.until_time =")
        run_id = data.metadata.get("run_id") or disk_id or run_identity(cfg, data.state)
        sim = load_checkpoint(path, make_observers(cfg, out, run_id), data=data, take_state=True)
        notes = [f"continued at t = {data.time!r}: {k} {a!r} -> {b!r}" for k, (a, b) in changes.items()]
        previous = _previous_notes(out / "config.toml")
        write_atomic(out / "config.toml", config_text(cfg, run_id, previous + notes))
        replayed = 0 if data.final_events is None else data.final_events - data.events  # recomputed, not new
        summary = _execute(sim, cfg, out, progress, {"restart_changes": {k: list(v) for k, v in changes.items()}} if changes else None, replayed)
        return summary


def _check_end(end: float, data: CheckpointData, what: str):
    """Refuse a restart to ``end`` if the run already got there (nothing to do) or beyond (the
    restart would drop the frames, rows and final state it wrote after ``end``)."""
    reached = data.time if data.final_time is None else data.final_time
    if end < reached:
        raise ConfigError(
            f"{what} {end!r} is before t = {reached!r}, where the run already ended: the restart would drop "
            f"what the run wrote after t = {end!r}; give a later end time, or start a new run"
        )
    if end == reached:
        raise ConfigError(f"the run is complete (it reached {what} {end!r}): give a later --until-time to extend it")


def _previous_notes(path: Path) -> list[str]:
    """The notes of earlier restarts in ``config.toml`` (kept as the record of the run)."""
    if not path.is_file():
        return []
    lines = path.read_text().split("\n")[1:]
    return [line[2:] for line in lines if line.startswith("# continued at ")]


def _write_final(sim: Simulation):
    """The state where the run stopped, if it stopped between output points: a last trajectory
    frame, and the final state in the checkpoint (beside its restart point, see
    :func:`edmd.files.checkpoint.save_final_state`). Restarts continue from the checkpoint point, cut the
    trajectory back to it and recompute the rest exactly, so no extra resync enters the run."""
    for o in sim.observers:
        if isinstance(o, Checkpoint):
            o.close()  # writes a point skipped by the wall-clock interval if the run sits on it
    trajectories = [o for o in sim.observers if isinstance(o, Trajectory) and o.last_time != sim.time]
    checkpoints = [o for o in sim.observers if isinstance(o, Checkpoint) and o.last_written is not None and o.last_written != sim.time]
    if not (trajectories or checkpoints):
        return
    state, totals = sim.state, sim.totals()
    for o in trajectories:
        o.observe(sim, state, totals)
    for o in checkpoints:
        save_final_state(o.path, state, totals)


def _save_error(sim: Simulation, out: Path, exc: EngineError) -> dict:
    """Save the state at the moment of an engine failure; the summary records the error."""
    try:
        state = sim.state
    except Exception:  # noqa: BLE001 - the engine may be unusable; the summary still says what happened
        state = None
    if state is not None:
        with atomic_path(out / "error_state.gsd") as tmp:
            write_state(tmp, state, sim.totals())
    return {"status": "failed", "error": f"{type(exc).__name__}: {exc}", "error_time": sim.time, "error_state": "error_state.gsd" if state else None}


def _execute(sim: Simulation, cfg: Config, out: Path, progress: bool | None, extra: dict | None = None, replayed: int = 0) -> dict:
    """Run ``sim`` to the end of ``cfg`` and write the summary; ``replayed``: events a restart
    recomputes between its checkpoint point and where the run ended (not counted in ``max_events``)."""
    show = cfg.run.progress if progress is None else progress
    until = max(cfg.run.until_time, sim.time)
    budget = None if cfg.run.max_events is None else cfg.run.max_events + replayed
    failure = None
    try:
        sim.run(until_time=None if math.isinf(until) else until, max_events=budget, wall_time=cfg.run.wall_time, progress=show)
        _write_final(sim)
    except EngineError as exc:
        failure = _save_error(sim, out, exc)
        failure_exc = exc
    finally:
        sim.close()
    summary = summarize(sim, next((o for o in sim.observers if isinstance(o, Thermo)), None))
    summary.update(extra or {})
    if failure is not None:
        summary.update(failure)
        write_atomic(out / "summary.json", json.dumps(summary, indent=2))
        saved = f"; the state at t = {sim.time!r} is in {out / 'error_state.gsd'}" if failure["error_state"] else ""
        raise type(failure_exc)(f"{failure_exc}{saved} (summary in {out / 'summary.json'})") from None
    (out / "error_state.gsd").unlink(missing_ok=True)  # a failure of an earlier attempt is over
    write_atomic(out / "summary.json", json.dumps(summary, indent=2))  # the run is complete, whatever the figures do
    if cfg.output.plots and (cfg.output.thermo or cfg.output.trajectory):  # figures need one of them
        from .plots import plot_run

        summary["plots"] = [p.name for p in plot_run(out)]
        write_atomic(out / "summary.json", json.dumps(summary, indent=2))
    return summary


def summarize(sim: Simulation, thermo: Thermo | None) -> dict:
    """Final numbers of a run: counters, speed, last thermo row and machine info."""
    st = sim.peculiar_state(sim.state)  # (sheared: relative to the flow, as thermo.csv)
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
    summary.update(sim.emd_counters())
    if sim.engine.mode == "dem":
        summary["dt"] = sim.dt
        summary["particle_steps_per_second"] = st.n * sim.events / sim.wall_seconds if sim.wall_seconds > 0 else math.nan
    written = [o.last_written for o in sim.observers if isinstance(o, Checkpoint) and o.last_written is not None]
    if written:
        summary["checkpoint_time"] = written[-1]  # the restart point (the final state is saved beside it)
    if thermo is not None and thermo.rows:
        summary.update(_pressures(thermo.rows, st.periodic))
    return summary


def _pressures(rows: list[dict], periodic) -> dict:
    """Last and mean pressure over the thermo intervals: the bulk pressure of a periodic box, the
    pressure on each pair of walls of a closed axis (the bulk formula has no meaning there)."""
    columns = ["pressure"] if all(periodic) else [f"wall_pressure_{a}" for a, p in zip("xyz", periodic) if not p]
    out = {}
    for c in columns:
        values = [r[c] for r in rows if not math.isnan(r[c])]
        if values:
            out[f"{c}_last"] = values[-1]
            out[f"{c}_mean"] = sum(values) / len(values)
    return out
