"""The engine: owns the compiled-core arrays of one system and drives its event loop (:func:`~edmd._core.loop.loop_variant`).

Users normally go through :class:`edmd.Simulation`; the engine is the thin layer that turns a
:class:`~edmd.state.State` into arrays, runs the event loop in segments and answers with
exact snapshots. Times inside the core are *local* (relative to ``t_origin``); a **resync**
streams every particle to the current time, re-bases the clock to zero, re-orders particles
spatially, and rebuilds neighbour structures and the calendar. Resyncs happen only at
deterministic points (start, every ``resync_every`` events, list growth), so a run split into
several :meth:`advance` calls is bit-for-bit the run done in one.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import warnings

import numpy as np
from numba import typeof

from .._core import layout as L
from .._core.bath import bath_schedule
from .._core.bundles import Drive, Lists, Particles, new_events, new_pairs
from .._core.cells import GI_WORK, cells_buffer_size, new_grid
from .._core.images import image_offset
from .._core.jit import in_disk_cache
from .._core.loop import GEO_ARG, integrate_kinetic, loop_variant
from .._core.wallmotion import rider_axis
from .._core.queue import QI_MOVED, calendar_shape, new_queue, queue_build
from .._core.snapshot import IMAGES, N_SUMS, POSITIONS, VELOCITIES, particle_sums, stream_all, stream_rows
from .._core.nblist import list_reach
from .._core.wells import capture_by_distance, captured_pairs, load_captured, well_reach
from ..physics import collide
from ..physics.emdstar import EMDStar, FrictionTableWarning, emd_bundle, friction_table_misses
from ..physics.tables import PAIR_SPECIES
from .memory import grid_shape
from .neighbours import big_count, block_reach, cell_edge, local_densities
from ..state import State, StateError, StateView, default_inertia, filled, one_if_equal, rescale_temperature

#: ``INFO`` when a run must compile its loop variant first (the CLI shows it)
log = logging.getLogger("edmd.compile")


#: the fewest events between two maintenance resyncs: a resync re-predicts every particle, and
#: resyncs after every event or two kept simultaneous events from ever advancing the clock
#: (reported as an inelastic collapse)
MIN_RESYNC_EVENTS = 64


@dataclasses.dataclass
class EngineOptions:
    """Tuning knobs of the event engine (all have sensible defaults).

    Attributes:
        neighbours: ``"list"`` (neighbour lists with a shell; best for dense systems),
            ``"cells"`` (cell grid with crossing events; best for dilute systems) or ``"auto"``
            (lists at packing fraction >= ``auto_threshold``, in a box without shear, unless a
            few particles at least :data:`AUTO_BIG_RATIO` times larger than the rest are taken
            out of cells mode's cell size: then cells).
        skin: list shell thickness in units of the mean diameter (lists only): pairs whose
            list centres are closer than ``sigma_ij + skin`` are neighbours.
        resync_every: events between two maintenance resyncs, per particle (one costs as much
            as 2-3 events per particle; benchmarks/README.md, "Resyncs"); at least
            :data:`MIN_RESYNC_EVENTS` events.
        events_per_bucket: target occupation of a calendar bucket.
        auto_threshold: packing fraction above which ``"auto"`` picks lists; ``None``: the
            measured crossover of :data:`AUTO_THRESHOLD` (0.35 for spheres, 0.6 for disks;
            benchmarks/README.md, "Neighbour structure").
        debug: check at every collision that the pair touches and that neither partner
            overlaps any neighbour (relative tolerance ``debug_tolerance``); a violation stops
            the run with :class:`EngineError`. Slower; for testing. eMD* runs check the touch
            only, which a contact fails that begins inside the residual overlap of a
            force-based end (a third particle pushing a pair together again as its contact
            ends; physics.md §2.2): raise ``debug_tolerance`` to that overlap over the contact
            distance, ``xi_c = 2 zeta_d e_n v_n / omega_0`` for a dashpot, ``1.5 A e_n v_n`` for
            viscoelastic Hertz.
        debug_tolerance: relative tolerance of the debug checks.
        cell_size: cell edge of ``"cells"`` mode in units of the largest contact distance
            (>= 1); ``None`` picks it from the density by the cost model of
            :func:`edmd.run.neighbours.cell_edge`. Either is capped at a quarter of the shortest
            periodic box length (4 cells per periodic axis at least); list mode ignores it.
    """

    neighbours: str = "auto"
    skin: float = 0.5
    resync_every: float = 200.0
    events_per_bucket: float = 4.0
    auto_threshold: float | None = None
    debug: bool = False
    debug_tolerance: float = 1e-9
    cell_size: float | None = None

    def __post_init__(self):
        if self.neighbours not in ("auto", "list", "cells"):
            raise ValueError(f"neighbours must be 'auto', 'list' or 'cells', got {self.neighbours!r}")
        if not self.skin > 0:
            raise ValueError(f"skin must be positive, got {self.skin}")
        if not self.resync_every > 0:
            raise ValueError(f"resync_every must be positive, got {self.resync_every}")
        if not self.events_per_bucket > 0:
            raise ValueError(f"events_per_bucket must be positive, got {self.events_per_bucket}")
        if not (self.debug_tolerance >= 0 and math.isfinite(self.debug_tolerance)):
            raise ValueError(f"debug_tolerance must be a number >= 0, got {self.debug_tolerance}")
        if self.cell_size is not None and not self.cell_size >= 1.0:
            raise ValueError(f"cell_size must be >= 1 (cells at least one contact distance wide), got {self.cell_size}")


#: packing fraction from which ``neighbours="auto"`` takes lists, by dimension: where lists overtake
#: cells (N = 1e4, one core; mono- and polydisperse, benchmarks/README.md "Neighbour structure")
AUTO_THRESHOLD = {2: 0.6, 3: 0.35}
#: size ratio of the big particles to the others from which ``"auto"`` keeps cells mode at any
#: density when it takes them out of the cell size: neighbour lists size their centre cells and
#: every particle's list capacity by the largest contact. One intruder among 1e4 (one core,
#: benchmarks/README.md "Big particles"), lists / cells in M coll/s: ratio 2, 3D eta = 0.45,
#: 1.42 / 0.77; ratio 3, 0.70 / 0.75 (2D eta = 0.65: 1.34 / 1.49); ratio 10, 0.036 / 0.65
AUTO_BIG_RATIO = 3.0


def _species(m: np.ndarray, r: np.ndarray) -> list[tuple[float, float]] | None:
    """The distinct ``(mass, radius)`` of particles of masses ``m`` and radii ``r`` if there are at most
    :data:`~edmd.physics.tables.PAIR_SPECIES` (else ``None``): the species whose pairs get pair tables."""
    if m.size and m.min() == m.max() and r.min() == r.max():
        return [(float(m[0]), float(r[0]))]
    masses, radii = np.unique(m), np.unique(r)
    if masses.size > PAIR_SPECIES or radii.size > PAIR_SPECIES:
        return None
    kinds = np.unique(np.searchsorted(masses, m) * radii.size + np.searchsorted(radii, r))
    if kinds.size > PAIR_SPECIES:
        return None
    return [(float(masses[k // radii.size]), float(radii[k % radii.size])) for k in kinds]


def check_loadable(state: State, engine, box: bool = True):
    """Refuse a state to load into ``engine`` (the event engine or the DEM's) that has another number
    of particles or dimension, or (``box``) another box or other periodic axes: it would run in the
    engine's box."""
    if state.n != engine.n or state.dim != engine.dim:
        raise StateError("a loaded state must have the same number of particles and dimension")
    if box and not (np.array_equal(state.box, engine.box_user) and np.array_equal(state.periodic, engine.periodic)):
        raise StateError(
            f"a loaded state must have the simulation's box {engine.box_user.tolist()} and periodic axes {engine.periodic.tolist()}, "
            f"got {state.box.tolist()} and {state.periodic.tolist()}: make a new Simulation for another box"
        )


def _radii_key(radius: np.ndarray) -> tuple[float, float, float]:
    """What the neighbour structure depends on of the radii (the largest, the smallest and their sum):
    a loaded state with another key gets its structure chosen again."""
    return float(radius.max()), float(radius.min()), float(radius.sum())


@dataclasses.dataclass(frozen=True)
class Saved:
    """The engine arrays a checkpoint saves right after its resync (:mod:`edmd.files.checkpoint`).

    ``take_state``: the State loaded with them is the restart's own, handed over to the engine
    (see :meth:`Engine.load`).
    """

    counters: np.ndarray
    accumulators: np.ndarray
    list_capacity: int
    take_state: bool = False


def _one_value(values: np.ndarray) -> float | None:
    """The one value of ``values`` when they are all equal (snapshots then give it as a
    :func:`~edmd.state.filled` constant, no memory per particle), else ``None``."""
    one = one_if_equal(values)
    return float(one[0]) if one.size == 1 else None


def _inverse(order: np.ndarray, dtype=np.int32) -> np.ndarray:
    """The inverse of the permutation ``order``: ``inverse[order[j]] = j``."""
    inverse = np.empty(len(order), dtype)
    inverse[order] = np.arange(len(order), dtype=dtype)
    return inverse


def _partners(partner: np.ndarray, inverse: np.ndarray) -> np.ndarray:
    """Partner indices ``partner`` (-1: none) renumbered by ``inverse`` (:func:`_inverse`), int32."""
    return np.where(partner >= 0, inverse[np.maximum(partner, 0)], -1).astype(np.int32)


def _vector3(v) -> np.ndarray:
    """A 2D or 3D vector as three float64 components (2D: z = 0)."""
    out = np.zeros(3)
    out[: len(v)] = v
    return out


def _permuted(a: np.ndarray, perm: np.ndarray) -> np.ndarray:
    """``a`` with its rows in the order ``perm`` (row ``j`` was row ``perm[j]``), in place: a column
    at a time, so that the copy made is one column's."""
    columns = a.reshape(len(a), -1) if len(a) else a
    for c in range(columns.shape[1] if len(a) else 0):
        columns[:, c] = columns[perm, c]
    return a


class EngineError(RuntimeError):
    """The event loop found an inconsistency (debug mode) or cannot go on."""


class CollapseError(EngineError):
    """Events pile up at one instant: inelastic collapse, or a ball coming to rest on a wall (Zeno)."""


class Engine:
    """Compiled-core arrays of one system (internal; see :class:`edmd.Simulation`)."""

    def __init__(self, state: State, options: EngineOptions | None = None, rule=None, wall=None, gravity=None, saved: Saved | None = None, **drivers):
        """``drivers``: ``thermostat``, ``forcing``, ``vibration``, ``well``, ``growth``, ``shear`` (``None``: off).
        ``saved``: the engine arrays of a checkpoint (:class:`Saved`): the engine is rebuilt
        exactly as it was right after the resync to ``state`` at which they were saved."""
        thermostat, forcing, vibration, well, growth, shear = (drivers.pop(k, None) for k in ("thermostat", "forcing", "vibration", "well", "growth", "shear"))
        if drivers:
            raise TypeError(f"unknown engine arguments {sorted(drivers)}")
        self.options = options or EngineOptions()
        self.dim = state.dim
        self.n = state.n
        self.periodic = state.periodic.copy()
        self.box_user = state.box.copy()
        self.box, self.half = state.geometry()
        self.grav = np.zeros(3)
        if gravity is not None:
            g = np.asarray(gravity, float)
            if g.shape != (self.dim,) or not np.all(np.isfinite(g)):
                raise ValueError(f"gravity must be {self.dim} finite numbers, got {gravity!r}")
            self.grav[: self.dim] = g
        self.vibration = vibration
        self.well = well
        self.shear = shear
        self._shear_offset = float(state.shear_offset)
        self.geo = self._geometry(float(state.time))
        self.fp = np.zeros(L.N_FP)
        self.ip = np.zeros(L.N_IP, np.int64)
        self.rule = collide.Inelastic(1.0) if rule is None else rule
        if isinstance(self.rule, EMDStar):
            self.rule = self.rule.for_dim(self.dim)  # (frictional: the fallback's sticking restitution of spheres or disks)
        self.wall = collide.default_wall(self.rule) if wall is None else wall
        self.emd_rule = self.rule if isinstance(self.rule, EMDStar) else None
        if self.emd_rule is not None and self.emd_rule.friction_table:
            for miss in friction_table_misses(self.emd_rule, state.mass, state.radius, state.inertia, self.dim):
                warnings.warn(f"friction_table: {miss}", FrictionTableWarning, stacklevel=3)
        collide.pack(self.rule, self.wall, self.fp, self.ip)
        self.thermostat = thermostat
        self.forcing = forcing
        for driver in (thermostat, forcing):
            if driver is not None:
                driver.pack(self.fp, self.ip)
        if forcing is not None and self.emd_rule is not None:
            raise StateError("white-noise forcing and eMD* cannot be combined: a kick would break a pending soft contact")
        if vibration is not None:
            self._check_vibration(state, vibration)
        if well is not None:
            if self.emd_rule is not None:
                raise StateError("square wells and eMD* cannot be combined: eMD*'s soft contacts have no well")
            well.pack(self.fp, self.ip)
        self.growth = growth
        if growth is not None:
            self._check_growth(state)
        self._check_shear(state, gravity is not None and np.any(self.grav != 0.0))
        self.etab = collide.viscoelastic_table()[0]
        self.ip[L.IP_WALLS] = sum(1 << k for k in range(self.dim) if not self.periodic[k])
        self.ip[L.IP_MAXSTALL] = 2 * self.n + 1000
        self.fp[L.FP_MTOT] = float(state.mass.sum())
        self.ip[L.IP_DEBUG] = int(self.options.debug)
        self.fp[L.FP_DEBUG_TOL] = self.options.debug_tolerance
        self.acc = np.zeros(L.N_ACC)
        self.cnt = np.zeros(L.N_COUNTERS, np.int64)
        self.clog = np.zeros((0, 5))
        self.work = np.zeros(4, np.int64)  # cells scanned, pairs tested, calendar entries moved, events (work_counters)
        self.collision_log: list[np.ndarray] | None = None
        self.list_capacity = 0
        self._fault: str | None = None  # (a resync's StateError: the engine cannot go on)
        self._neighbours_for(state)
        if growth is not None:
            speed = math.sqrt(growth.kT / float(state.mass.mean()))
            args = (state.packing_fraction, self.dim, 2.0 * float(state.radius.max()), speed, float(self.fp[L.FP_SKIN]))
            self.growth = growth.resolved(state.time, *args)
            self.growth.pack(self.fp, self.ip)
        #: growing radii, per segment: (time, packing fraction, reduced pressure, collisions) at its end
        #: (this process's segments: a checkpoint does not carry them)
        self.segments: list[tuple[float, float, float, int]] = []
        self._select_loop(growing=growth is not None)
        if saved is None:
            self.load(state)
        else:
            self._restore(state, saved)

    def _select_loop(self, growing: bool):
        """The event loop compiled for this system's features only (see :func:`loop_variant`)."""
        ip = self.ip
        self._loop_grows = growing
        self.loop = loop_variant(
            ip[L.IP_WALLS] != 0,
            self.emd_rule is not None,
            ip[L.IP_TANGENT] != L.TANGENT_SMOOTH,
            ip[L.IP_NORMAL],
            self.thermostat is not None,
            self.forcing is not None,
            self.well is not None,
            growing,
            self.mode == "list",
        )
        run_events, geo_type = self.loop.run_events, typeof(self.geo)
        if not any(sig.args[GEO_ARG] == geo_type for sig in run_events.nopython_signatures) and not in_disk_cache(run_events, (GEO_ARG, self.geo)):
            name = self.loop.name + ("+vibration" if self.vibration is not None else "") + ("+shear" if self.shear is not None else "")
            log.info("compiling the event loop for %s runs with %s (once; cached afterwards, see `edmd compile`)", name, self.loop.neighbours)

    # ------------------------------------------------------------------ set-up
    def _neighbours_for(self, state: State):
        """Choose the neighbour structure for ``state``'s radii and density, and size the cell walks' buffer."""
        self._choose_neighbours(state)
        self.cbuf = np.zeros(cells_buffer_size(self.grid_cells, self.shear is not None, self.big_reach), np.int32)

    def _choose_neighbours(self, state: State):
        opt = self.options
        self._chosen_for = _radii_key(state.radius)
        mode = opt.neighbours
        reach = list_reach(self.fp)
        sigma_max, periodic_len, periodic3 = self._grid_ranges(state)
        split = None if mode == "list" else self._big_split(state, periodic_len, periodic3)
        if mode == "auto":
            threshold = AUTO_THRESHOLD[self.dim] if opt.auto_threshold is None else opt.auto_threshold
            mode = "list" if (state.packing_fraction >= threshold or self._pair_state) and self.shear is None else "cells"
            if mode == "list" and not self._pair_state and split is not None and float(state.radius.max()) >= AUTO_BIG_RATIO * split[1]:
                mode = "cells"  # (big particles: lists' centre cells and every list would be sized by them)
        if mode == "cells" and self._pair_state:
            what = "square wells" if self.well is not None else "growing particles"
            raise StateError(f"{what} need neighbours='list' (or 'auto'): their pair events are predicted over neighbour lists")
        self.r_small, self.big_reach = math.inf, 1  # (no big particles)
        if mode == "cells":
            cells = self._cells(state, sigma_max, periodic_len, periodic3, split)
            if cells is not None:
                cells, self.r_small, self.big_reach = cells
                if self.r_small < math.inf:
                    bigs = int(np.count_nonzero(state.radius > self.r_small))
                    logging.getLogger("edmd.engine").info("cells mode: %d big particle(s) taken out of the cell size (radius > %g; they scan %d cells around)", bigs, self.r_small, self.big_reach)
            else:  # fewer than 4 cells on a periodic axis: a pair of cells would be adjacent through two images
                if opt.neighbours == "cells":
                    short = periodic_len[periodic_len < 4.0 * sigma_max]
                    detail = (
                        f"periodic box lengths >= 4 x the largest contact distance ({4 * sigma_max:g}), got {short.min():g}"
                        if short.size
                        else "a grid of >= 4 cells on every periodic axis, which the memory cap on the cell count does not allow here"
                    )
                    raise StateError(f"neighbours='cells' needs {detail}; use neighbours='list' or 'auto'")
                mode = "list"
        skin = opt.skin * 2.0 * float(state.radius.mean())
        if mode == "list" and periodic_len.size:
            limit = 0.25 * (0.5 * periodic_len.min() - sigma_max) * 2.0
            if limit <= 0:
                raise StateError(
                    f"periodic box length {periodic_len.min():g} must exceed twice the largest contact "
                    f"distance{' (the square well edge)' if reach > 1.0 else ''} ({2 * sigma_max:g})"
                )
            skin = min(skin, limit)
        self.mode = mode
        self.ip[L.IP_MODE] = L.NB_LIST if mode == "list" else L.NB_CELLS
        if hasattr(self, "loop") and self.loop.neighbours != ("lists" if mode == "list" else "cells"):
            self._select_loop(self._loop_grows)  # (a load chose another structure: its loop)
        self.fp[L.FP_SKIN] = skin
        if mode == "cells":
            self.grid_cells = cells
        else:
            self.grid_cells = grid_shape(self.box, periodic3, sigma_max + skin, self.n, self.dim)
            self.list_capacity = 0  # (the next build counts the lists first: _rebuild)

    def _grid_ranges(self, state: State):
        """The largest interaction range, the periodic box lengths and the periodic flags of 3 axes."""
        sigma_max = 2.0 * float(state.radius.max()) * list_reach(self.fp)
        return sigma_max, self.box[: self.dim][self.periodic], np.r_[self.periodic, [False] * (3 - self.dim)]

    def _cells(self, state: State, sigma_max: float, periodic_len, periodic3, split):
        """``(cells, r_small, reach)`` of cells mode (``None``: none fit): the cells per axis, with a
        few big particles taken out of the cell size where that pays (``split``, :meth:`_big_split`;
        else ``r_small = inf``, ``reach = 1``)."""
        if split is not None:
            return split
        if np.any(periodic_len < 4.0 * sigma_max):
            return None
        cells = self._cell_grid(state, sigma_max, periodic_len, periodic3)
        return None if cells is None else (cells, math.inf, 1)

    def _big_split(self, state: State, periodic_len, periodic3):
        """``(cells, r_small, reach)`` of cells sized without the big particles (physics.md §1.4,
        "Big particles"), or ``None``: none pay, or the box is too short for the bigs' blocks (on a
        periodic axis at least :math:`2K + 2` cells, and a length of at least twice the largest
        contact plus 4 cells: between two scans of a pair its nearest image cannot change), or the
        run shears (the sliding faces' blocks are 3 cells wide) or has a fixed ``cell_size``."""
        if self.shear is not None or self.options.cell_size is not None:
            return None
        m = big_count(state.radius, state.n / state.volume, self.dim)
        if m == 0:
            return None
        top = np.partition(state.radius, (state.n - m - 1, state.n - 2))
        r_small = float(top[state.n - m - 1])  # (the largest that is not big)
        r_max, sigma_max = float(top[-1]), float(top[-1] + top[-2])  # (the largest contact: of the two largest)
        if np.any(periodic_len < 8.0 * r_small):
            return None
        for edge in (None, 2.0 * r_small):  # the cost model's cells, else the smallest (they fit wherever any do)
            cells = self._cell_grid(state, 2.0 * r_small, periodic_len, periodic3, edge)
            if cells is None:
                continue
            lengths = self.box[: self.dim] / cells[: self.dim]
            split = cells[: self.dim] > 1
            if not split.any():
                continue
            reach = block_reach(r_max + r_small, lengths[split])
            periodic = split & self.periodic
            if np.all(cells[: self.dim][periodic] >= 2 * reach + 2) and np.all(self.box[: self.dim][periodic] >= 2.0 * sigma_max + 4.0 * lengths[periodic]):
                return cells, r_small, reach
        return None

    def _cell_grid(self, state: State, sigma_max: float, periodic_len, periodic3, edge: float | None = None):
        """Cells per axis of cells mode: the edge ``edge``, else of ``cell_size`` or of the cost model
        (:func:`.neighbours.cell_edge`), at most a quarter of the shortest periodic length; ``None``
        when the memory cap leaves fewer than 4 cells on a periodic axis."""
        if edge is None:
            edge = self._preferred_edge(state, sigma_max)
        if periodic_len.size:  # >= 4 cells on a periodic axis: a pair of cells is then adjacent through one image only
            edge = max(sigma_max, min(edge, float(periodic_len.min()) / 4.0))
        cells = grid_shape(self.box, periodic3, edge, self.n, self.dim)
        return None if np.any(cells[: self.dim][self.periodic] < 4) else cells

    def _preferred_edge(self, state: State, sigma_max: float) -> float:
        """The cells' edge of ``cell_size``, or of the cost model (:func:`.neighbours.cell_edge`) at the density."""
        sigma_mean = 2.0 * float(state.radius.mean())
        if self.options.cell_size is not None:
            return self.options.cell_size * sigma_max
        if np.any(self.grav != 0.0):  # a bed under gravity: its dense layers set the cells (at every load)
            density, weights = local_densities(state.position, self.box[: self.dim], sigma_mean)
            return cell_edge(density, sigma_mean, sigma_max, self.dim, weights)
        return cell_edge(state.n / state.volume, sigma_mean, sigma_max, self.dim)

    @property
    def _pair_state(self) -> bool:
        """Whether pair events need more than the hard-sphere predictor (square wells, growth): lists only."""
        return self.well is not None or self.growth is not None

    def _check_growth(self, state: State):
        """Growth is built for compressing hard spheres: smooth constant-restitution collisions, in a
        periodic box or between fixed walls."""
        if not isinstance(self.rule, collide.Inelastic):
            raise StateError(f"growing particles collide by a constant e_n (edmd.collide.Inelastic), not {type(self.rule).__name__}")
        others = [name for name, x in (("eMD*", self.emd_rule), ("a square well", self.well), ("a thermostat", self.thermostat),
                                       ("forcing", self.forcing), ("a vibrating wall", self.vibration), ("gravity", np.any(self.grav != 0) or None)) if x is not None]  # fmt: skip
        if others:
            raise StateError(f"growing particles cannot be combined with {', '.join(others)}")

    def _check_shear(self, state: State, gravity: bool):
        """Lees-Edwards boundaries need periodic x and y; they shear smooth or rough hard spheres under
        any instantaneous rule, with walls on z. A state with sliding images needs them."""
        if self.shear is None:
            if state.shear_offset != 0.0:
                raise StateError(
                    f"the state has Lees-Edwards images (shear_offset = {state.shear_offset:g}): run it with shear=edmd.Shear(rate=...) "
                    "(rate 0 keeps the images where they are) or set its shear_offset to 0"
                )
            return
        if self.dim < 2 or not (self.periodic[0] and self.periodic[1]):
            raise StateError("Lees-Edwards shear needs periodic x (the flow) and y (the gradient) axes")
        others = [name for name, x in (("eMD*", self.emd_rule), ("a square well", self.well), ("a thermostat", self.thermostat),
                                       ("forcing", self.forcing), ("a vibrating wall", self.vibration), ("growing particles", self.growth),
                                       ("gravity", gravity or None)) if x is not None]  # fmt: skip
        if others:
            raise StateError(f"Lees-Edwards shear cannot be combined with {', '.join(others)} (yet)")

    def _start_segment(self):
        """Growth at a load: the rate relative to the loaded radii and the lists' margin up to the
        segment's latest end (none once the radii have stopped growing)."""
        g, cnt = self.growth, self.cnt
        if cnt[L.C_GROW_NEXT] == 0:  # the first load: the first segment end after now
            cnt[L.C_GROW_NEXT] = int(math.floor((self.t_origin - g.start) / g.segment)) + 1
            cnt[L.C_GROW_EVENTS] = cnt[L.C_EVENTS]
            self.acc[L.A_SEG_VIRIAL], self.acc[L.A_SEG_KE_INT] = self.acc[L.A_VIRIAL], self.acc[L.A_KE_INT]
            cnt[L.C_GROW_DONE] = int(g.end is not None and g.end <= self.t_origin)
        growing = not cnt[L.C_GROW_DONE]
        if self._loop_grows != growing:
            self._select_loop(growing)
        rate = g.rate / g.factor(self.t_origin) if growing else 0.0
        self.fp[L.FP_GROW_LOCAL] = rate
        self.fp[L.FP_LIST_MARGIN] = rate * (self._segment_stop() - self.t_origin) if growing else 0.0

    @property
    def growing(self) -> bool:
        """Whether the radii are growing now."""
        return self.growth is not None and not self.cnt[L.C_GROW_DONE]

    def _segment_stop(self) -> float:
        """The latest end of the current segment: the next :math:`t_0 + k\\Delta`, or the growth's end."""
        g = self.growth
        grid = g.segment_end(int(self.cnt[L.C_GROW_NEXT]))
        return grid if g.end is None else min(grid, g.end)

    def _segment_events_left(self) -> int:
        """Events before the current segment ends by its count (``Growth.events`` per particle)."""
        return max(int(math.ceil(self.growth.events * self.n)) - int(self.cnt[L.C_EVENTS] - self.cnt[L.C_GROW_EVENTS]), 0)

    def _end_segment(self, stop: float | None):
        """Growth at a segment end (the engine is there): record the segment's packing fraction and
        reduced pressure, stop growing if a target is reached, rescale the velocities to ``kT``
        (booked as energy input) and reload. ``stop``: the segment's latest end if it ended there
        (``None``: by its event count)."""
        g, cnt, acc = self.growth, self.cnt, self.acc
        now = self.now
        state = self.snapshot()
        heat = 2.0 * (self.kinetic_integral(now) - acc[L.A_SEG_KE_INT])  # d N kT over the segment
        pressure = 1.0 + (acc[L.A_VIRIAL] - acc[L.A_SEG_VIRIAL]) / heat if heat > 0.0 else math.nan
        self.segments.append((now, state.packing_fraction, pressure, int(cnt[L.C_COLL])))
        before = state.kinetic_energy()
        rescale_temperature(state, g.kT)
        acc[L.A_ENERGY_INPUT] += state.kinetic_energy() - before
        if stop is not None and stop == g.segment_end(int(cnt[L.C_GROW_NEXT])):
            cnt[L.C_GROW_NEXT] += 1
        cnt[L.C_GROW_EVENTS] = cnt[L.C_EVENTS]
        cnt[L.C_GROW_DONE] = int((stop is not None and stop == g.end) or (g.pressure is not None and pressure >= g.pressure))
        self._reload(state, float(acc[L.A_NOW]))
        acc[L.A_SEG_VIRIAL], acc[L.A_SEG_KE_INT] = acc[L.A_VIRIAL], acc[L.A_KE_INT]

    def _geometry(self, origin: float) -> tuple:
        """The ``geo`` tuple for local times counted from ``origin`` (a vibrating wall's phase depends on it)."""
        wall = None if self.vibration is None else self.vibration.geo_entries(origin)
        if wall is not None and self.well is not None:  # (no riders: the wells' pair events do not follow the wall)
            wall = (*wall[:-1], 0.0)
        shear = None if self.shear is None else (self.shear.rate, self._shear_offset)  # (the loaded state's images)
        return L.make_geo(self.box, self.half, self.grav, wall, shear)

    def _check_vibration(self, state: State, vib):
        k = vib.axis_index
        if k >= self.dim or self.periodic[k]:
            raise StateError(f"the vibrating wall's axis {vib.axis!r} must be closed by walls (walls.axes)")
        room = self.box[k] - 2.0 * vib.amplitude - 2.0 * float(state.radius.max())
        if room <= 0.0:
            raise StateError(
                f"the vibrating wall sweeps 2 x amplitude = {2 * vib.amplitude:g} of the box length {self.box[k]:g} "
                f"along {vib.axis}: no room left for a particle of diameter {2 * float(state.radius.max()):g}"
            )

    def _vibration_clear(self, state: State):
        """Every particle must be on the box side of the vibrating wall when it is loaded."""
        vib = self.vibration
        k = vib.axis_index
        plane = vib.plane(float(state.time), float(self.box[k]))
        x, r = state.position[:, k], state.radius
        gap = x - r - plane if vib.side == "lower" else plane - x - r
        worst = int(np.argmin(gap))
        if gap[worst] < -1e-9 * float(self.box[k]):
            raise StateError(
                f"particle {worst} overlaps the vibrating wall at time {state.time:g} (the wall is at {vib.axis} = {plane:.6g}, "
                f"the particle reaches {x[worst] - r[worst] if vib.side == 'lower' else x[worst] + r[worst]:.6g}); "
                "choose a phase that starts the wall at its rest plane (sine: phase = -pi/2) or make room"
            )

    def load(self, state: State, new: bool = True, take: bool = False):
        """(Re)build every array from ``state``: particles are spatially sorted internally.

        ``new``: a state from outside the engine (not one of its own resyncs or checkpoints),
        checked to be clear of the vibrating wall. ``take``: the caller hands ``state`` over (a
        restart's own): its positions, velocities and images are dropped (``None``) as soon as
        they are copied, before the engine's other arrays are made.
        """
        check_loadable(state, self, new)
        self.t_origin = float(state.time)
        self._shear_offset = float(state.shear_offset)
        if self.vibration is not None and new:  # (the engine's own states touch the wall to round-off of the re-based phase)
            self._vibration_clear(state)
        self.geo = self._geometry(self.t_origin)
        if self.growth is not None:
            self._start_segment()
            self._choose_neighbours(state)  # (the radii have grown: cells of the list grid, skin, capacity)
        elif new and _radii_key(state.radius) != self._chosen_for:  # (other radii: larger ones need larger cells or lists)
            self._neighbours_for(state)
        elif self._cells_follow_density():
            sigma_max, periodic_len, periodic3 = self._grid_ranges(state)  # (a bed settles or lifts: the cells follow its density)
            cells = self._cells(state, sigma_max, periodic_len, periodic3, self._big_split(state, periodic_len, periodic3))
            if cells is not None:
                self.grid_cells, self.r_small, self.big_reach = cells
                self.cbuf = np.zeros(cells_buffer_size(self.grid_cells, False, self.big_reach), np.int32)
        n = self.n
        order = self._spatial_order(state)
        pending = self._pending_arrays(state, order)
        captures = 0 if self.well is None else self.well.capacity(state.radius, self.dim)
        if self.well is not None and state.captured_pairs is not None:
            self._check_capture_counts(state, captures)
        for bundle in ("part", "ev", "q", "grid", "lists", "emd", "drive", "pairs"):
            setattr(self, bundle, None)  # (a resync's old arrays go before the new ones are made; nothing below refuses the state)
        self.tag = order.astype(np.int32)
        P = np.zeros((n, L.ROW + (self.vibration is not None)))  # (the riders' column: a vibrating wall's runs only)
        for k in range(self.dim):  # (a column at a time: no temporary copy of every position)
            P[:, k] = state.position[order, k]
            P[:, 3 + k] = state.velocity[order, k]
        P[:, L.R] = state.radius[order]
        self.acc[L.A_RIDE_MASS] = self._load_riders(state, order, P) if self.vibration is not None else 0.0
        image = np.zeros((n, 3), np.int32)
        for k in range(self.dim):
            image[:, k] = state.image[order, k]
        if take:
            state.position = state.velocity = state.image = None
        self.part = Particles(P, state.mass[order], *self._spins(state, order), image, np.zeros(n, np.int32), self._tc_times(state, order))
        self._one = tuple(_one_value(a) for a in (P[:, L.R], self.part.mass))  # (the same through resyncs)
        self._new_emd(pending, state.mass, state.radius)
        self.ev = new_events(n)
        self.pairs = new_pairs(n, captures)
        self._derive_captures = self.well is not None and state.captured_pairs is None
        if self.well is not None and not self._derive_captures:
            self._load_captured(state, order)
        self.drive = self._new_drive()
        self._rebuild()
        if new and self.well is not None and not self._derive_captures:
            self._check_captured(state)

    def _cells_follow_density(self) -> bool:
        """Whether a load chooses the cells again: cells of the automatic size under gravity (a bed
        settles or lifts, and the cells follow its density)."""
        return self.mode == "cells" and self.options.cell_size is None and bool(np.any(self.grav != 0.0))

    def _new_emd(self, pending, mass: np.ndarray, radius: np.ndarray):
        """The eMD* bundle with the ``pending`` contacts (internal order, see :meth:`_pending_arrays`)
        of particles of masses ``mass`` and radii ``radius`` (any order; the bundle of size 0 without eMD*)."""
        soft = self.emd_rule is not None
        self.emd = emd_bundle(self.n if soft else 0, self.emd_rule, pending, self.dim, _species(mass, radius) if soft else None)

    def _load_riders(self, state: State, order: np.ndarray, P: np.ndarray) -> float:
        """Mark in ``P`` (internal order) the particles of ``state`` that go on riding on the
        vibrating wall, and return their total mass: those marked ``riding`` that are on it and
        move with it, to within what the stick speed allows (and the round-off of the re-based
        phase), put exactly on it (the energies booked are then those the core moves). Any other
        (the wall does not let particles stick, an updater changed the velocity) flies on."""
        speed = self.geo[L.G_WALL_STICK]
        if speed == 0.0:
            return 0.0
        mass = 0.0
        for p in np.flatnonzero(np.asarray(state.riding, bool)[order]):
            i = order[p]
            k, x, v = rider_axis(0.0, P[p, L.R], self.geo)  # (the core's own rider at local time 0)
            if abs(state.position[i, k] - x) <= speed / self.vibration.omega + 1e-12 * self.box[k] and abs(state.velocity[i, k] - v) <= speed:
                P[p, L.RIDE], P[p, k], P[p, 3 + k] = 1.0, x, v
                mass += float(state.mass[i])
        return mass

    def _spins(self, state: State, order: np.ndarray):
        """Spins and moments of inertia in internal order, or arrays of size 0 when nothing turns:
        a smooth rule at a wall and between particles, and no spin in ``state`` (32 bytes per
        particle that most runs never read). Snapshots then give zero spins and the default
        moments of inertia; a state with other spins or moments keeps them."""
        w = state.angular_velocity
        if not self._turns(w, state.inertia, state.mass, state.radius):
            return np.zeros((0, 3)), np.zeros(0)
        omega = np.zeros((self.n, 3))
        if self.dim == 3:
            for k in range(3):
                omega[:, k] = w[order, k]
        else:
            omega[:, 2] = w[order]
        return omega, state.inertia[order]

    def _turns(self, w: np.ndarray, inertia: np.ndarray, mass: np.ndarray, radius: np.ndarray) -> bool:
        """Whether the engine keeps spins and moments of inertia: a rough rule (at a wall or between
        particles), spins ``w``, moments ``inertia`` other than the default of ``mass`` and
        ``radius``, or growing radii (which keep the moments they were loaded with)."""
        rough = self.ip[L.IP_TANGENT] != L.TANGENT_SMOOTH or self.ip[L.IP_WALL_TANGENT] != L.TANGENT_SMOOTH
        return bool(rough or np.any(w) or self.growth is not None or not np.array_equal(inertia, default_inertia(mass, radius, self.dim)))

    def _tc_times(self, state: State, order: np.ndarray) -> np.ndarray:
        """Local times of the last collisions, or an array of size 0 when the TC model is off and
        ``state`` has none (nothing would read or change them: their snapshots give ``-inf``)."""
        last = state.last_collision
        if not self._keeps_last(last):
            return np.zeros(0)
        return last[order] - self.t_origin

    def _keeps_last(self, last: np.ndarray) -> bool:
        """Whether the engine keeps the times ``last`` of the last collisions: the TC model reads
        them, or some particle has collided."""
        return bool(self.ip[L.IP_TC]) or not np.all(last == -np.inf)

    def _new_drive(self) -> Drive:
        """The bath's events and the timers after a load at ``t_origin`` (off: every time ``inf``)."""
        axes = np.zeros((2, 3), np.int64)
        axes[0, : self.dim] = 1
        axes[1, 2 if self.dim == 2 else 0 :] = 1  # disks spin about z only
        epoch = np.array([self.t_origin]).view(np.uint64)[0]
        key = np.array([epoch, self.ip[L.IP_BATH_SEED], self.ip[L.IP_KICK_SEED]], np.uint64)
        drive = Drive(np.full(self.n if self.thermostat is not None else 0, np.inf), np.full(L.N_TIMERS, np.inf), np.array([self.t_origin]), key, axes)
        if self.thermostat is not None:
            bath_schedule(drive, self.fp[L.FP_BATH_RATE])
        if self.forcing is not None:
            tick = self.forcing.first_tick(self.t_origin)
            if int(self.cnt[L.C_KICK_NEXT]) == tick + 1:  # a reload at the time of the kick just done
                tick += 1
            self.cnt[L.C_KICK_NEXT] = tick
            drive.timer_t[L.TIMER_KICK] = self.forcing.tick_time(tick) - self.t_origin
        return drive

    def _pending_arrays(self, state: State, order: np.ndarray):
        """Pending eMD* contacts of ``state`` in internal order (``None``: nothing pending)."""
        if not state.has_pending:
            return None
        if self.emd_rule is None:
            raise StateError("the state has pending eMD* contacts: simulate it with the EMDStar rule it came from")
        dv = np.zeros((self.n, 3))
        dv[:, : self.dim] = state.pending_velocity[order]
        return dv, state.pending_until[order] - self.t_origin, _partners(state.pending_partner[order], _inverse(order))

    def _check_capture_counts(self, state: State, capacity: int):
        """Refuse a capture map with more partners per particle than hard cores fit in a well."""
        counts = np.bincount(state.captured_pairs.ravel(), minlength=self.n)
        if counts.size and counts.max() > capacity:
            worst = int(np.argmax(counts))
            raise StateError(
                f"particle {worst} is captured by {int(counts[worst])} partners, more than hard cores can fit "
                f"inside its square well ({capacity}): the captured pairs do not belong to this state"
            )

    def _load_captured(self, state: State, order: np.ndarray):
        """The capture map of ``state`` (user order, checked by :meth:`_check_capture_counts`) in internal order."""
        load_captured(self.pairs, _inverse(order, np.int64)[state.captured_pairs])

    def _check_captured(self, state: State):
        """A capture map from outside must be the state's geometry: the pairs inside the edge, up to
        pairs within round-off (1e-9) of it."""
        geometric = new_pairs(self.n, self.pairs.captured.shape[1])
        reach = well_reach(self.fp)
        capture_by_distance(self.part.rows, geometric, self.lists, self.geo, reach, 0.0)
        found = {tuple(sorted(p)) for p in self.tag[captured_pairs(geometric)].tolist()}
        for i, j in found ^ {tuple(p) for p in state.captured_pairs.tolist()}:
            r = float(state.contact_ratio(i, j))
            if abs(r / reach - 1.0) > 1e-9:
                inside = "inside the edge but not captured" if r < reach else "captured but beyond the edge"
                raise StateError(
                    f"particles {i} and {j} are {inside} ({r:.6g} contact distances, the edge at {reach:g}): the state's "
                    "captured_pairs belong to another state or well width (set captured_pairs=None to capture by distance)"
                )

    @property
    def well_energy(self) -> float:
        """The square wells' potential energy, :math:`-\\varepsilon` per captured pair (0 without wells)."""
        if self.well is None:
            return 0.0
        return -self.well.depth * 0.5 * float(self.pairs.captured_n.sum())

    @staticmethod
    def _list_room(sizes: np.ndarray) -> int:
        """Columns of the list rows for lists of ``sizes``: the fullest plus a margin (a list that
        outgrows it sends the run to a resync with more)."""
        return int(sizes.max() * 1.25) + 4

    def _trim_lists(self):
        """Shrink list rows to :meth:`_list_room` (lists grow again on overflow), in
        place: the rows move to the front of their buffer, which is then cut (no second copy)."""
        nbl, nbl_n, centre = self.lists
        n, old = nbl.shape
        cap = self._list_room(nbl_n)
        if cap >= old:
            return
        self.lists = None
        flat = nbl.reshape(-1)
        block = max(1, (1 << 20) // old)
        for a in range(0, n, block):  # row i moves from i * old to i * cap <= i * old: front to back is safe
            b = min(n, a + block)
            flat[a * cap : b * cap] = nbl[a:b, :cap].ravel()
        del flat
        nbl.resize((n, cap), refcheck=False)  # (no view of the buffer is left)
        self.lists = Lists(nbl, nbl_n, centre)
        self.list_capacity = cap

    def _spatial_order(self, state: State):
        """Deterministic spatial sort (cell index, then original index) for memory locality."""
        return np.argsort(self._cell_keys(lambda k: state.position[:, k]), kind="stable")

    def _cell_keys(self, column) -> np.ndarray:
        """The (row-major) index of the cell of each particle; ``column(k)``: the particles'
        coordinates along axis ``k``."""
        nc = self.grid_cells
        c = np.zeros(self.n, np.int64)
        for k in range(self.dim):
            if nc[k] > 1:
                ck = np.floor((column(k) + 0.5 * self.box[k]) / (self.box[k] / nc[k])).astype(np.int64)
                c *= nc[k]
                c += np.clip(ck, 0, nc[k] - 1)
        return c

    def _rebuild(self):
        """Bin, build neighbour lists and the calendar for particles all at local time 0."""
        n = self.n
        geo = self.geo
        while True:
            bigs = np.flatnonzero(self.part.rows[:, L.R] > self.r_small).astype(np.int32)  # (none without a split)
            self.grid = new_grid(n, self.box, self.grid_cells, bigs, self.big_reach, self.r_small)
            cap = self.list_capacity if self.mode == "list" else 1  # (0: count the lists first)
            nl = n if self.mode == "list" else 1
            self.lists = Lists(np.zeros((nl, cap), np.int32), np.zeros(nl, np.int32), np.zeros((nl, 3)))
            if self.loop.setup_events(self.part, self.ev, self.grid, self.lists, geo, self.fp, self.ip, self.cbuf, self.emd, self.drive, self.pairs, 0.0, self._derive_captures):
                break
            self.list_capacity = self._list_room(self.lists.size) if cap == 0 else int(self.list_capacity * 1.5) + 4
        if self.mode == "list":
            self._trim_lists()
        keys = np.empty(n + L.N_TIMERS)
        width, nb = calendar_shape(self._calendar_keys(keys), 0.0, self.options.events_per_bucket)  # (sorts them)
        self.q = new_queue(n + L.N_TIMERS, nb)
        queue_build(self.q, self._calendar_keys(keys), 0.0, width, nb)
        del keys
        self.acc[L.A_NOW] = 0.0
        self.acc[L.A_LAST_T] = 0.0
        self._start_sums()
        self.events_at_sync = int(self.cnt[L.C_EVENTS])

    def _calendar_keys(self, keys: np.ndarray) -> np.ndarray:
        """Fill ``keys`` with the calendar's keys: each particle's earliest event, then the timers."""
        n = self.n
        np.minimum(self.ev.pair_t, self.ev.aux_t, out=keys[:n])
        keys[n:] = self.drive.timer_t
        return keys

    def _start_sums(self):
        """The accumulators' running sums of the particles, all at local time 0: kinetic energy,
        momentum, the tensor ``sum m v (x) v`` and the energy current,
        of the committed velocities (eMD*: with the pending jumps; shear: peculiar, see
        ``_core/stress.py``), a block of rows at a time (no temporary of every particle)."""
        rows, mass, part = self.part.rows, self.part.mass, self.part
        ke, momentum, tensor, current = 0.0, np.zeros(3), np.zeros((3, 3)), np.zeros(3)
        for a in range(0, self.n, 1 << 16):
            b = min(self.n, a + (1 << 16))
            v, m = rows[a:b, L.VX : L.VZ + 1], mass[a:b]
            if self.emd_rule is not None:
                v = v + self.emd.pending_dv[a:b]
            if self.shear is not None:
                v = v.copy()
                v[:, 0] -= self.shear.rate * rows[a:b, L.Y]
            v2 = np.einsum("ij,ij->i", v, v)
            ke += 0.5 * float(m @ v2)
            momentum += np.einsum("i,ij->j", m, v)
            tensor += np.einsum("i,ij,ik->jk", m, v, v)
            energy = 0.5 * m * v2
            if len(part.omega):
                energy += 0.5 * part.inertia[a:b] * np.einsum("ij,ij->i", part.omega[a:b], part.omega[a:b])
            current += energy @ v
        self.acc[L.A_KE] = ke
        self.acc[L.A_PX : L.A_PZ + 1] = momentum
        self.acc[L.A_KT : L.A_KT + 6] = [tensor[a, b] for a, b in L.TENSOR_AXES]
        self.acc[L.A_JE : L.A_JE + 3] = current

    # ------------------------------------------------------------------ running
    @property
    def now(self) -> float:
        """Absolute time of the last processed event (or of the last resync)."""
        return self.t_origin + float(self.acc[L.A_NOW])

    def compile(self):
        """Compile the event loop now (a call that processes no event), so that timings exclude it."""
        self.loop.run_events(
            self.part, self.ev, self.q, self.grid, self.lists, self.geo, self.fp, self.ip,
            self.acc, self.cnt, self.clog, self.cbuf, self.etab, self.emd, self.drive, self.pairs, -math.inf, 0,
        )  # fmt: skip

    def advance(self, t_stop: float, max_events: int | float = math.inf) -> int:
        """Process every event before absolute time ``t_stop``, at most ``max_events`` of them.

        Returns the status code of the last loop call (``ST_TIME``, ``ST_EVENTS`` or ``ST_IDLE``).
        """
        if self._fault is not None:
            raise EngineError(f"the engine stopped at a fault of its last resync: {self._fault}")
        budget = max_events
        interval = max(int(self.options.resync_every * self.n), MIN_RESYNC_EVENTS)
        while True:
            if budget <= 0:
                return L.ST_EVENTS
            if int(self.cnt[L.C_EVENTS]) - self.events_at_sync >= interval:
                self.resync()
            chunk = int(min(budget, interval - (int(self.cnt[L.C_EVENTS]) - self.events_at_sync)))
            before = int(self.cnt[L.C_EVENTS])
            stop, growing = t_stop, self.growing
            if growing:  # stop at the segment's latest end (processed once the clock is to go past it) or count
                stop = min(t_stop, self._segment_stop())
                chunk = min(chunk, self._segment_events_left())
            status = self.loop.run_events(
                self.part, self.ev, self.q, self.grid, self.lists, self.geo, self.fp, self.ip,  # (a resync re-bases the wall's phase)
                self.acc, self.cnt, self.clog, self.cbuf, self.etab, self.emd, self.drive, self.pairs, stop - self.t_origin, chunk,
            )  # fmt: skip
            done = int(self.cnt[L.C_EVENTS]) - before
            budget -= done
            self._take_work(done)
            if growing and ((status == L.ST_TIME and stop < t_stop) or (status == L.ST_EVENTS and self._segment_events_left() == 0)):
                timed = status == L.ST_TIME
                if timed:
                    self.acc[L.A_NOW] = stop - self.t_origin
                self._end_segment(stop if timed else None)
                if not self.growing:
                    return L.ST_GROWN
                continue
            if status == L.ST_LOG_FULL:
                self._flush_log()
            elif status == L.ST_LIST_FULL:
                self.list_capacity = int(self.list_capacity * 1.5) + 4
                self.resync()
            elif status == L.ST_STALL:
                raise CollapseError(
                    f"{int(self.ip[L.IP_MAXSTALL])} events at t = {self.now!r} without the clock advancing: "
                    "inelastic collapse (or a particle coming to rest on a wall, the Zeno limit). Use the TC "
                    "model (collision tc = ...) or a velocity-dependent restitution"
                )
            elif status == L.ST_OVERLAP:
                i, j = (int(self.tag[self.cnt[c]]) for c in (L.C_BAD_I, L.C_BAD_J))
                raise EngineError(
                    f"debug check failed at t = {self.now!r}: particles {i} and {j} "
                    f"(relative contact error {self.acc[L.A_BAD]:.3g})"
                )
            elif status == L.ST_BAD_EVENT:
                particle, kind = int(self.tag[self.cnt[L.C_BAD_I]]), int(self.cnt[L.C_BAD_J])
                raise EngineError(
                    f"particle {particle} has an event of kind {kind} at t = {self.now!r}, which the "
                    f"{self.loop.name} event loop ({self.loop.neighbours}) does not handle (a bug: please report it)"
                )
            elif status != L.ST_EVENTS:
                return status

    def resync(self, t: float | None = None):
        """Stream everything to time ``t`` (default: now), re-base the clock and rebuild (deterministic).

        ``t`` may lie after the last event only if no event is due before it (the engine has
        just returned ``ST_TIME`` for a stop time ``>= t``): checkpoints resync at their exact time.
        """
        local = float(self.acc[L.A_NOW]) if t is None else float(t) - self.t_origin
        at = self.now if t is None else float(t)
        # what the load rebuilds from the particles alone goes before the rows are streamed or the
        # snapshot is made (at N = 1e6 the resync peaked 48 B per particle above the set-up with them)
        self.ev = self.q = self.grid = self.lists = self.drive = None
        if self._rebases_in_place() and self._streamed_sound(at - self.t_origin):  # (the snapshot's local time)
            self._close(local)
            self._rebase(at)
            return
        try:  # (the snapshot's way, handed over to the load: drivers whose load reads the state, or a fault)
            state = self.snapshot(at, checked=True)
        except StateError as exc:  # (a fault: the state stays readable, the engine cannot go on)
            self._fault = str(exc)
            raise
        self._reload(state, local, take=True)

    def replace(self, state: State):
        """Continue from ``state``, a changed copy of the system at a time no event is due before
        (an updater's work, see :class:`edmd.run.updaters.Updater`): a resync to a given state."""
        self._reload(state, float(state.time) - self.t_origin)

    def _reload(self, state: State, local: float, take: bool = False):
        """Close the collision log and the kinetic-energy integral at local time ``local`` (the
        time of ``state``) and rebuild every array from ``state`` (``take``: the engine's own
        snapshot, handed over to the load, see :meth:`load`)."""
        self._close(local)
        self.load(state, new=False, take=take)

    def _close(self, local: float):
        """Close the collision log and the kinetic-energy integral at local time ``local``."""
        self._flush_log()
        integrate_kinetic(self.acc, local, self.geo, self.fp[L.FP_MTOT])

    def _rebases_in_place(self) -> bool:
        """Whether a resync rebuilds from the engine's own arrays (:meth:`_rebase`): not when a load
        reads more of the state (growing radii, a vibrating wall's riders, square wells' captures,
        cells that follow a bed's density)."""
        return self.growth is None and self.vibration is None and self.well is None and not self._cells_follow_density()

    def _streamed_sound(self, local: float) -> bool:
        """Stream the rows to local time ``local`` in place (:func:`~edmd._core.snapshot.stream_rows`)
        and tell whether they, the spins, the last collisions and the pending contacts hold what
        :meth:`State.check <edmd.state.State.check>` accepts (else the resync's snapshot names the
        fault: the rows streamed to ``local`` are still the state at ``local``)."""
        reach = np.zeros(3)
        lo = np.full(3, np.inf)
        for k in range(self.dim):
            reach[k] = 0.0 if self.periodic[k] else 1.0
            lo[k] = 0.5 * self.box_user[k] * (1.0 + 2e-12)
        p, e = self.part, self.emd
        if stream_rows(p.rows, p.image, local, self.dim, self.geo, reach, lo) >= 0:
            return False
        last = p.last_collision
        return bool(np.isfinite(p.omega).all() and np.isfinite(e.pending_dv).all() and not np.isnan(e.pending_until).any() and not np.any(np.isnan(last) | (last == np.inf)))

    def _rebase(self, at: float):
        """Re-base the clock at absolute time ``at`` and rebuild from the rows streamed there
        (:meth:`_streamed_sound`): the arrays that :meth:`load` makes of the snapshot at ``at``, bit
        for bit, without making it. The rows are put in spatial order in place, a column at a time
        (a resync then needs no copy of every particle)."""
        t_old = self.t_origin
        self._shear_offset = self.shear_offset(at)
        self.t_origin = at
        self.geo = self._geometry(at)
        perm = self._new_order()
        pending = self._pending_moved(perm, t_old)
        self.part = self._particles_moved(perm, t_old)
        del perm  # (before the rebuild)
        self._new_emd(pending, self.part.mass, self.part.rows[:, L.R])
        self.ev = new_events(self.n)
        self.pairs = new_pairs(self.n, 0)
        self.drive = self._new_drive()
        self._rebuild()

    def _new_order(self) -> np.ndarray:
        """Sort the particles the load's way (cell index, then user index: :meth:`_spatial_order`),
        set the new tags and return the permutation of the rows (new row ``j`` is old row ``perm[j]``)."""
        rows, n = self.part.rows, self.n
        keys = np.empty(n, np.int64)
        keys[self.tag] = self._cell_keys(lambda k: rows[:, k])  # (in the user's order)
        order = np.argsort(keys, kind="stable")
        del keys
        index = _inverse(self.tag)
        self.tag = order.astype(np.int32)
        return index[order]

    def _particles_moved(self, perm: np.ndarray, t_old: float) -> Particles:
        """The particles in the rows' new order ``perm``, permuted in place, local times from the new
        origin (own times 0, last collisions shifted as a snapshot and a load shift them), spins and
        last collisions kept or dropped as :meth:`_spins` and :meth:`_tc_times` decide."""
        p = self.part
        rows, mass = _permuted(p.rows, perm), _permuted(p.mass, perm)
        rows[:, L.T] = 0.0
        omega, inertia = p.omega, p.inertia
        if len(omega) and not self._turns(omega[:, 2] if self.dim == 2 else omega, inertia, mass, rows[:, L.R]):
            omega, inertia = np.zeros((0, 3)), np.zeros(0)
        if self.dim == 2:
            omega[:, :2] = 0.0
        last = p.last_collision
        last += t_old  # (the snapshot's time, then the load's local time)
        last -= self.t_origin
        if not self._keeps_last(last):
            last = np.zeros(0)
        return Particles(rows, mass, _permuted(omega, perm), _permuted(inertia, perm), _permuted(p.image, perm), np.zeros(self.n, np.int32), _permuted(last, perm))

    def _pending_moved(self, perm: np.ndarray, t_old: float):
        """The pending eMD* contacts in the rows' new order ``perm`` (see :meth:`_rebase`) and local
        times from the new origin, as :meth:`_pending_arrays` makes them of a snapshot (``None``:
        nothing pending)."""
        e = self.emd
        if not np.any(e.partner >= 0):
            return None
        dv = e.pending_dv[perm]
        dv[:, self.dim :] = 0.0
        until = e.pending_until + t_old
        until -= self.t_origin
        return dv, until[perm], _partners(e.partner[perm], _inverse(perm))

    def _restore(self, state: State, saved: Saved):
        """Load ``state`` with the counters, accumulators and list capacity saved right after a
        resync to it; the maintenance schedule (``events_at_sync``) follows from the counters."""
        if saved.counters.shape != self.cnt.shape or saved.accumulators.shape != self.acc.shape:
            raise StateError(
                f"checkpoint counters/accumulators have shapes {saved.counters.shape}/{saved.accumulators.shape}, "
                f"this engine expects {self.cnt.shape}/{self.acc.shape}"
            )
        self.cnt[:] = saved.counters
        self.acc[:] = saved.accumulators
        self.list_capacity = int(saved.list_capacity)
        self.load(state, new=False, take=saved.take_state)

    # ------------------------------------------------------------------ observation
    def stream(self, t: float, which: int = POSITIONS | VELOCITIES | IMAGES):
        """User-order positions (wrapped), velocities and images at absolute time ``t`` (``which``:
        those to make, :func:`edmd._core.snapshot.stream_all`; the others have no rows)."""
        return stream_all(self.part.rows, self.part.image, self.tag, t - self.t_origin, self.dim, self.geo, which)

    def sums(self, t: float, u=(0.0, 0.0, 0.0), flow: float = 0.0, gravity=(0.0, 0.0, 0.0)) -> np.ndarray:
        """The sums over the particles at absolute time ``t`` that a thermo row needs, indexed by
        ``edmd._core.snapshot.S_*``: :func:`~edmd._core.snapshot.particle_sums` of the committed
        velocities relative to ``u`` and to the shear flow of rate ``flow``, in one pass over the
        engine's own rows (no copy of every particle, no user order)."""
        p = self.part
        pending = self.emd.pending_dv if self.emd_rule is not None else np.zeros((0, 3))  # (the bundle without eMD* holds a (0,) array)
        s = np.zeros(N_SUMS)
        particle_sums(p.rows, p.mass, p.image, pending, p.omega, p.inertia, t - self.t_origin, self.dim, self.geo,
                      _vector3(u), float(flow), _vector3(gravity), s, np.zeros(N_SUMS))  # fmt: skip
        return s

    def _user_order(self, values: np.ndarray) -> np.ndarray:
        """``values`` of the particles in internal order, in the user's order."""
        out = np.empty_like(values)
        out[self.tag] = values
        return out

    def _fields(self, t: float) -> tuple[dict, dict]:
        """The state at absolute time ``t``: its fields that are not per particle, and a function
        that makes each per-particle field (user order) when called."""
        d, n = self.dim, self.n
        omega, inertia, tlast = self.part.omega, self.part.inertia, self.part.last_collision

        one_radius, one_mass = self._one

        def radius():
            grown = 1.0 + self.fp[L.FP_GROW_LOCAL] * (t - self.t_origin)
            if one_radius is not None:  # (one radius: one number, the arrays' arithmetic)
                return filled((np.array([one_radius]) * grown)[0], (n,))
            r = self._user_order(self.part.rows[:, L.R])
            r *= grown
            return r

        def mass():
            return self._user_order(self.part.mass) if one_mass is None else filled(one_mass, (n,))

        fixed = {"box": self.box_user.copy(), "time": float(t), "periodic": self.periodic.copy(), "shear_offset": self.shear_offset(t)}
        makers = {
            "position": lambda: self.stream(t, POSITIONS)[0],
            "velocity": lambda: self.stream(t, VELOCITIES)[1],
            "image": lambda: self.stream(t, IMAGES)[2],
            "radius": radius,
            "mass": mass,
            "angular_velocity": lambda: self._user_order(omega if d == 3 else omega[:, 2]) if len(omega) else filled(0.0, (n, 3) if d == 3 else (n,)),
            "inertia": lambda: self._user_order(inertia) if len(inertia) else default_inertia(mass(), radius(), d),
            "last_collision": lambda: self._user_order(tlast + self.t_origin) if len(tlast) else filled(-np.inf, (n,)),
            "riding": lambda: self._user_order(self.part.rows[:, L.RIDE] != 0.0) if self.vibration is not None else filled(False, (n,), bool),
        }
        if self.emd_rule is not None:
            partner = self.emd.partner
            makers["pending_velocity"] = lambda: self._user_order(self.emd.pending_dv[:, :d])
            makers["pending_until"] = lambda: self._user_order(self.emd.pending_until + self.t_origin)
            makers["pending_partner"] = lambda: self._user_order(np.where(partner >= 0, self.tag[np.maximum(partner, 0)], -1).astype(np.int64))
        if self.well is not None:
            fixed["captured_pairs"] = self.tag[captured_pairs(self.pairs)]
        return fixed, makers

    def snapshot(self, t: float | None = None, checked: bool = False) -> State:
        """The exact state at absolute time ``t`` (default: now), particles in user order.

        Built without the State's checks (:meth:`State.trusted`: observers take one per output),
        unless ``checked``: resyncs check what they reload, so an engine fault (a NaN, a particle
        outside the box) stops the run there with a :class:`StateError` naming it."""
        t = self.now if t is None else t
        fixed, makers = self._fields(t)
        image = self.stream(t, IMAGES)[2].astype(np.int64)  # (a State's are int64: made first, the int32 stream gone before the rest exist)
        pos, vel, _ = self.stream(t, POSITIONS | VELOCITIES)  # (one pass for the two)
        fields = {"position": pos, "velocity": vel, "image": image, **fixed}
        fields["radius"], fields["mass"] = makers.pop("radius")(), makers.pop("mass")()
        if not len(self.part.inertia):  # (the default, of the radii and masses just made)
            makers["inertia"] = lambda: default_inertia(fields["mass"], fields["radius"], self.dim)
        fields.update({name: make() for name, make in makers.items() if name not in fields})
        if self.well is not None:  # (sorted and checked the State's way)
            return State(**fields, check_overlaps=False)
        state = State.trusted(**fields)
        if checked:
            state.check()
        return state

    def view(self, t: float | None = None) -> StateView:
        """The state at absolute time ``t`` (default: now) as a :class:`~edmd.state.StateView`:
        each per-particle field made from the engine when it is read; readable until the engine
        processes another event or reloads."""
        t = self.now if t is None else t
        fixed, makers = self._fields(t)

        def mark():  # (what changes when the engine processes an event or reloads)
            return int(self.cnt[L.C_EVENTS]), self.t_origin, id(self.part)

        made = mark()
        return StateView.of(self.n, self.dim, fixed, makers, lambda: mark() == made, lambda u, flow, gravity: self.sums(t, u, flow, gravity))

    def shear_offset(self, t: float) -> float:
        """The offset of the Lees-Edwards images above the box at absolute time ``t`` (0 without shear),
        in :math:`[-L_x/2, L_x/2)`: the core's :func:`edmd._core.images.image_offset`."""
        return 0.0 if self.shear is None else float(image_offset(t - self.t_origin, self.geo))

    def _take_work(self, events: int):
        """Move the work counted in the grid and the calendar (since they were made) to :attr:`work`."""
        counted = self.grid.shape[GI_WORK : GI_WORK + 2]
        self.work += (counted[0], counted[1], self.q.ints[QI_MOVED], events)
        counted[:] = 0
        self.q.ints[QI_MOVED] = 0

    def work_counters(self) -> dict[str, int]:
        """Work of the event loop in this process (since this engine was made or loaded; not
        checkpointed: a load does work a continuous run does not): the events processed, the
        cells scanned and the pairs tested by the predictions (list rebuilds and the layers of
        cell crossings included), and the calendar entries moved when a bucket opens or the
        calendar wraps. Per event none of them may grow with N at a fixed density.

        Example:
            >>> import edmd
            >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), 1.0, seed=2))
            >>> sim.run(max_events=5000)
            >>> w = sim.engine.work_counters()
            >>> w["events"], 1 < w["pairs_tested"] / w["events"] < 50
            (5000, True)
        """
        names = ("cells_scanned", "pairs_tested", "calendar_moves", "events")
        return {name: int(w) for name, w in zip(names, self.work)}

    def emd_counters(self) -> dict[str, int]:
        """eMD* counters (physics.md §4.8): contacts handled by A/B events, exceptions a) and b),
        and contacts resolved by the instantaneous rule."""
        c = self.cnt
        return {
            "emd_contacts": int(c[L.C_EMD_A]),
            "emd_exceptions_a": int(c[L.C_EMD_EXC_A]),
            "emd_exceptions_b": int(c[L.C_EMD_EXC_B]),
            "emd_fallbacks": int(c[L.C_EMD_FALLBACK]),
        }

    @property
    def keeps_stress(self) -> bool:
        """Whether the accumulators hold the stress tensor (:mod:`edmd._core.stress`): every run
        but those with a vibrating wall (whose riders move with it; a vibrated bed has no
        homogeneous stress)."""
        return self.vibration is None

    @property
    def keeps_energy_current(self) -> bool:
        """Whether the accumulators hold the energy current (:mod:`edmd._core.stress`): runs without
        gravity, a vibrating wall, square wells (whose potential energy it leaves out), white-noise
        forcing (whose kicks it does not follow) or shear."""
        return self.keeps_stress and not np.any(self.grav) and self.well is None and self.forcing is None and self.shear is None

    def accumulators_at(self, t: float) -> np.ndarray:
        """A copy of the accumulators (``layout.ACCUMULATORS``) carried on to absolute time ``t``
        (no event before it): the kinetic-energy integral, and the work and momentum that the
        vibrating wall gives the particles riding on it (:func:`edmd._core.loop.integrate_kinetic`)."""
        acc = self.acc.copy()
        integrate_kinetic(acc, t - self.t_origin, self.geo, self.fp[L.FP_MTOT])
        return acc

    def kinetic_integral(self, t: float) -> float:
        """Cumulative time integral of the translational kinetic energy up to absolute ``t``."""
        return float(self.accumulators_at(t)[L.A_KE_INT])

    # ------------------------------------------------------------------ collision log
    def enable_log(self, capacity: int = 65536, walls: bool = False):
        """Record every collision as ``(time, i, j, v_n, v_t)`` with user indices; with ``walls``
        also every wall impact, with ``j = -1 - (2 axis + face)`` (face 0 the lower wall) and the
        speeds relative to the wall."""
        self.clog = np.zeros((capacity, 5))
        self.ip[L.IP_LOG_CAP] = capacity
        self.ip[L.IP_LOG_WALLS] = int(walls)
        self.collision_log = []

    def _flush_log(self):
        k = int(self.cnt[L.C_LOG])
        if k and self.collision_log is not None:
            rows = self.clog[:k].copy()
            rows[:, 0] += self.t_origin
            rows[:, 1] = self.tag[rows[:, 1].astype(np.int64)]
            j = rows[:, 2].astype(np.int64)
            rows[:, 2] = np.where(j >= 0, self.tag[np.maximum(j, 0)], j)  # j < 0: wall -1 - j
            self.collision_log.append(rows)
        self.cnt[L.C_LOG] = 0

    def take_log(self) -> np.ndarray:
        """All collisions recorded since the last call, ``(k, 5)``."""
        self._flush_log()
        out = np.concatenate(self.collision_log) if self.collision_log else np.zeros((0, 5))
        self.collision_log = [] if self.collision_log is not None else None
        return out
