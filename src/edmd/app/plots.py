"""Figures of a run, each showing what the run is for: Haff's law, the equation of state, eMD* exceptions...

Every ``plot_*`` function takes an optional Axes (a pair of Axes for the two-panel figures) and
returns what it drew on; without one it makes a new Figure rendered by matplotlib's Agg backend
(no pyplot, no display needed). :func:`run_figures` builds the standard set of a run directory
as Figures, titled with the run's key parameters; :func:`plot_run` writes them as PNG files
into the directory (``edmd plot DIR``). Trajectories are read one frame at a time and large
systems are subsampled (:data:`MAX_PARTICLES`), so a run of :math:`10^6` particles plots in
bounded memory.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import gsd.fl
import numpy as np
from matplotlib.ticker import NullFormatter

from ..files.atomic import atomic_path
from ..analysis import MSD, RDF, AlgebraicCooling, HaffLaw, Profile, VelocityDistribution, compressibility_factor, usf_temperature
from ..analysis._common import axes, each_state
from ..analysis.thermal import _thermo_table
from .config import Config, ConfigError, load_config
from ..state import State
from ..files.trajectory import frame_count, iter_states, read_state

#: thermo columns drawn in the energy balance when present (the first two always are)
ENERGY_COLUMNS = ("kinetic_energy", "rotational_energy", "potential_energy", "dissipated_energy")
#: eMD* counters of the thermo table, as fractions of the contacts handled by A/B events
EMD_COUNTERS = (
    ("emd_exceptions_a", "exception a) (rotation step impossible)"),
    ("emd_exceptions_b", "exception b) (three-particle contact)"),
    ("emd_fallbacks", "instantaneous-rule fallbacks"),
)
#: most particles drawn in a snapshot or used for P(v) and g(r) (a random subset beyond)
MAX_PARTICLES = 100_000
#: most positions (frames x particles) kept for the MSD averaged over time origins
MSD_SAMPLES = 2_000_000
#: the axes drawn by each snapshot view (3D: the third is the slab's)
VIEWS = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}


def _drawn(table, column) -> bool:
    """A column worth a curve: present and not identically zero (no spin, no gravity)."""
    return column in table and bool(np.any(np.asarray(table[column]) != 0))


def _panels(axs, n: int = 2, figsize=(9.0, 3.8)):
    """``axs``, or the ``n`` side-by-side Axes of a new Agg-rendered Figure."""
    if axs is not None:
        return tuple(axs)
    from matplotlib.figure import Figure

    return tuple(Figure(figsize=figsize, layout="constrained").subplots(1, n))


def _later(table, t0: float):
    """Rows after ``t0`` (for log axes in ``t - t0``) and their times ``t - t0``."""
    later = table["time"] > t0
    return later, table["time"][later] - t0


def plot_temperature(thermo, law=None, ax=None):
    r"""Temperature against time; with a cooling ``law``, log-log against :math:`t - t_0` with the law.

    ``law`` is a :class:`~edmd.analysis.HaffLaw` (constant :math:`e_n`), an
    :class:`~edmd.analysis.AlgebraicCooling` (viscoelastic :math:`t^{-5/3}`) or any callable
    :math:`T(t)` with attributes ``t0`` and ``label``. A ``temperature_rot`` column (rough
    particles) is drawn too when the table has a non-zero one.

    Example:
        >>> table = {"time": np.arange(4.0), "temperature": 1 / (1 + np.arange(4.0)) ** 2, "pressure": np.ones(4)}
        >>> ax = plot_temperature(table, HaffLaw(0.9, 3, density=0.2, sigma=1.0, kT0=1.0, eta=0.1))
        >>> ax.get_xscale(), len(ax.get_lines()[0].get_xdata())
        ('log', 3)
    """
    table = _thermo_table(thermo)
    ax = axes(ax)
    columns = [("temperature", "T (translational)"), ("temperature_rot", "T (rotational)")]
    if law is None:
        for col, label in columns:
            if _drawn(table, col) or col == "temperature":
                ax.plot(table["time"], table[col], "-", label=label)
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.set_xlabel("t")
    else:
        later, dt = _later(table, law.t0)
        for col, label in columns:
            if _drawn(table, col):
                ax.loglog(dt, table[col][later], "o", ms=3, label=label)
        ax.loglog(dt, law(table["time"][later]), "-", label=law.label)
        ax.set_xlabel(r"$t - t_0$")
    ax.set_ylabel("temperature")
    ax.legend(fontsize="small")
    return ax


def plot_rough_temperature(thermo, axs=None):
    r"""Rough particles: :math:`T_{\rm tr}` and :math:`T_{\rm rot}` (log-log against :math:`t - t_0`) and their ratio.

    Returns the two Axes (temperatures, ratio :math:`T_{\rm rot}/T_{\rm tr}`).

    Example:
        >>> t = np.arange(5.0)
        >>> table = {"time": t, "temperature": 1 / (1 + t), "temperature_rot": 0.5 / (1 + t), "pressure": t}
        >>> ax_t, ax_r = plot_rough_temperature(table)
        >>> ax_t.get_yscale(), ax_r.get_lines()[0].get_ydata().tolist()
        ('log', [0.5, 0.5, 0.5, 0.5])
    """
    table = _thermo_table(thermo)
    ax_t, ax_r = _panels(axs)
    later, dt = _later(table, table["time"][0])
    for col, label in (("temperature", r"$T_{\rm tr}$"), ("temperature_rot", r"$T_{\rm rot}$")):
        ax_t.loglog(dt, table[col][later], "o-", ms=3, label=label)
    ax_t.set_ylabel("temperature")
    ax_t.legend(fontsize="small")
    tr = table["temperature"][later]
    ratio = np.divide(table["temperature_rot"][later], tr, out=np.full_like(tr, np.nan), where=tr > 0)
    ax_r.semilogx(dt, ratio, "o-", ms=3)
    ax_r.set_ylabel(r"$T_{\rm rot} / T_{\rm tr}$")
    for ax in (ax_t, ax_r):
        ax.set_xlabel(r"$t - t_0$")
        ax.xaxis.set_minor_formatter(NullFormatter())
    return ax_t, ax_r


def _pressure_column(table):
    """The pressure of a run: the virial one in a periodic box, the mean of the wall pressures with walls."""
    walls = [c for c in table if c.startswith("wall_pressure_")]
    if not walls:
        return np.asarray(table["pressure"]), "P (virial)"
    return np.mean([table[c] for c in walls], axis=0), "P (on the walls)"


def _bulk_density(frames) -> tuple[float, float, int]:
    """Number density and packing fraction away from the walls, averaged over frames, and the dimension.

    In a periodic box: :math:`N/V`. With walls the layers at the walls hold more than their
    share, so the density is counted over the centres farther than two mean diameters from
    every wall (:math:`N/V` where that leaves no room).
    """
    densities = []
    for s in each_state(frames):
        volume = float(s.particle_volume().mean())
        half = np.where(s.periodic, 0.5 * s.box, 0.5 * s.box - 4.0 * float(s.radius.mean()))
        if s.periodic.all() or np.any(half <= 0):
            densities.append(s.n / s.volume)
        else:
            densities.append(np.all(np.abs(s.position) <= half, axis=1).sum() / float(np.prod(2.0 * half)))
    n = float(np.mean(densities))
    return n, n * volume, s.dim


def plot_pressure(thermo, frames, axs=None):
    r"""Pressure and compressibility factor :math:`Z = P/(nT)` against the hard-sphere equation of state.

    The reference is :func:`~edmd.analysis.compressibility_factor` (Carnahan–Starling in 3D,
    Henderson in 2D) at the number density :math:`n` and packing fraction of ``frames`` (a
    State, States or a GSD file): :math:`N/V` in a periodic box. With walls the pressure is the
    mean force per area on them (``wall_pressure_<axis>`` columns) and :math:`n` the density
    farther than two diameters from every wall (the bulk the walls are in equilibrium with).
    Returns the two Axes (pressure, Z).

    Example:
        >>> import edmd
        >>> s = edmd.lattice(64, 0.3)
        >>> table = {"time": np.arange(3.0), "temperature": np.ones(3), "pressure": [np.nan, 1.0, 1.1]}
        >>> ax_p, ax_z = plot_pressure(table, s)
        >>> round(float(ax_z.get_lines()[1].get_ydata()[0]), 4)   # Carnahan-Starling Z(0.3)
        3.9738
    """
    table = _thermo_table(thermo)
    ax_p, ax_z = _panels(axs)
    t, kT = table["time"], table["temperature"]
    density, eta, dim = _bulk_density(frames)
    z_eos = compressibility_factor(eta, dim)
    eos = "Carnahan–Starling" if dim == 3 else "Henderson"
    p, label = _pressure_column(table)
    ax_p.plot(t, p, "o", ms=3, label=label)
    ax_p.plot(t, density * kT * z_eos, "-", label=f"{eos}: $nTZ$")
    ax_p.set_ylabel("pressure")
    nkT = density * np.asarray(kT, float)
    z = np.divide(np.asarray(p, float), nkT, out=np.full(nkT.shape, np.nan), where=nkT > 0)  # (none at rest: T = 0)
    ax_z.plot(t, z, "o", ms=3, label=r"$Z = P/(nT)$")
    ax_z.plot([t[0], t[-1]], [z_eos, z_eos], "-", label=rf"{eos}, $\eta$ = {eta:.4g}: Z = {z_eos:.4g}")
    ax_z.set_ylabel("Z")
    for ax in (ax_p, ax_z):
        ax.set_xlabel("t")
        ax.legend(fontsize="small")
    return ax_p, ax_z


def plot_emd_exceptions(thermo, ax=None):
    r"""eMD* exception rates: exceptions a), b) and fallbacks per contact handled by A/B events, cumulative.

    :math:`f_x(t) = N_x(t)/N_A(t)` from the thermo columns ``emd_exceptions_a``,
    ``emd_exceptions_b``, ``emd_fallbacks`` and ``emd_contacts`` (physics.md §4.8).

    Example:
        >>> n = np.array([0.0, 10.0, 20.0])
        >>> table = {"time": n, "temperature": n, "pressure": n, "emd_contacts": n,
        ...          "emd_exceptions_a": n / 10, "emd_exceptions_b": 0 * n, "emd_fallbacks": 0 * n}
        >>> plot_emd_exceptions(table).get_lines()[0].get_ydata().tolist()
        [0.1, 0.1]
    """
    table = _thermo_table(thermo)
    missing = [c for c, _ in EMD_COUNTERS if c not in table] + ([] if "emd_contacts" in table else ["emd_contacts"])
    if missing:
        raise ValueError(f"the thermo table lacks the eMD* counters {missing} (not an eMD* run?)")
    ax = axes(ax)
    contacts = np.asarray(table["emd_contacts"], float)
    some = contacts > 0
    for col, label in EMD_COUNTERS:
        ax.plot(table["time"][some], table[col][some] / contacts[some], "o-", ms=3, label=label)
    ax.set_xlabel("t")
    ax.set_ylabel("per A event (cumulative)")
    ax.legend(fontsize="small")
    return ax


def _vertical(state: State, gravity) -> int:
    """The axis gravity points along (the last one without gravity)."""
    g = np.zeros(state.dim) if gravity is None else np.asarray(gravity, float)
    return int(np.argmax(np.abs(g))) if np.any(g != 0) else state.dim - 1


def plot_height(thermo, frames, gravity=None, axs=None):
    r"""A single particle: its height above the floor and its energies against time (no temperature).

    ``frames`` are States (or a GSD file) read one at a time; the height is measured along
    gravity (the last axis without it): the gap :math:`x + L/2 - R` between the particle and
    the wall below, or the coordinate on a periodic axis. The energy panel shows the kinetic
    (translational + rotational), potential and mechanical energy from the thermo table.
    Returns the two Axes (height, energy).

    Example:
        >>> ball = State(position=[[0.0, 0.0]], velocity=[[0.0, -1.0]], radius=0.5, mass=1.0, box=[4.0, 4.0],
        ...              periodic=[True, False])
        >>> table = {"time": np.zeros(1), "temperature": np.zeros(1), "pressure": np.zeros(1),
        ...          "kinetic_energy": np.full(1, 0.5), "potential_energy": np.zeros(1)}
        >>> ax_h, ax_e = plot_height(table, [ball], gravity=[0.0, -1.0])
        >>> ax_h.get_lines()[0].get_ydata().tolist()
        [1.5]
    """
    table = _thermo_table(thermo)
    ax_h, ax_e = _panels(axs)
    times, heights = [], []
    for s in each_state(frames):
        k = _vertical(s, gravity)
        floor = -0.5 * s.box[k] + s.radius[0] if not s.periodic[k] else 0.0
        times.append(s.time)
        heights.append(float(s.position[0, k] - floor))
    ax_h.plot(times, heights, "o-", ms=2)
    ax_h.set_ylabel(f"height ({'xyz'[k]}) above the wall" if not s.periodic[k] else "xyz"[k])
    kinetic = table["kinetic_energy"] + (table["rotational_energy"] if "rotational_energy" in table else 0.0)
    potential = table["potential_energy"] if "potential_energy" in table else np.zeros_like(kinetic)
    for values, label in ((kinetic, "kinetic"), (potential, "potential"), (kinetic + potential, "kinetic + potential")):
        ax_e.plot(table["time"], values, "-", label=label)
    ax_e.set_ylabel("energy")
    ax_e.legend(fontsize="small")
    for ax in (ax_h, ax_e):
        ax.set_xlabel("t")
    return ax_h, ax_e


def plot_energy(thermo, ax=None):
    """Energy balance: kinetic, rotational and potential energy (when present), dissipated energy and their sum.

    Example:
        >>> table = {"time": np.arange(3.0), "temperature": np.ones(3), "pressure": np.ones(3),
        ...          "kinetic_energy": np.array([3.0, 2.0, 1.0]), "dissipated_energy": np.array([0.0, 1.0, 2.0])}
        >>> plot_energy(table).get_lines()[-1].get_ydata().tolist()
        [3.0, 3.0, 3.0]
    """
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


def sample_particles(n: int, at_most: int) -> np.ndarray | None:
    """Sorted indices of a fixed random subset of ``at_most`` of ``n`` particles (``None``: keep all).

    The subset is the same at every call, so the frames of a movie or an MSD follow the same particles.

    Example:
        >>> sample_particles(10, 20) is None, sample_particles(10**6, 3).tolist() == sample_particles(10**6, 3).tolist()
        (True, True)
    """
    if n <= at_most:
        return None
    return np.sort(np.random.default_rng(0).choice(n, at_most, replace=False))


def _take(state: State, keep: np.ndarray | None) -> State:
    """The particles ``keep`` of ``state`` (with committed velocities: pending eMD* contacts are not carried)."""
    if keep is None:
        return state
    return State(
        position=state.position[keep],
        velocity=state.committed_velocity[keep],
        radius=state.radius[keep],
        mass=state.mass[keep],
        box=state.box,
        time=state.time,
        angular_velocity=state.angular_velocity[keep],
        inertia=state.inertia[keep],
        image=state.image[keep],
        periodic=state.periodic,
        shear_offset=state.shear_offset,
        check_overlaps=False,
    )


def slab_mask(state: State, axis: int, thickness: float | None, centre: float | None):
    """Particles whose centres lie within ``thickness/2`` of ``centre`` along ``axis``.

    Defaults: one mean diameter thick, centred on the median particle (so a slab through a
    lattice or a settled bed is never empty). Returns the mask, the centre and the half thickness.

    Example:
        >>> import edmd
        >>> mask, centre, half = slab_mask(edmd.lattice(500, 0.3), 2, None, None)
        >>> bool(mask.any()), half
        (True, 0.5)
    """
    x = state.position[:, axis]
    thickness = 2.0 * float(state.radius.mean()) if thickness is None else thickness
    centre = float(np.partition(x, x.size // 2)[x.size // 2]) if centre is None else centre
    return np.abs(x - centre) <= 0.5 * thickness, centre, 0.5 * thickness


def _colours(state: State, color_by: str):
    """Values and colour map: speed, spin ``|omega|`` (3D) or signed ``omega_z`` (2D, diverging about 0)."""
    if color_by == "speed":
        return np.linalg.norm(state.committed_velocity, axis=1), "viridis", "speed"
    w = state.angular_velocity
    if state.dim == 3:
        return np.linalg.norm(w, axis=1), "viridis", r"spin $|\omega|$"
    return w, "RdBu_r", r"spin $\omega_z$"


def plot_snapshot(state: State, color_by: str = "speed", ax=None, slab: float | None = None, slab_centre: float | None = None,
                  view: str = "xy", max_particles: int | None = None):  # fmt: skip
    """Particles drawn to scale, coloured by speed (``|v|``) or spin (``omega_z`` in 2D, ``|omega|`` in 3D).

    ``view`` names the two axes drawn (``"xy"``, ``"xz"``: a side view for gravity along z,
    ``"yz"``; 2D states have ``"xy"`` only). 3D states are shown as a slab across the third
    axis: particles whose centres lie within ``slab`` (default one mean diameter) of
    ``slab_centre`` (default the median particle's position, so that the slab goes through the
    particles), drawn with their full radius. At most ``max_particles`` of them (default
    :data:`MAX_PARTICLES`) are drawn: a random subset.
    The signed 2D spin uses a diverging colour map centred on zero.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(100, 0.3, dim=2), 1.0, seed=1, spin=True)
        >>> coll = plot_snapshot(s, "spin").collections[0]
        >>> len(coll.get_offsets()), coll.norm.vmin == -coll.norm.vmax
        (100, True)
    """
    if color_by not in ("speed", "spin"):
        raise ValueError(f"color_by must be 'speed' or 'spin', got {color_by!r}")
    if view not in VIEWS or (state.dim == 2 and view != "xy"):
        raise ValueError(f"view must be one of {list(VIEWS) if state.dim == 3 else ['xy']}, got {view!r}")
    from matplotlib.collections import EllipseCollection

    ax = axes(ax, figsize=(5.5, 5.0))
    h, v = VIEWS[view]
    where = ""
    keep = np.ones(state.n, bool)
    if state.dim == 3:
        depth = 3 - h - v
        keep, centre, half = slab_mask(state, depth, slab, slab_centre)
        where = f", slab |{'xyz'[depth]} {'-' if centre >= 0 else '+'} {abs(centre):.4g}| <= {half:.3g}"
    idx = np.flatnonzero(keep)
    sub = sample_particles(idx.size, MAX_PARTICLES if max_particles is None else max_particles)
    if sub is not None:
        where += f", {sub.size} of {idx.size} shown"
        idx = idx[sub]
    values, cmap, label = _colours(state, color_by)
    d = 2.0 * state.radius[idx]
    coll = EllipseCollection(d, d, np.zeros_like(d), units="xy", offsets=state.position[idx][:, [h, v]],
                             offset_transform=ax.transData, array=values[idx], cmap=cmap)  # fmt: skip
    if cmap == "RdBu_r":
        top = float(np.abs(values[idx]).max(initial=0.0)) or 1.0
        coll.set_clim(-top, top)
    ax.add_collection(coll)
    ax.set_xlim(-0.5 * state.box[h], 0.5 * state.box[h])
    ax.set_ylim(-0.5 * state.box[v], 0.5 * state.box[v])
    ax.set_aspect("equal")
    ax.set_xlabel("xyz"[h])
    ax.set_ylabel("xyz"[v])
    ax.figure.colorbar(coll, ax=ax, label=label)
    ax.set_title(f"t = {state.time:.6g}{where}", fontsize="small")
    return ax


def plot_profile(profile, axs=None):
    """Density, granular temperature and mean velocity along the profile's axis
    (:class:`edmd.analysis.Profile`), side by side; returns the Axes."""
    axs = _panels(axs, 3, figsize=(12.0, 3.8))
    for ax, quantity in zip(axs, ("density", "temperature", "velocity")):
        profile.plot(ax, quantity)
    return axs


def _figure(drawn):
    """The Figure of an Axes, of a tuple of Axes, or a Figure."""
    from matplotlib.figure import Figure

    if isinstance(drawn, tuple):
        drawn = drawn[0]
    return drawn if isinstance(drawn, Figure) else drawn.figure


def save(drawn, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Save the Figure of ``drawn`` (an Axes, a tuple of Axes or a Figure) as PNG (atomically); returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        _figure(drawn).savefig(tmp, dpi=dpi, format="png")
    return path


# ------------------------------------------------------------------------------------ run directories
#: the short names of collision parameters in figure titles
_PARAMETERS = {"e_n": "e_n", "beta": "beta", "e_t": "e_t", "mu": "mu", "young": "Y", "poisson": "nu", "A": "A", "k": "k",
               "gamma": "gamma", "tc": "tc"}  # fmt: skip


@dataclasses.dataclass
class _Run:
    """What a run directory holds: its kind (which figure shows what it is for) and its title."""

    kind: str
    config: Config | None
    first: State | None
    gravity: np.ndarray | None
    label: str

    @property
    def has_gravity(self) -> bool:
        return self.gravity is not None and bool(np.any(self.gravity != 0))


def _read_run(run_dir: Path, traj: Path, frames: int) -> _Run:
    try:
        cfg = load_config(run_dir / "config.toml")
    except ConfigError:
        cfg = None
    first = read_state(traj, 0, check_overlaps=False) if frames else None
    gravity = None if cfg is None or cfg.system.gravity is None else np.asarray(cfg.system.gravity, float)
    n = first.n if first is not None else (cfg.system.n if cfg is not None else None)
    run = _Run(_run_kind(cfg, n, gravity), cfg, first, gravity, "")
    run.label = _run_label(run_dir, run, n)
    return run


def _run_kind(cfg: Config | None, n: int | None, gravity) -> str:
    """``single`` (N = 1), ``emdstar``, ``sheared``, ``vibrated`` (a vibrating wall), ``well`` (square wells), ``elastic``, ``granular`` (constant e_n),
    ``rough``, ``viscoelastic`` or ``other``.

    ``other``: no config.toml, the DEM, or gravity on many particles (no homogeneous law applies).
    """
    if n == 1:
        return "single"
    if cfg is None or cfg.integrator.kind == "dem":
        return "other"
    if cfg.collision.rule == "emdstar":
        return "emdstar"
    if cfg.shear is not None:
        return "sheared"
    if cfg.vibration is not None:
        return "vibrated"
    if cfg.well is not None:  # (not the hard-sphere equation of state: the temperature, and the rdf's jump)
        return "well"
    if gravity is not None and np.any(gravity != 0):
        return "other"
    return {"inelastic": "granular"}.get(cfg.collision.rule, cfg.collision.rule)


def _run_label(run_dir: Path, run: _Run, n: int | None) -> str:
    """Two title lines: the run and its system (N, dim, eta), then the rule and its parameters, gravity, walls."""
    cfg, first = run.config, run.first
    system = [f"N = {n}"] if n is not None else []
    if first is not None:
        system += [f"{first.dim}D", f"eta = {first.packing_fraction:.3g}"]
    elif cfg is not None:
        system += [f"{cfg.system.dim}D", f"eta = {cfg.system.packing_fraction:.3g}"]
    rule = []
    if cfg is not None:
        c = cfg.collision
        rule = [f"DEM ({cfg.contact.model})"] if cfg.integrator.kind == "dem" else [c.rule + (f" ({c.contact})" if c.rule == "emdstar" else "")]
        rule += [f"{short} = {getattr(c, key):.3g}" for key, short in _PARAMETERS.items() if getattr(c, key, None) is not None]
        rule += [f"walls {''.join(cfg.walls.axes)}"] if cfg.walls.axes else []
        rule += [f"square well {cfg.well.width:.3g} x sigma, depth {cfg.well.depth:.3g}"] if cfg.well is not None else []
        rule += [f"shear rate {cfg.shear.rate:.3g}"] if cfg.shear is not None else []
    if run.has_gravity:
        rule.append("g = (" + ", ".join(f"{g:.3g}" for g in run.gravity) + ")")
    name = run_dir.resolve().name
    return f"{name}: " + ", ".join(system) + ("\n" + ", ".join(rule) if rule else "")


def _frames(traj: Path, start: int = 0, keep: np.ndarray | None = None):
    """The frames of ``traj`` from ``start``, one at a time, reduced to the particles ``keep``."""
    for state in iter_states(traj, start=start, check_overlaps=False):
        yield _take(state, keep)


def _frame_times(traj: Path) -> np.ndarray:
    """The time of every frame (read without the particle data)."""
    with gsd.fl.open(str(traj), "r") as f:
        return np.array([float(f.read_chunk(frame=k if f.chunk_exists(k, "log/time") else 0, name="log/time")[0]) for k in range(f.nframes)])


def _cooling_law(run: _Run, table):
    """Haff's law (constant e_n) or the viscoelastic t^(-5/3) through the last row; ``None`` for other runs."""
    t, kT = table["time"], table["temperature"]
    if run.kind == "granular" and run.first is not None and kT[0] > 0:  # (a gas at rest does not cool)
        return HaffLaw.from_state(run.first, run.config.collision.e_n, kT0=float(kT[0]), t0=float(t[0]))
    if run.kind == "viscoelastic" and t[-1] > t[0] and kT[-1] > 0:
        return AlgebraicCooling(t1=float(t[-1]), kT1=float(kT[-1]), t0=float(t[0]))
    return None


def usf_restitution(cfg: Config, state: State) -> float | None:
    """The restitution of a run that the kinetic theory of uniform shear flow describes (smooth
    monodisperse particles of constant e_n, 1 if elastic, no TC; physics.md §5.8), or ``None``."""
    c = cfg.collision
    e_n = 1.0 if c.rule == "elastic" else c.e_n if c.rule == "inelastic" else None
    mono = np.all(state.radius == state.radius[0]) and np.all(state.mass == state.mass[0])
    return e_n if e_n is not None and c.tc is None and mono else None


def _sheared_temperature(run: _Run, table):
    """T(t) of a sheared run (relative to the flow) with the steady temperature of Grad's theory of
    uniform shear flow for smooth monodisperse particles of constant e_n < 1 (physics.md §5.8)."""
    ax = plot_temperature(table)
    first = run.first
    e_n = None if first is None else usf_restitution(run.config, first)
    if e_n is not None and e_n < 1.0:
        kT = usf_temperature(run.config.shear.rate, first.packing_fraction, e_n, first.dim, 2.0 * float(first.radius[0]), float(first.mass[0]))
        ax.axhline(kT, color="k", ls="--", lw=1, label=f"steady shear flow, Grad: {kT:.4g}")
        ax.legend(fontsize="small")
    return ax


def _purpose_figure(run: _Run, table, traj: Path) -> tuple[str, object] | None:
    """The figure of what the run is for, with its file stem."""
    if run.kind == "single":
        return ("height", plot_height(table, _frames(traj), run.gravity)) if run.first is not None else None
    if run.kind == "emdstar":
        return "emd_exceptions", plot_emd_exceptions(table)
    if run.kind == "elastic" and run.first is not None:
        return "pressure", plot_pressure(table, _frames(traj, start=max(frame_count(traj) - 5, 0)))
    if run.kind == "rough":
        return "temperature", plot_rough_temperature(table)
    if run.kind == "sheared":
        return "temperature", _sheared_temperature(run, table)
    if run.kind == "vibrated" and run.first is not None:  # the bed's profiles over the second half of the run
        axis = run.config.vibration.axis
        profile = Profile(axis, bins=40).compute(_frames(traj, start=frame_count(traj) // 2))
        return f"profile_{axis}", plot_profile(profile)
    return "temperature", plot_temperature(table, _cooling_law(run, table))


def _rdf(states: list[State]) -> RDF:
    """g(r) up to 5 diameters (or half the shortest periodic or accessible length), bins of 0.02 diameters."""
    s = states[-1]
    sigma = 2.0 * float(s.radius.mean())
    lengths = np.where(s.periodic, s.box, s.box - sigma)
    r_max = min(5.0 * sigma, 0.5 * float(lengths.min()))
    return RDF(bins=max(int(round(r_max / (0.02 * sigma))), 10), r_max=r_max).compute(states)


def _msd(run: _Run, traj: Path, frames: int) -> MSD:
    """MSD over every frame: averaged over time origins for elastic runs (stationary), from the first frame otherwise."""
    steps = np.diff(_frame_times(traj))
    window = run.kind == "elastic" and steps[0] > 0 and np.allclose(steps, steps[0], rtol=1e-9)
    at_most = max(1, MSD_SAMPLES // frames) if window else MAX_PARTICLES
    return MSD("window" if window else "direct").compute(_frames(traj, keep=sample_particles(run.first.n, at_most)))


def _snapshot_view(run: _Run) -> str:
    """A side view (gravity vertical) for 3D runs with gravity along z, the x-y plane otherwise."""
    return "xz" if run.first.dim == 3 and run.has_gravity and _vertical(run.first, run.gravity) == 2 else "xy"


def _frame_figures(run: _Run, traj: Path, frames: int, color_by: str) -> dict:
    n = run.first.n
    last = list(_frames(traj, start=max(frames - 5, 0), keep=sample_particles(n, MAX_PARTICLES)))
    shear = None if run.config is None or run.config.shear is None else run.config.shear.build()
    drawn = {}
    flowing = last if shear is None else [shear.peculiar_state(s) for s in last]
    if n > 1 and all(s.temperature() > 0 for s in flowing):  # particles at rest have no distribution
        drawn["velocity_distribution"] = VelocityDistribution().compute(flowing).plot()  # (sheared: relative to the flow)
    if n > 1 and not run.has_gravity:  # a settling column has no uniform density to normalise g(r) by
        drawn["rdf"] = _rdf(last).plot()
    if n > 1 and frames >= 2 and shear is None:  # (sheared: x displacements are the flow's, not diffusion)
        drawn["msd"] = _msd(run, traj, frames).plot()
    drawn["snapshot"] = plot_snapshot(read_state(traj, -1, check_overlaps=False), color_by, view=_snapshot_view(run))
    return drawn


def run_figures(run_dir: str | os.PathLike, color_by: str = "speed") -> dict:
    """The standard figures of a run directory: file stem -> matplotlib Figure.

    From ``thermo.csv``, the figure of what the run is for (the kind of run comes from
    ``config.toml``): ``temperature`` (inelastic: log-log against Haff's law; viscoelastic:
    against :math:`t^{-5/3}`; rough: :math:`T_{\\rm tr}`, :math:`T_{\\rm rot}` and their ratio;
    DEM, gravity or no config.toml: T(t)), ``pressure`` (elastic: P and Z against the
    equation of state), ``emd_exceptions`` (eMD*) or ``height`` (a single particle), and
    ``energy``. From ``trajectory.gsd``: ``velocity_distribution`` and ``rdf`` (last 5 frames;
    no g(r) under gravity; sheared runs: peculiar velocities), ``msd`` (every frame, averaged over time origins for elastic runs
    only, from the first frame for cooling ones; not for sheared runs) and ``snapshot`` (last frame; a side view
    for 3D runs with gravity). Every Figure is titled with the run's name and key parameters.

    Example:
        >>> import edmd, tempfile, pathlib
        >>> from edmd.files.trajectory import write_state
        >>> out = pathlib.Path(tempfile.mkdtemp())
        >>> write_state(out / "trajectory.gsd", edmd.maxwell_boltzmann(edmd.lattice(27, 0.1), 1.0, seed=1))
        >>> _ = (out / "thermo.csv").write_text("time,temperature,pressure,kinetic_energy,dissipated_energy\\n0,1,nan,40.5,0\\n")
        >>> figures = run_figures(out)   # one frame, no config.toml: the kind of run is unknown
        >>> sorted(figures), "N = 27" in figures["snapshot"].get_suptitle()
        (['energy', 'rdf', 'snapshot', 'temperature', 'velocity_distribution'], True)
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise FileNotFoundError(f"no run directory {run_dir}")
    thermo, traj = run_dir / "thermo.csv", run_dir / "trajectory.gsd"
    frames = frame_count(traj)
    if not thermo.is_file() and frames == 0:
        raise FileNotFoundError(f"{run_dir} has neither thermo.csv nor trajectory frames: nothing to plot")
    run = _read_run(run_dir, traj, frames)
    drawn = {}
    if thermo.is_file():
        table = _thermo_table(thermo)
        purpose = _purpose_figure(run, table, traj)
        if purpose is not None:
            drawn[purpose[0]] = purpose[1]
        drawn["energy"] = plot_energy(table)
    if frames:
        drawn.update(_frame_figures(run, traj, frames, color_by))
    figures = {name: _figure(d) for name, d in drawn.items()}
    for fig in figures.values():
        fig.suptitle(run.label, fontsize="small")
    return figures


def plot_run(run_dir: str | os.PathLike, color_by: str = "speed") -> list[Path]:
    """Write the figures of :func:`run_figures` as ``<stem>.png`` into the run directory; returns the files written."""
    run_dir = Path(run_dir)
    return [save(fig, run_dir / f"{name}.png") for name, fig in run_figures(run_dir, color_by).items()]


__all__ = [
    "plot_emd_exceptions",
    "plot_energy",
    "plot_height",
    "plot_pressure",
    "plot_rough_temperature",
    "plot_run",
    "plot_snapshot",
    "plot_temperature",
    "run_figures",
    "save",
]
