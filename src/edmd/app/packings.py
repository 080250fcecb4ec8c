"""``edmd compress``: the particles of a configuration compressed to a packing fraction, a reduced
pressure or jamming (:func:`edmd.compression`), written as a packing directory."""

from __future__ import annotations

import csv
import io
import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..analysis.packing import ContactNetwork
from ..files.atomic import write_atomic
from ..files.trajectory import read_state, write_state
from ..run.compress import HISTORY, Compression, at_radii, compress_film, compression
from ..state import State
from .config import Config, ConfigError, dump_config
from .runner import RUN_FILES, claim_directory, dilute_fraction, random_start, refuse_foreign

#: files ``edmd compress`` writes into its directory
PACKING_FILES = ("config.toml", "packing.gsd", "compression.csv", "summary.json", "compression.png", "contacts.png")


def dilute_start(cfg: Config, target: float | None, film: str | None = None) -> State:
    """The particles of ``[system]`` at random in its box (walls on ``[walls]`` axes) at
    :func:`~edmd.app.runner.dilute_fraction` of the ``target``, velocities at ``kT`` (or the state
    of ``system.from_file``).

    ``film``: an axis closed by ``[walls]``: the box has the walls and twice the configured length along
    that axis, at half the ``target`` (squeezing it to half that length gives the configured box).
    """
    s = cfg.system
    if s.from_file is not None:
        return read_state(s.from_file, s.from_frame)
    if film is None:
        return random_start(cfg, dilute_fraction(target))
    if film not in cfg.walls.axes:
        raise ConfigError(f"--film {film}: the axis must be closed by walls ([walls] axes = [{film!r}])")
    aspect = np.ones(s.dim) if s.aspect is None else np.array(s.aspect, float)
    aspect["xyz".index(film)] *= 2.0
    return random_start(cfg, 0.5 * target, aspect)


def history_csv(history: np.ndarray, n: int) -> str:
    """The compression history of ``n`` particles as CSV text: one row per segment
    (:data:`edmd.run.compress.HISTORY`) and its ``collision_rate``, collisions per particle and unit time.

    Example:
        >>> from edmd.run.compress import HISTORY
        >>> print(history_csv(np.array([(1.0, 0.2, 2.5, 100), (2.0, 0.25, 3.0, 300)], dtype=HISTORY), n=50), end="")
        time,packing_fraction,pressure,collisions,collision_rate
        1.0,0.2,2.5,100,nan
        2.0,0.25,3.0,300,4.0
    """
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([*HISTORY.names, "collision_rate"])
    spans = np.diff(history["time"], prepend=np.nan)
    rates = np.diff(history["collisions"], prepend=0) / (n * spans)
    writer.writerows([repr(float(t)), repr(float(phi)), repr(float(z)), int(c), repr(float(rate))] for (t, phi, z, c), rate in zip(history, rates, strict=True))
    return buf.getvalue()


def compress_directory(
    cfg: Config,
    out: str | Path,
    packing_fraction: float | None = None,
    pressure: float | None = None,
    rate: float | None = None,
    gap: float = 1e-9,
    force: bool = False,
    progress: Callable[[float, float], None] | None = None,
    film: str | None = None,
    speed: float = 0.05,
) -> dict:
    """Compress the particles of ``cfg`` and write ``out``: ``packing.gsd`` (the final state, scaled
    back to the configured radii), ``compression.csv`` (packing fraction, reduced pressure,
    collisions and collision rate per segment; the first segment's rate is NaN), ``summary.json``, ``config.toml`` and the figures ``compression.png``
    (pressure against packing fraction) and, with a pressure target, ``contacts.png`` (contact numbers).

    Without a target, the packing fraction of ``[system]`` is the target. ``rate`` defaults to
    ``system.compress_rate``. ``film``: an axis closed by ``[walls]``: the particles keep their size
    and the upper wall of that axis moves in at ``speed`` (:func:`edmd.compress_film`) from twice the
    configured length to it (``packing.gsd``, ``summary.json`` and ``config.toml`` only). Returns the summary.
    """
    out = Path(out)
    if packing_fraction is None and pressure is None:
        packing_fraction = cfg.system.packing_fraction
    if film is not None and pressure is not None:
        raise ConfigError("a film is squeezed to a packing fraction (--to), not to a pressure")
    if not (gap > 0 and speed > 0):
        raise ConfigError(f"the contact gap and the wall speed must be positive, got {gap!r} and {speed!r}")
    if packing_fraction is not None and not 0 < packing_fraction < 1:  # (the start's, half of it, was named)
        raise ConfigError(f"the target packing fraction must be in (0, 1), got {packing_fraction!r}")
    _claim_packing(out, force)
    start = dilute_start(cfg, packing_fraction, film)
    started = time.process_time()
    if film is not None:
        k = "xyz".index(film)
        packing = compress_film(start, start.box[k] * start.packing_fraction / packing_fraction, film, speed, kT=cfg.system.kT, engine=cfg.engine.model_dump())
        _write_packing(out, cfg, packing)
        summary = {"n": packing.n, "dim": packing.dim, "packing_fraction": packing.packing_fraction, "film_axis": film, "separation": float(packing.box[k]),
                   "wall_speed": speed, "cpu_seconds": time.process_time() - started}  # fmt: skip
    else:
        rate = cfg.system.compress_rate if rate is None else rate
        run = compression(start, packing_fraction, pressure, rate=rate, kT=cfg.system.kT, engine=cfg.engine.model_dump(), progress=progress)
        cpu = time.process_time() - started
        packing = at_radii(run.state, start.radius)
        _write_packing(out, cfg, packing)
        write_atomic(out / "compression.csv", history_csv(run.history, packing.n))
        net = None if pressure is None else ContactNetwork(gap).compute(packing)  # (relative gaps: the same at any scale)
        summary = _summary(run, packing, rate, cpu, net)
        run.plot().figure.savefig(out / "compression.png", dpi=120)
        if net is not None:
            net.plot().figure.savefig(out / "contacts.png", dpi=120)
    write_atomic(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _write_packing(out: Path, cfg: Config, packing: State):
    """The packing and its configuration, first (a later failure keeps them)."""
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / "config.toml", dump_config(cfg))
    write_state(out / "packing.gsd", packing)


def _claim_packing(out: Path, force: bool):
    refuse_foreign(out, [name for name in RUN_FILES if name not in PACKING_FILES], "a run of `edmd run`", "a packing")
    old = [out / name for name in PACKING_FILES if (out / name).exists()]
    claim_directory(out, old, force, "already holds a packing ({names}): choose another --out or replace it with --force")


def _summary(run: Compression, packing: State, rate: float, cpu: float, net: ContactNetwork | None) -> dict:
    summary = {
        "n": packing.n,
        "dim": packing.dim,
        "packing_fraction": packing.packing_fraction,
        "pressure": run.pressure,
        "reached": run.reached,
        "rate": rate,
        "collisions": int(run.history["collisions"][-1]) if len(run.history) else 0,
        "segments": len(run.history),
        "cpu_seconds": cpu,
    }
    if net is not None:
        summary |= {
            "contact_gap": net.gap,
            "mean_contact_number": net.mean_contact_number,
            "isostatic_contact_number": net.isostatic,
            "rattler_fraction": net.rattler_fraction,
        }
    return summary
