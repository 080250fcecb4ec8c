"""Initial states: lattices, random insertion, radius distributions, Maxwell–Boltzmann velocities.

Everything is reproducible from a seed (``numpy.random.default_rng``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ._core.geometry import random_insert, relax_overlaps
from ._core.layout import make_geo
from .run.neighbours import overlap_grid
from .state import State, StateError, _is_filled, one_if_equal

LATTICES = {2: ("hex", "square"), 3: ("fcc", "sc")}
#: closest packing fraction each lattice reaches with touching spheres
LATTICE_MAX = {"hex": math.pi / (2 * math.sqrt(3)), "square": math.pi / 4, "fcc": math.pi / (3 * math.sqrt(2)), "sc": math.pi / 6}


def _rng(seed) -> np.random.Generator:
    """numpy's generator for ``seed``, a non-negative integer (``ValueError`` naming it otherwise)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return np.random.default_rng(seed)


def radii(n: int, distribution: float | dict, rng: np.random.Generator | None = None) -> np.ndarray:
    """Draw ``n`` radii.

    ``distribution`` is a number (monodisperse) or a dict with ``kind``:

    * ``{"kind": "uniform", "min": a, "max": b}``
    * ``{"kind": "normal", "mean": m, "std": s}`` (truncated at ``mean ± 3 std``; ``std <= mean / 3``)
    * ``{"kind": "lognormal", "mean": m, "std": s}`` (mean and std of the radius itself)
    * ``{"kind": "discrete", "values": [r1, r2, ...], "fractions": [f1, f2, ...]}`` (exact counts)

    Example:
        >>> radii(4, {"kind": "discrete", "values": [0.5, 0.7], "fractions": [0.5, 0.5]}).tolist()
        [0.5, 0.5, 0.7, 0.7]
    """
    rng = rng or np.random.default_rng(0)
    if isinstance(distribution, (int, float)):
        if not distribution > 0:
            raise StateError(f"radius must be positive, got {distribution}")
        return np.full(n, float(distribution))
    if not isinstance(distribution, dict):
        raise StateError(
            f"radius must be a number or a distribution dict (kind: uniform, normal, lognormal, discrete), got {type(distribution).__name__}; "
            "for given radii use {'kind': 'discrete', 'values': [...], 'fractions': [...]} or build an edmd.State"
        )
    d = dict(distribution)
    kind = d.pop("kind", None)
    try:
        if kind == "uniform":
            lo, hi = float(d.pop("min")), float(d.pop("max"))
            if not 0 < lo <= hi:
                raise StateError(f"uniform radii need 0 < min <= max, got min={lo}, max={hi}")
            out = rng.uniform(lo, hi, n)
        elif kind in ("normal", "lognormal"):
            mean, std = float(d.pop("mean")), float(d.pop("std"))
            if not (mean > 0 and std >= 0):
                raise StateError(f"{kind} radii need mean > 0 and std >= 0, got mean={mean}, std={std}")
            if kind == "normal":
                if std > mean / 3:  # (the lower clip would pile radii up at 1e-3 mean: not the requested distribution)
                    raise StateError(
                        f"normal radii need std <= mean / 3 (truncated at mean +- 3 std, all positive), got mean={mean}, std={std}; "
                        "use kind = 'lognormal' for wider distributions"
                    )
                out = np.clip(rng.normal(mean, std, n), max(mean - 3 * std, 1e-3 * mean), mean + 3 * std)
            else:
                s2 = math.log(1 + (std / mean) ** 2)
                out = rng.lognormal(math.log(mean) - 0.5 * s2, math.sqrt(s2), n)
        elif kind == "discrete":
            values = np.asarray(d.pop("values"), float)
            fr = np.asarray(d.pop("fractions", np.ones(len(values))), float)
            if values.size == 0 or np.any(values <= 0) or fr.shape != values.shape or np.any(fr < 0) or fr.sum() <= 0:
                raise StateError("discrete radii need positive values and as many non-negative fractions")
            counts = np.floor(fr / fr.sum() * n).astype(int)
            counts[np.argmax(fr)] += n - counts.sum()
            out = np.repeat(values, counts)
        else:
            raise StateError(f"unknown radius distribution kind {kind!r} (uniform, normal, lognormal, discrete)")
    except KeyError as exc:
        raise StateError(f"radius distribution {kind!r} needs the key {exc.args[0]!r}") from None
    if d:
        raise StateError(f"unknown keys for radius distribution {kind!r}: {sorted(d)}")
    return out


def _masses(r, dim, mass, density):
    if density is not None:
        if not density > 0:
            raise StateError(f"density must be positive, got {density}")
        vol = 4.0 / 3.0 * np.pi * r**3 if dim == 3 else np.pi * r**2
        return density * vol
    if not np.all(np.asarray(mass) > 0):
        raise StateError(f"mass must be positive, got {mass}")
    return np.broadcast_to(np.asarray(mass, float), r.shape)  # (one mass: a State keeps it in no memory)


def _check_counts(n, dim):
    """``n`` a positive integer and ``dim`` 2 or 3, or a :class:`StateError` naming the bad one."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise StateError(f"n must be a whole number of particles, got {n!r}")
    if n < 1:
        raise StateError(f"n must be positive, got {n}")
    if dim not in (2, 3):
        raise StateError(f"dim must be 2 or 3, got {dim}")


def _periodic_flags(periodic, dim) -> np.ndarray:
    flags = np.ones(dim, bool) if periodic is None else np.asarray(periodic, bool)
    if flags.shape != (dim,):
        raise StateError(f"periodic must be {dim} booleans, got {periodic!r}")
    return flags


def _box_for(n_particle_volume, packing_fraction, dim, aspect):
    if not 0 < packing_fraction < 1:
        raise StateError(f"packing fraction must be in (0, 1), got {packing_fraction}")
    volume = n_particle_volume / packing_fraction
    aspect = np.ones(dim) if aspect is None else np.asarray(aspect, float)
    if aspect.shape != (dim,) or np.any(aspect <= 0):
        raise StateError(f"aspect must be {dim} positive numbers, got {aspect}")
    return aspect * (volume / np.prod(aspect)) ** (1.0 / dim)


def lattice_sites(kind: str, counts: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Sites of a lattice with ``counts`` unit cells per axis, in units of the cell edges.

    Returns ``(sites, cell)``: ``sites`` ``(M, d)`` in ``[0, counts)`` and the unit-cell
    aspect ``cell`` (``(1, sqrt(3))`` for the rectangular cell of the hexagonal lattice).
    """
    basis = {
        "sc": ([[0, 0, 0]], [1, 1, 1]),
        "fcc": ([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]], [1, 1, 1]),
        "square": ([[0, 0]], [1, 1]),
        "hex": ([[0, 0], [0.5, 0.5]], [1, math.sqrt(3)]),
    }
    if kind not in basis:
        raise StateError(f"unknown lattice {kind!r}; choose from {sorted(basis)}")
    b, cell = basis[kind]
    b = np.asarray(b, float)
    grids = np.meshgrid(*[np.arange(c) for c in counts], indexing="ij")
    origins = np.stack([g.ravel() for g in grids], axis=1).astype(float)
    sites = (origins[:, None, :] + b[None, :, :]).reshape(-1, len(counts))
    return sites, np.asarray(cell, float)


def lattice(
    n: int,
    packing_fraction: float,
    dim: int = 3,
    kind: str | None = None,
    radius: float | dict = 0.5,
    mass: float = 1.0,
    density: float | None = None,
    seed: int = 0,
    periodic: Sequence[bool] | None = None,
) -> State:
    """Particles on a lattice (fcc/sc in 3D, hex/square in 2D) in a box, at rest.

    ``periodic`` marks periodic axes (default: all); the other axes are closed by walls and the
    lattice is fitted between them (outermost sites 1.001 largest radii from the walls).

    The box is as cubic as the lattice allows and holds the smallest lattice with at least
    ``n`` sites; surplus sites are left empty at random. Polydisperse radii are placed at random
    on the sites and must fit: the nearest-neighbour distance must exceed the largest diameter.

    Example:
        >>> s = lattice(32, 0.3, dim=3, kind="fcc")
        >>> s.n, round(s.packing_fraction, 12)
        (32, 0.3)
    """
    _check_counts(n, dim)
    kind = kind or LATTICES[dim][0]
    if kind not in LATTICES[dim]:
        raise StateError(f"lattice {kind!r} is not a {dim}D lattice; choose from {LATTICES[dim]}")
    rng = _rng(seed)
    r = radii(n, radius, rng)
    v_particles = float(np.sum(4.0 / 3.0 * np.pi * r**3 if dim == 3 else np.pi * r**2))
    per_cell = {"sc": 1, "fcc": 4, "square": 1, "hex": 2}[kind]
    _, cell = lattice_sites(kind, [1] * dim)
    cells_needed = math.ceil(n / per_cell)
    # unit cells per axis: as close to a cubic box as the cell aspect allows
    base = (cells_needed * np.prod(cell)) ** (1.0 / dim) / cell
    counts = np.maximum(np.floor(base).astype(int), 1)
    while np.prod(counts) < cells_needed:
        k = int(np.argmin(counts * cell))
        counts[k] += 1
    sites, cell = lattice_sites(kind, counts)
    volume = v_particles / packing_fraction if 0 < packing_fraction < 1 else -1.0
    if volume <= 0:
        raise StateError(f"packing fraction must be in (0, 1), got {packing_fraction}")
    a = (volume / np.prod(counts * cell)) ** (1.0 / dim)
    box = counts * cell * a
    pos = sites * cell * a
    chosen = np.sort(rng.choice(len(sites), size=n, replace=False)) if len(sites) > n else np.arange(n)
    pos = pos[chosen] - 0.5 * box + 0.25 * a * cell
    pos = (pos + 0.5 * box) % box - 0.5 * box
    periodic = _periodic_flags(periodic, dim)
    for k in np.flatnonzero(~periodic):  # fit the occupied sites between the walls
        lo, hi = pos[:, k].min(), pos[:, k].max()
        inner = 0.5 * box[k] - r.max() * (1.0 + 1e-3)  # a gap: resting on a wall is a Zeno limit
        pos[:, k] = 0.0 if hi == lo else (pos[:, k] - lo) / (hi - lo) * 2.0 * inner - inner
    r = rng.permutation(r) if np.ptp(r) > 0 else r
    nn = a * {"sc": 1.0, "fcc": 1 / math.sqrt(2), "square": 1.0, "hex": 1.0}[kind]
    if nn < 2.0 * r.max() * (1 + 1e-12) or not periodic.all():
        trial = State(position=pos, velocity=np.zeros_like(pos), radius=r, mass=1.0, box=box, periodic=periodic, check_overlaps=False)
        pair = trial.overlapping_pair(0.0)
        if pair is not None:  # (the closest sites: with walls the lattice is squeezed between them)
            i, j, d = pair
            eta_max = packing_fraction * (d / (r[i] + r[j])) ** dim
            magic = {"fcc": "4 k^3", "sc": "k^3", "square": "k^2", "hex": "2 k^2 (near-square boxes)"}[kind]
            where = " (squeezed between the walls)" if not periodic.all() else ""
            raise StateError(
                f"packing fraction {packing_fraction} cannot be built on a {kind} lattice with these radii: "
                f"neighbouring sites are {d:.6g} apart{where} but their particles need {r[i] + r[j]:.6g} "
                f"(they touch near packing fraction {eta_max:.4f}; n = {magic} fills the lattice exactly)"
            )
    m = _masses(r, dim, mass, density)
    return State(position=pos, velocity=np.zeros_like(pos), radius=one_if_equal(r), mass=m, box=box, periodic=periodic)


def random_packing(
    n: int,
    packing_fraction: float,
    dim: int = 3,
    radius: float | dict = 0.5,
    mass: float = 1.0,
    density: float | None = None,
    seed: int = 0,
    aspect: Sequence[float] | None = None,
    max_attempts: int = 1000,
    method: str = "auto",
    periodic: Sequence[bool] | None = None,
) -> State:
    """Random, non-overlapping particles in a periodic box, at rest.

    ``method="insert"``: random sequential insertion, largest particles first; fails with a clear
    error when a particle cannot be placed in ``max_attempts`` tries (insertion jams near
    eta ~ 0.38 in 3D, 0.55 in 2D). ``method="relax"``: random positions, then overlaps removed
    by steepest descent on a harmonic overlap energy (radii inflated so that a gap remains);
    works up to near random close packing and gives an amorphous start for dense fluids.
    ``method="auto"``: relaxation above eta = 0.2 (3D) / 0.4 (2D), else insertion, continued by
    relaxation if it gets stuck. ``periodic`` marks periodic axes (default: all); the others are
    closed by walls that the particles stay inside of.

    Example:
        >>> s = random_packing(100, 0.1, dim=2, seed=3)
        >>> s.overlapping_pair() is None
        True
    """
    _check_counts(n, dim)
    if method not in ("auto", "insert", "relax"):
        raise StateError(f"method must be 'auto', 'insert' or 'relax', got {method!r}")
    rng = _rng(seed)
    r = radii(n, radius, rng)
    vol = 4.0 / 3.0 * np.pi * r**3 if dim == 3 else np.pi * r**2
    box = _box_for(float(vol.sum()), packing_fraction, dim, aspect)
    order = np.argsort(-r, kind="stable")
    r = r[order]
    box3 = np.ones(3)
    box3[:dim] = box
    periodic = _periodic_flags(periodic, dim)
    half = np.full(3, np.inf)
    half[:dim] = np.where(periodic, 0.5 * box, np.inf)
    geo = make_geo(box3, half)
    periodic3 = np.r_[periodic, np.zeros(3 - dim, bool)]
    grid = overlap_grid(r, box3, periodic3, dim)
    pos3 = np.zeros((n, 3))
    placed, attempts, batch = 0, 0, 16
    if method == "auto" and packing_fraction > (0.2 if dim == 3 else 0.4):
        method = "relax"  # insertion slows down long before it jams
    while placed < n and attempts < max_attempts and method != "relax":
        uniforms = rng.random((min(n - placed, 4096), batch, 3))
        first_failed = random_insert(r, geo, grid, pos3, uniforms, placed, dim)
        attempts = attempts + batch if first_failed == placed else 0
        placed = first_failed
    if placed < n:
        if method == "insert":
            raise StateError(
                f"random insertion failed at particle {placed} of {n} after {max_attempts} attempts: packing "
                f"fraction {packing_fraction} is too high for random insertion; use method='relax' or a lattice"
            )
        pos3[placed:, :dim] = (rng.random((n - placed, dim)) - 0.5) * (box - 2.0 * r.max() * ~periodic)
        inflate = 1.0 + 2e-3
        sweeps = relax_overlaps(pos3, r, geo, overlap_grid(r, box3, periodic3, dim, inflate), inflate, 0.3, 20000, dim)
        if sweeps > 20000:
            raise StateError(
                f"could not remove the overlaps of a random packing at packing fraction {packing_fraction} "
                f"(random packings jam near 0.64 in 3D, 0.84 in 2D); use a lattice start"
            )
    m = _masses(r, dim, mass, density)
    return State(position=pos3[:, :dim], velocity=np.zeros((n, dim)), radius=one_if_equal(r), mass=m, box=box, periodic=periodic)


def replicate(state: State, counts: Sequence[int]) -> State:
    r"""Tile ``state`` ``counts[k]`` times along each periodic axis ``k`` (LAMMPS ``replicate``).

    Copy :math:`(a_0, a_1, a_2)` of particle :math:`i` sits at
    :math:`x_k + L_k\,(a_k - (c_k - 1)/2)` in the box of lengths :math:`c_k L_k` (centred, as
    every box is); it is particle :math:`i + N\,(a_0 + c_0 (a_1 + c_1 a_2))`. Radii, masses, moments
    of inertia, spins and velocities are copied, images start at zero. A state without overlaps
    (through its periodic faces too) gives a state without overlaps, at the same packing fraction.

    Made for large starts: an amorphous packing of ``n / 64`` particles relaxed by
    :func:`random_packing` and replicated 4 x 4 x 4 takes seconds where relaxing ``n`` particles
    takes minutes to hours. The copies move in step until their velocities are redrawn: follow it
    with :func:`maxwell_boltzmann`, after which collisions decorrelate them within a few mean free
    times.

    Example:
        >>> base = random_packing(500, 0.45, seed=1)
        >>> s = replicate(base, [2, 1, 3])
        >>> s.n, bool(np.array_equal(s.box, base.box * [2, 1, 3])), round(s.packing_fraction, 12)
        (3000, True, 0.45)
    """
    counts = np.asarray(counts)
    if counts.shape != (state.dim,) or not np.issubdtype(counts.dtype, np.integer) or np.any(counts < 1):
        raise StateError(f"replicate needs {state.dim} whole numbers >= 1 (copies per axis), got {counts.tolist()}")
    walled = np.flatnonzero((counts > 1) & ~state.periodic)
    if walled.size:
        raise StateError(f"replicate: axis {'xyz'[walled[0]]} is closed by walls; only periodic axes can be tiled")
    if state.has_pending or state.captured_pairs is not None or state.shear_offset != 0.0:
        raise StateError(
            "replicate: the state has pending eMD* contacts, captured square-well pairs or sliding (sheared) images, "
            "which the copies would not follow; replicate a state without them (e.g. the start before the run)"
        )
    copies = int(np.prod(counts))
    box = state.box * counts
    shift = np.stack(np.meshgrid(*[np.arange(c) - 0.5 * (c - 1) for c in counts], indexing="ij"), axis=-1)
    shift = shift.transpose(*reversed(range(state.dim)), state.dim).reshape(copies, state.dim) * state.box
    pos = (state.position[None, :, :] + shift[:, None, :]).reshape(-1, state.dim)
    pos -= box * np.floor(pos / box + 0.5)  # (a copy that round-off put past a face comes back in, within an ulp)

    def tiled(a):  # (one radius, mass or moment kept as one)
        return a[:1] if a.ndim == 1 and _is_filled(a) else np.tile(a, (copies,) + (1,) * (a.ndim - 1))

    spins = state.angular_velocity
    return State(
        position=pos,
        velocity=tiled(state.velocity),
        radius=tiled(state.radius),
        mass=tiled(state.mass),
        box=box,
        time=state.time,
        angular_velocity=tiled(spins) if np.any(spins) else None,
        inertia=tiled(state.inertia),
        periodic=state.periodic,
        last_collision=tiled(state.last_collision) if np.any(state.last_collision != -np.inf) else None,
        riding=tiled(state.riding) if np.any(state.riding) else None,
    )


def maxwell_boltzmann(state: State, kT: float, seed: int = 0, spin: bool = False) -> State:
    r"""Give ``state`` Maxwell–Boltzmann velocities at temperature ``kT`` with zero total momentum.

    Velocities are drawn with variance :math:`kT/m_i` per component, the centre-of-mass velocity
    is removed and the result rescaled so that the temperature is exactly ``kT``. With ``spin``
    angular velocities are drawn with variance :math:`kT/I_i` as well (rotational temperature
    exactly ``kT``). Returns a new state.

    Example:
        >>> s = maxwell_boltzmann(lattice(500, 0.2), kT=2.0, seed=1)
        >>> round(s.temperature(), 12), bool(np.allclose(s.momentum(), 0, atol=1e-12))
        (2.0, True)
    """
    if not kT >= 0 or not math.isfinite(kT):
        raise StateError(f"kT must be a non-negative number, got {kT}")
    if state.n == 1 and kT > 0:
        raise StateError(
            "maxwell_boltzmann: a single particle with zero total momentum is at rest, it cannot have a temperature "
            "kT > 0; give it a velocity directly (State(velocity=...)) or use kT = 0"
        )
    rng = _rng(seed)
    out = state.copy()
    v = rng.normal(size=(state.n, state.dim)) * np.sqrt(kT / state.mass)[:, None]
    v -= (state.mass[:, None] * v).sum(axis=0) / state.mass.sum()
    t = float(np.sum(state.mass[:, None] * v**2) / (state.dim * state.n))
    out.velocity = v * math.sqrt(kT / t) if t > 0 else v
    if spin:
        shape = (state.n, 3) if state.dim == 3 else (state.n,)
        w = rng.normal(size=shape) * np.sqrt(kT / state.inertia).reshape((-1,) + (1,) * (len(shape) - 1))
        dof = 3 if state.dim == 3 else 1
        tr = float(np.sum(state.inertia * (w**2 if w.ndim == 1 else (w**2).sum(axis=1))) / (dof * state.n))
        out.angular_velocity = w * math.sqrt(kT / tr) if tr > 0 else w
    return out
