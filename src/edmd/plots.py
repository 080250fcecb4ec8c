"""Figures of a run: temperature (Haff's law), energy balance, P(v), g(r), MSD, snapshots.

Every ``plot_*`` function takes an optional Axes and returns the Axes it drew on; without one
it makes a new Figure rendered by matplotlib's Agg backend (no pyplot, no display needed).
:func:`plot_run` writes the standard set as PNG files into a run directory (``edmd plot DIR``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ._io import atomic_path
from .analysis import MSD, RDF, HaffLaw, VelocityDistribution
from .analysis._common import axes
from .analysis.thermal import _thermo_table
from .config import ConfigError, load_config
from .state import State
from .trajectory import frame_count, iter_states, read_state

#: thermo columns drawn in the energy balance when present (the first two always are)
ENERGY_COLUMNS = ("kinetic_energy", "rotational_energy", "potential_energy", "dissipated_energy")


def _drawn(table, column) -> bool:
    """A column worth a curve: present and not identically zero (no spin, no gravity)."""
    return column in table and bool(np.any(np.asarray(table[column]) != 0))


def plot_temperature(thermo, haff: HaffLaw | None = None, ax=None):
    r"""Temperature against time; with ``haff``, log-log against :math:`t - t_0` with Haff's law.

    A ``temperature_rot`` column (rough particles) is drawn too when the table has a non-zero one.
    """
    table = _thermo_table(thermo)
    ax = axes(ax)
    t = table["time"]
    columns = [("temperature", "T (translational)"), ("temperature_rot", "T (rotational)")]
    if haff is None:
        for col, label in columns:
            if _drawn(table, col) or col == "temperature":
                ax.plot(t, table[col], "-", label=label)
        ax.set_xlabel("t")
    else:
        later = t > haff.t0
        for col, label in columns:
            if _drawn(table, col):
                ax.loglog(t[later] - haff.t0, table[col][later], "o", ms=3, label=label)
        ax.loglog(t[later] - haff.t0, haff(t[later]), "-", label=rf"Haff's law, $\tau_0$ = {haff.tau0:.4g}")
        ax.set_xlabel(r"$t - t_0$")
    ax.set_ylabel("temperature")
    ax.legend(fontsize="small")
    return ax


def plot_energy(thermo, ax=None):
    """Energy balance: kinetic, rotational and potential energy (when present), dissipated energy and their sum."""
    table = _thermo_table(thermo)
    ax = axes(ax)
    t = table["time"]
    present = [c for c in ENERGY_COLUMNS if _drawn(table, c) or c in ("kinetic_energy", "dissipated_energy")]
    for col in present:
        ax.plot(t, table[col], "-", label=col.replace("_", " "))
    total = sum(table[c] for c in present)
    ax.plot(t, total, "k--", label="sum (conserved)")
    ax.set_xlabel("t")
    ax.set_ylabel("energy")
    ax.legend(fontsize="small")
    return ax


def _slab(state: State, thickness: float | None, centre: float):
    """Particles whose centres lie within the slab ``|z - centre| <= thickness/2`` (3D)."""
    thickness = 2.0 * float(state.radius.mean()) if thickness is None else thickness
    return np.abs(state.position[:, 2] - centre) <= 0.5 * thickness


def plot_snapshot(state: State, color_by: str = "speed", ax=None, slab: float | None = None, slab_centre: float = 0.0):
    """Particles drawn to scale, coloured by speed (``|v|``) or spin (``omega_z`` in 2D, ``|omega|`` in 3D).

    3D states are shown as a slab: particles whose centres lie within ``slab`` (default one mean
    diameter) of ``z = slab_centre``, drawn with their full radius.
    """
    if color_by not in ("speed", "spin"):
        raise ValueError(f"color_by must be 'speed' or 'spin', got {color_by!r}")
    from matplotlib.collections import EllipseCollection

    ax = axes(ax, figsize=(5.5, 5.0))
    keep = np.ones(state.n, bool) if state.dim == 2 else _slab(state, slab, slab_centre)
    if color_by == "speed":
        values = np.linalg.norm(state.committed_velocity, axis=1)
    else:
        w = state.angular_velocity
        values = w if state.dim == 2 else np.linalg.norm(w, axis=1)
    d = 2.0 * state.radius[keep]
    coll = EllipseCollection(d, d, np.zeros_like(d), units="xy", offsets=state.position[keep, :2],
                             offset_transform=ax.transData, array=values[keep], cmap="viridis")  # fmt: skip
    ax.add_collection(coll)
    half = 0.5 * state.box[:2]
    ax.set_xlim(-half[0], half[0])
    ax.set_ylim(-half[1], half[1])
    ax.set_aspect("equal")
    ax.figure.colorbar(coll, ax=ax, label="spin" if color_by == "spin" else "speed")
    where = "" if state.dim == 2 else f", slab |z - {slab_centre:g}| <= {0.5 * (slab or 2 * state.radius.mean()):.3g}"
    ax.set_title(f"t = {state.time:.6g}{where}", fontsize="small")
    return ax


def save(ax, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Save the Figure of ``ax`` as PNG (atomically); returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        ax.figure.savefig(tmp, dpi=dpi, format="png")
    return path


def _restitution(run_dir: Path) -> float:
    """The constant e_n of a smooth inelastic run (Haff's law applies); 1 otherwise or without config.toml."""
    try:
        collision = load_config(run_dir / "config.toml").collision
    except ConfigError:
        return 1.0
    return collision.e_n if collision.rule == "inelastic" else 1.0


def _haff_for_run(run_dir: Path, table) -> HaffLaw | None:
    """Haff's law for an inelastic run: e_n from config.toml, n, sigma, eta from the first frame."""
    e_n = _restitution(run_dir)
    traj = run_dir / "trajectory.gsd"
    if e_n >= 1.0 or frame_count(traj) == 0:
        return None
    first = read_state(traj, 0, check_overlaps=False)
    return HaffLaw.from_state(first, e_n, kT0=float(table["temperature"][0]), t0=float(table["time"][0]))


def plot_run(run_dir: str | os.PathLike, color_by: str = "speed") -> list[Path]:
    """Write the standard figures of a run directory into it; returns the files written.

    ``temperature.png`` (log-log with Haff's law for inelastic runs) and ``energy.png`` from
    ``thermo.csv``; ``velocity_distribution.png``, ``rdf.png`` (last 5 frames), ``msd.png`` (all
    frames: averaged over time origins for elastic runs, from the first frame for cooling ones,
    which are not stationary) and ``snapshot.png`` (last frame) from ``trajectory.gsd``.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise FileNotFoundError(f"no run directory {run_dir}")
    thermo, traj = run_dir / "thermo.csv", run_dir / "trajectory.gsd"
    frames = frame_count(traj)
    if not thermo.is_file() and frames == 0:
        raise FileNotFoundError(f"{run_dir} has neither thermo.csv nor trajectory frames: nothing to plot")
    written = []
    if thermo.is_file():
        table = _thermo_table(thermo)
        written.append(save(plot_temperature(table, _haff_for_run(run_dir, table)), run_dir / "temperature.png"))
        written.append(save(plot_energy(table), run_dir / "energy.png"))
    if frames:
        written += _plot_frames(run_dir, traj, frames, color_by)
    return written


def _plot_frames(run_dir: Path, traj: Path, frames: int, color_by: str) -> list[Path]:
    last = list(iter_states(traj, start=max(frames - 5, 0), check_overlaps=False))
    final = last[-1]
    written = []
    if all(s.temperature() > 0 for s in last):  # a single particle, or one at rest, has no distribution
        written.append(save(VelocityDistribution().compute(last).plot(), run_dir / "velocity_distribution.png"))
    if final.n > 1:
        sigma = 2.0 * float(final.radius.mean())
        r_max = min(5.0 * sigma, 0.5 * float(final.box[final.periodic].min())) if final.periodic.any() else 5.0 * sigma
        written.append(save(RDF(bins=max(int(round(r_max / (0.02 * sigma))), 10), r_max=r_max).compute(last).plot(), run_dir / "rdf.png"))
    if frames >= 2:
        states = list(iter_states(traj, check_overlaps=False))
        equal = np.allclose(np.diff([s.time for s in states]), states[1].time - states[0].time, rtol=1e-9)
        mode = "window" if equal and _restitution(run_dir) == 1.0 else "direct"
        written.append(save(MSD(mode).compute(states).plot(), run_dir / "msd.png"))
    written.append(save(plot_snapshot(final, color_by), run_dir / "snapshot.png"))
    return written


__all__ = ["plot_energy", "plot_run", "plot_snapshot", "plot_temperature", "save"]
