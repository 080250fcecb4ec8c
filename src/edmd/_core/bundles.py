"""Named bundles of the core's arrays: what travels into the compiled functions, field by field.

Each bundle is a :class:`typing.NamedTuple` of arrays only (a float tuple in a bundle made every call taking it slow).
Numba types them as named tuples: a field is read by name (``ev.pair_t``) at no run-time cost,
and unpacking keeps working. No numeric indexing of bundles is left in the core: a new field
goes at the end of its bundle and everything that unpacks the whole bundle is updated with it.

Example:
    >>> import numpy as np
    >>> ev = new_events(4)
    >>> ev.pair_j.dtype, float(ev.aux_t[0])
    (dtype('int32'), inf)
"""

from typing import NamedTuple

import numpy as np


class Particles(NamedTuple):
    """The particles in internal (spatially sorted) order; times are local (see engine)."""

    rows: np.ndarray  #: (N, ROW) float64: position, velocity, own time stamp, radius (layout.X...R)
    mass: np.ndarray  #: (N,)
    omega: np.ndarray  #: (N, 3) angular velocity
    inertia: np.ndarray  #: (N,) moment of inertia
    image: np.ndarray  #: (N, 3) int32 periodic image counters
    count: np.ndarray  #: (N,) int32 event counter (validates partners' predictions)
    last_collision: np.ndarray  #: (N,) local time of the last collision (TC model)


class Events(NamedTuple):
    """The two candidate events of each particle (Lubachevsky's scheme, physics.md §1.5)."""

    pair_t: np.ndarray  #: (N,) time of the earliest predicted contact
    pair_j: np.ndarray  #: (N,) int32 its partner (-1: none)
    pair_c: np.ndarray  #: (N,) int32 the partner's event counter at prediction time
    aux_t: np.ndarray  #: (N,) time of the single-particle event
    aux_k: np.ndarray  #: (N,) int32 its kind (layout.AUX_*)


class Pairs(NamedTuple):
    """Pair interactions with several event kinds and per-pair state (square wells, :mod:`.wells`);
    arrays of size 0 in other runs. Kept out of :class:`Events`: the bundles that the called cell
    functions take by value stay small (three more arrays in ``Events`` halved the speed of
    cell-mode gases, measured)."""

    kind: np.ndarray  #: (N,) int32 the kind of each particle's pair event (layout.PAIR_*)
    captured: np.ndarray  #: (N, K) int32 the partners inside each particle's square well
    captured_n: np.ndarray  #: (N,) int32 how many


class Grid(NamedTuple):
    """Cells ("sectors", physics.md §1.4) as linked lists."""

    head: np.ndarray  #: (cells + bigs,) int32 first particle of each cell (-1: empty), then the big particles (``cells.GI_BIGS``)
    link: np.ndarray  #: (N,) int32 next particle in the same cell (-1: last)
    cell: np.ndarray  #: (N,) int32 cell of each particle
    shape: np.ndarray  #: (7,) int64 cells per axis, the work counters (cells.GI_WORK: cells scanned, pairs tested), the bigs' number and reach
    size: np.ndarray  #: (9,) float64 cell lengths, their inverses, the largest and smallest radius (``cells.GF_RMAX``, ``GF_RMIN``), the largest that is not big


class Lists(NamedTuple):
    """Verlet neighbour lists with a skin (physics.md §1.4)."""

    members: np.ndarray  #: (N, capacity) int32 neighbours of each particle
    size: np.ndarray  #: (N,) int32 how many
    centre: np.ndarray  #: (N, 3) where each list was built (its shell's centre)


class Calendar(NamedTuple):
    """The event calendar (see :mod:`.queue`)."""

    key: np.ndarray  #: (N,) event time of each particle
    loc: np.ndarray  #: (N,) int32 bucket of each particle (or its heap slot)
    link: np.ndarray  #: (N,) int32 next particle in the bucket
    back: np.ndarray  #: (N,) int32 previous particle in the bucket
    head: np.ndarray  #: (buckets + 1,) int32 first particle of each bucket (last: overflow)
    heap: np.ndarray  #: (N,) int32 binary heap of the current bucket
    ints: np.ndarray  #: (5,) int64 QI_* scalars
    floats: np.ndarray  #: (3,) float64 QF_* scalars


class EMDStarData(NamedTuple):
    """Pending eMD* contacts and the matrix-of-restitution table (physics.md §4.8, :mod:`.emdstar`)."""

    pending_dv: np.ndarray  #: (N, 3) pending velocity increment (zero: none); (0,) without eMD* (a type the predictors prune by)
    pending_until: np.ndarray  #: (N,) local time of the pending B event (inf: none)
    partner: np.ndarray  #: (N,) int32 partner of the pending contact (-1: none)
    values: np.ndarray  #: lookup-table node values (:mod:`.lookup`)
    table_grid: np.ndarray  #: (16,) table geometry (an array: a float tuple in a bundle made calls slow)
    central: np.ndarray  #: central-collision table
    central_grid: np.ndarray  #: (4,) its geometry
    weights: np.ndarray  #: scratch of the table lookup (lookup.SCRATCH_SHAPE)
    solver: np.ndarray  #: (13, 3) scratch of the direct two-body solver
    work: np.ndarray  #: (11, 3) scratch of the lab-frame update (r1, r2, v1, v2, r1A, r2A, V, D1, D2, spins after a frictional contact)
    friction: np.ndarray  #: scratch of the frictional two-body solver (twobody_friction.SCRATCH_ROWS, N_STATE)
    friction_table: np.ndarray  #: (n_c, n_s, 2) the hard-limit table of frictional contacts (:mod:`.friction_lookup`)
    friction_grid: np.ndarray  #: (8,) its geometry (n_c = 0: no table)
    pair_values: np.ndarray  #: the pair table of the one species (:func:`.lookup.pair_restitution`)
    pair_grid: np.ndarray  #: (lookup.PAIR_GRID,) its geometry (NaN species: no table)


class Drive(NamedTuple):
    """What drives the system: the Andersen bath's per-particle events (:mod:`.bath`) and the
    global timers in the calendar (:mod:`.forcing`; timer ``k`` is calendar entry ``N + k``)."""

    bath_t: np.ndarray  #: (N,) local time of each particle's next bath event (inf: no bath)
    timer_t: np.ndarray  #: (N_TIMERS,) local time of each timer's next tick (inf: off)
    origin: np.ndarray  #: (1,) the absolute time of local time 0 (tick times are absolute)
    key: np.ndarray  #: (3,) uint64: the bit pattern of the load time (the RNG epoch), bath seed, forcing seed
    axes: np.ndarray  #: (2, 3) int64: velocity (row 0) and spin (row 1) components that random draws touch


class Spins(NamedTuple):
    """Rotation and contact history of the frictional DEM (:mod:`.dem`); arrays with one row (and
    one history column) when the contacts are frictionless."""

    omega: np.ndarray  #: (N, 3) angular velocity (2D: z only)
    omega_p: np.ndarray  #: (N, 3) angular velocity extrapolated to the end of the step (for the damping)
    alpha: np.ndarray  #: (N, 3) angular acceleration
    inertia: np.ndarray  #: (N,) moment of inertia
    hist: np.ndarray  #: (N, K, 3) tangential spring of each half-list entry
    hist_old: np.ndarray  #: (N, K, 3) the springs of the previous list (carried into a new one)
    nbl_old: np.ndarray  #: (N, K) int32 the previous list
    nbl_n_old: np.ndarray  #: (N,) int32 its row lengths
    dv: np.ndarray  #: (N, 3) the velocity jumps of this step's contact onsets, applied after the force loop
    dw: np.ndarray  #: (N, 3) the same for the angular velocities


def new_events(n: int) -> Events:
    """No event predicted yet for ``n`` particles."""
    return Events(np.full(n, np.inf), np.full(n, -1, np.int32), np.zeros(n, np.int32), np.full(n, np.inf), np.zeros(n, np.int32))


def new_pairs(n: int, captures: int = 0) -> Pairs:
    """Pair-event kinds and an empty capture map of ``captures`` partners per particle (none: size 0)."""
    m = n if captures > 0 else 0
    return Pairs(np.zeros(m, np.int32), np.zeros((m, captures), np.int32), np.zeros(m, np.int32))
