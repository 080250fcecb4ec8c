"""The particle state: a structure of float64 arrays, validated on construction."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ._core.geometry import worst_overlap
from ._core.layout import make_geo
from ._core.snapshot import S_MASS, S_MASS_HEIGHT, S_PX, S_TWICE_KINETIC, S_TWICE_SPIN
from .run.neighbours import overlap_grid

#: relative overlap tolerated as round-off (contacts from a running simulation sit at |r| = sigma)
OVERLAP_TOLERANCE = 1e-9


class StateError(ValueError):
    """An inconsistent or unphysical particle state (the message names the problem)."""


def _no_pending(n, d):
    """The pending eMD* contacts of a state without any: zero increments, no B event, no partner."""
    return filled(0.0, (n, d)), filled(np.inf, (n,)), filled(-1, (n,), np.int64)


def _as_float(name, value, shape):
    arr = np.array(value, dtype=np.float64, copy=True)
    if arr.shape != shape:
        raise StateError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise StateError(f"{name} is not finite (NaN or inf) at index {tuple(int(b) for b in bad)}")
    return arr


def _per_particle(name, value, n):
    """``value``, one number or one per particle, as ``(n,)`` (a ``StateError`` naming ``name`` otherwise)."""
    arr = np.asarray(value, float)
    if arr.ndim > 1 or arr.size not in (1, n):
        raise StateError(f"{name} must be one number or {n} numbers (one per particle), got shape {arr.shape}")
    return np.broadcast_to(arr.reshape(-1) if arr.ndim else arr, (n,))


def filled(value, shape, dtype=np.float64) -> np.ndarray:
    """A read-only ``shape`` array holding ``value`` everywhere, in no memory (a broadcast scalar).

    The default of the fields that most runs never set (spins, images, TC times, pending eMD*
    contacts): 96 bytes per particle that a State of a million spheres does not allocate.

    Example:
        >>> a = filled(-1, (10**6, 3), np.int64)
        >>> a.shape, int(a[5, 2]), a.flags.writeable, a.strides
        ((1000000, 3), -1, False, (0, 0))
    """
    return np.broadcast_to(np.asarray(value, dtype), shape)


def _is_filled(arr) -> bool:
    """Whether ``arr`` is a :func:`filled` constant (kept as it is: it cannot be written to)."""
    return isinstance(arr, np.ndarray) and arr.size > 0 and not any(arr.strides)


#: rows per block of the sums over particles (:func:`_by_blocks`)
SUM_BLOCK = 65536


def _by_blocks(f, *arrays):
    """``f`` of the arrays' rows, summed over blocks of :data:`SUM_BLOCK` rows: their temporaries
    are those of one block (a sum over 1e7 particles took 3 more arrays of every particle). Up to
    one block, ``f`` of all rows itself (bit for bit)."""
    n = len(arrays[0])
    total = f(*(a[:SUM_BLOCK] for a in arrays))
    for start in range(SUM_BLOCK, n, SUM_BLOCK):
        total = total + f(*(a[start : start + SUM_BLOCK] for a in arrays))
    return total


def _one_or_each(name, value, n):
    """A per-particle float field: given as one number (or a :func:`filled` constant), that number
    everywhere in no memory (:func:`filled`, checked); else a checked copy of ``n`` numbers."""
    arr = value if isinstance(value, np.ndarray) else np.asarray(value, float)
    if (arr.size == 1 and arr.ndim <= 1) or (_is_filled(arr) and arr.shape == (n,)):
        return filled(_as_float(name, arr.reshape(-1)[:1], (1,))[0], (n,))
    return _as_float(name, _per_particle(name, value, n), (n,))


def one_if_equal(values: np.ndarray) -> np.ndarray:
    """``values``, or their one value (an array of one) when they are all equal: a :class:`State`
    then keeps it in no memory (monodisperse radii or masses: 8 bytes per particle).

    Example:
        >>> one_if_equal(np.full(4, 0.5)).tolist(), one_if_equal(np.array([0.5, 0.7])).tolist()
        ([0.5], [0.5, 0.7])
    """
    return values[:1] if values.size and values.min() == values.max() else values


def _field(name, value, default, shape):
    """A float field: ``default`` everywhere (:func:`filled`) when ``value`` is ``None``, a
    :func:`filled` constant kept (its one value checked), anything else a checked copy."""
    if value is None:
        return filled(default, shape)
    if _is_filled(value) and value.shape == shape and value.dtype == np.float64:
        _as_float(name, value.flat[:1], (1,))
        return value
    return _as_float(name, value, shape)


def default_inertia(mass, radius, dim):
    r"""Moment of inertia of solid spheres (:math:`\tfrac25 mR^2`, 3D) or disks (:math:`\tfrac12 mR^2`, 2D).

    Example:
        >>> float(default_inertia(np.array([1.0]), np.array([0.5]), 3)[0])
        0.1
    """
    q = 0.4 if dim == 3 else 0.5
    mass, radius = np.asarray(mass), np.asarray(radius)
    if _is_filled(mass) and _is_filled(radius) and mass.shape == radius.shape:  # (one moment: the arrays' arithmetic on one element)
        return filled((q * mass[:1] * radius[:1] ** 2)[0], mass.shape)
    return q * mass * radius**2


@dataclasses.dataclass(eq=False)
class State:
    r"""Positions, velocities, spins, radii and masses of N spheres (3D) or disks (2D) in a box.

    The box spans :math:`[-L_k/2, L_k/2)` on each axis (HOOMD/freud convention); ``periodic``
    marks periodic axes (the others are closed by walls). Two-dimensional states have ``d = 2``
    columns; the angular velocity of a disk is the scalar :math:`\omega_z`.

    Attributes:
        position: ``(N, d)`` positions, wrapped into the box.
        velocity: ``(N, d)`` velocities.
        radius: ``(N,)`` radii (> 0).
        mass: ``(N,)`` masses (> 0).
        box: ``(d,)`` box lengths.
        time: simulation time of this state.
        angular_velocity: ``(N, 3)`` in 3D, ``(N,)`` in 2D (zeros by default).
        inertia: ``(N,)`` moments of inertia (solid spheres/disks by default).
        image: ``(N, d)`` integer periodic images (for unwrapped positions).
        periodic: ``(d,)`` periodic flags (all ``True`` by default); every other axis is
            closed by hard walls at :math:`\pm L/2`.
        last_collision: ``(N,)`` time of each particle's last collision (``-inf``: none yet), the
            memory of the TC model.
        pending_velocity: ``(N, d)`` eMD* post-collisional increments not yet applied (zeros
            where no contact is pending; physics.md §4.8).
        pending_until: ``(N,)`` time of each particle's pending eMD* B event (``inf``: none).
        pending_partner: ``(N,)`` partner of the pending contact (``-1``: none).
        riding: ``(N,)`` whether each particle rides on the vibrating wall (the sticking
            solution, :class:`edmd.VibratingWall`; ``False`` by default).
        shear_offset: Lees-Edwards boundaries (:class:`edmd.Shear`): the x displacement of the
            periodic image above the box (at :math:`y + L_y`), which slides at :math:`\dot\gamma L_y`;
            0 by default (the plain periodic images). Overlaps and distances use it.
        captured_pairs: ``(M, 2)`` pairs inside each other's square well (:class:`edmd.SquareWell`),
            each pair once as ``(i, j)``, ``i < j``, sorted; ``None``: not recorded (a square-well
            run then captures the pairs closer than the well's edge).

    Fields left at their default (``angular_velocity``, ``image``, ``last_collision``, ``riding`` and
    the pending contacts), and ``radius``, ``mass`` and ``inertia`` given as one number, are
    read-only constants that take no memory (:func:`filled`): give a new array
    (``state.image = ...``) rather than writing into them.

    While eMD* contacts are pending, ``velocity`` is the actual flight velocity (the pair's
    centre-of-mass velocity) and observables (:meth:`kinetic_energy`, :meth:`temperature`,
    :meth:`momentum`) use :attr:`committed_velocity` = ``velocity + pending_velocity``. Overlaps
    are not checked in states with pending contacts (partners overlap by design).

    Example:
        >>> s = State(position=[[0.0, 0.0], [1.5, 0.0]], velocity=[[1.0, 0.0], [0.0, 0.0]],
        ...           radius=[0.5, 0.5], mass=[1.0, 1.0], box=[10.0, 10.0])
        >>> s.dim, s.n, round(s.kinetic_energy(), 3)
        (2, 2, 0.5)
    """

    position: np.ndarray
    velocity: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    box: np.ndarray
    time: float = 0.0
    angular_velocity: np.ndarray | None = None
    inertia: np.ndarray | None = None
    image: np.ndarray | None = None
    periodic: np.ndarray | None = None
    last_collision: np.ndarray | None = None
    pending_velocity: np.ndarray | None = None
    pending_until: np.ndarray | None = None
    pending_partner: np.ndarray | None = None
    captured_pairs: np.ndarray | None = None
    riding: np.ndarray | None = None
    shear_offset: float = 0.0
    check_overlaps: dataclasses.InitVar[bool] = True

    def __post_init__(self, check_overlaps: bool = True):
        pos = np.array(self.position, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] not in (2, 3):
            raise StateError(f"position must have shape (N, 2) or (N, 3), got {pos.shape}")
        n, d = pos.shape
        if n < 1:
            raise StateError("a state needs at least one particle")
        self.position = _as_float("position", pos, (n, d))
        self.velocity = _as_float("velocity", self.velocity, (n, d))
        self.radius = _one_or_each("radius", self.radius, n)
        self.mass = _one_or_each("mass", self.mass, n)
        self.box = _as_float("box", self.box, (d,))
        self.time = float(self.time)
        if not math.isfinite(self.time):
            raise StateError("time is not finite")
        spin_shape = (n, 3) if d == 3 else (n,)
        self.angular_velocity = _field("angular_velocity", self.angular_velocity, 0.0, spin_shape)
        inertia = default_inertia(self.mass, self.radius, d) if self.inertia is None else self.inertia
        self.inertia = _one_or_each("inertia", inertia, n)
        image = filled(0, (n, d), np.int64) if self.image is None else np.asarray(self.image)
        if image.shape != (n, d) or not np.issubdtype(image.dtype, np.integer):
            raise StateError(f"image must be integers of shape {(n, d)}, got {image.dtype} {image.shape}")
        self.image = image if _is_filled(image) and image.dtype == np.int64 else image.astype(np.int64, copy=True)
        periodic = np.ones(d, bool) if self.periodic is None else np.asarray(self.periodic, bool)
        if periodic.shape != (d,):
            raise StateError(f"periodic must have shape {(d,)}, got {periodic.shape}")
        self.periodic = periodic.copy()
        last = self.last_collision
        last = filled(-np.inf, (n,)) if last is None else last if _is_filled(last) else np.array(last, np.float64)
        if last.shape != (n,) or np.any(np.isnan(last)) or np.any(last == np.inf):
            raise StateError(f"last_collision must be {n} times (or -inf), got shape {last.shape}")
        self.last_collision = last
        riding = filled(False, (n,), bool) if self.riding is None else self.riding if _is_filled(self.riding) else np.array(self.riding)
        if riding.shape != (n,) or not (riding.dtype == bool or np.all((riding == 0) | (riding == 1))):
            raise StateError(f"riding must be {n} booleans, got {riding.dtype} {riding.shape}")
        self.riding = riding if riding.dtype == bool else riding.astype(bool)
        self._set_shear_offset(d)
        self._set_pending(n, d)
        self._set_captured(n)
        self._check_values()
        if check_overlaps and not self.has_pending:
            self.check_no_overlap()

    @classmethod
    def trusted(cls, **fields) -> State:
        """A State of arrays that are already what :meth:`__post_init__` would make of them
        (fresh, of the right shapes and dtypes, consistent): no conversion, copy or check.

        For the engine's snapshots (:meth:`edmd.run.engine.Engine.snapshot`), whose validation
        cost more than the run between two thermo rows of a short run; everything else builds
        States the checked way. Every field is given except the pending eMD* contacts (default:
        none) and ``captured_pairs`` (default: ``None``).
        """
        state = object.__new__(cls)
        n, d = fields["position"].shape
        state.pending_velocity, state.pending_until, state.pending_partner = _no_pending(n, d)
        state.captured_pairs = None
        state.shear_offset = 0.0
        for name, value in fields.items():
            setattr(state, name, value)
        return state

    def _set_shear_offset(self, d):
        offset = float(self.shear_offset)
        if not math.isfinite(offset):
            raise StateError(f"shear_offset is not finite: {offset}")
        if offset != 0.0 and (d < 2 or not (self.periodic[0] and self.periodic[1])):
            raise StateError("shear_offset (Lees-Edwards images) needs periodic x and y axes")
        self.shear_offset = offset

    def _set_captured(self, n):
        if self.captured_pairs is None:
            return
        pairs = np.asarray(self.captured_pairs)
        if pairs.size == 0:
            pairs = pairs.reshape(0, 2)
        if pairs.ndim != 2 or pairs.shape[1] != 2 or not (pairs.size == 0 or np.issubdtype(pairs.dtype, np.integer)):
            raise StateError(f"captured_pairs must be integer pairs of shape (M, 2), got {pairs.dtype} {pairs.shape}")
        pairs = np.sort(pairs.astype(np.int64), axis=1)
        bad = np.flatnonzero((pairs[:, 0] < 0) | (pairs[:, 1] >= n) | (pairs[:, 0] == pairs[:, 1]))
        if bad.size:
            raise StateError(f"captured pair {pairs[bad[0]].tolist()} is not two distinct particles of [0, {n})")
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
        if len(pairs) > 1 and np.any(np.all(pairs[1:] == pairs[:-1], axis=1)):
            raise StateError("captured_pairs lists a pair twice")
        self.captured_pairs = pairs

    def _set_pending(self, n, d):
        fields = (self.pending_velocity, self.pending_until, self.pending_partner)
        if all(f is None or _is_filled(f) for f in fields):
            none = _no_pending(n, d)
            if all(f is None or (f.shape == g.shape and f.flat[0] == g.flat[0]) for f, g in zip(fields, none)):
                self.pending_velocity, self.pending_until, self.pending_partner = none
                return
        dv = np.zeros((n, d)) if self.pending_velocity is None else self.pending_velocity
        self.pending_velocity = _as_float("pending_velocity", dv, (n, d))
        until = np.full(n, np.inf) if self.pending_until is None else np.array(self.pending_until, np.float64)
        partner = np.full(n, -1) if self.pending_partner is None else np.asarray(self.pending_partner)
        if until.shape != (n,) or partner.shape != (n,) or not np.issubdtype(partner.dtype, np.integer):
            raise StateError(f"pending_until and pending_partner must have shape ({n},) (partner: integers)")
        has = partner >= 0
        bad = np.flatnonzero((partner < -1) | (partner >= n) | (partner == np.arange(n)) | (has != np.isfinite(until)) | np.isnan(until))
        bad = np.union1d(bad, np.flatnonzero(~has & np.any(self.pending_velocity != 0.0, axis=1)))
        if bad.size:
            i = int(bad[0])
            raise StateError(
                f"inconsistent pending eMD* contact of particle {i}: partner {int(partner[i])}, B event at "
                f"{until[i]!r}, increment {self.pending_velocity[i].tolist()} (a partner in [0, N) needs a finite time)"
            )
        self.pending_until = until
        self.pending_partner = partner.astype(np.int64)

    # ------------------------------------------------------------------ checks
    def check(self):
        """Raise :class:`StateError` naming the first problem of a :meth:`trusted` state: a position,
        velocity, spin or pending increment that is not finite, a NaN time (or a last collision at
        ``+inf``), a
        radius, mass or moment of inertia that is not positive, a particle outside the box (the
        checks of a new State but the overlaps), or a field whose shape is not that of the
        positions' ``(N, d)`` (a field replaced after the State was made)."""
        self._check_shapes()
        for name in ("position", "velocity", "angular_velocity", "pending_velocity"):
            values = getattr(self, name)
            bad = np.flatnonzero(~np.isfinite(values).reshape(self.n, -1).all(axis=1))
            if bad.size:
                raise StateError(f"{name} is not finite (NaN or inf) at particle {int(bad[0])}: {values[bad[0]].tolist()}")
        for name, forbidden in (("last_collision", np.inf), ("pending_until", np.nan)):
            values = getattr(self, name)
            bad = np.flatnonzero(np.isnan(values) | (values == forbidden))
            if bad.size:
                raise StateError(f"{name} of particle {int(bad[0])} is {float(values[bad[0]])!r}")
        self._check_values()

    def _check_shapes(self):
        pos = self.position
        if not isinstance(pos, np.ndarray) or pos.ndim != 2 or pos.shape[1] not in (2, 3) or len(pos) < 1:
            raise StateError(f"position must be an array of shape (N, 2) or (N, 3), got {np.shape(pos)}")
        n, d = pos.shape
        shapes = {"velocity": (n, d), "radius": (n,), "mass": (n,), "inertia": (n,), "image": (n, d), "box": (d,), "periodic": (d,)}
        shapes.update(angular_velocity=(n, 3) if d == 3 else (n,), last_collision=(n,), riding=(n,), pending_velocity=(n, d), pending_until=(n,), pending_partner=(n,))
        for name, shape in shapes.items():
            value = getattr(self, name)
            if value is not None and np.shape(value) != shape:  # (None: a default a trusted State left out)
                raise StateError(f"{name} must have shape {shape} for {n} particles in {d}D, got {np.shape(value)}")

    def _check_values(self):
        for name in ("radius", "mass", "inertia"):
            arr = getattr(self, name)
            bad = np.flatnonzero(arr <= 0.0)
            if bad.size:
                raise StateError(f"{name} must be positive: particle {int(bad[0])} has {name} {float(arr[bad[0]])!r}")
        if np.any(self.box <= 0.0):
            raise StateError(f"box lengths must be positive, got {self.box.tolist()}")
        big = int(np.argmax(self.radius))
        short = np.flatnonzero(self.periodic & (self.box <= 2.0 * self.radius[big]))
        if short.size:
            k = int(short[0])
            raise StateError(
                f"particle {big} (diameter {2.0 * float(self.radius[big])!r}) does not fit the periodic box length "
                f"{float(self.box[k])!r} (axis {'xyz'[k]}): it would overlap its own periodic image"
            )
        out = np.zeros(self.n, bool)
        for k in range(self.dim):  # (one axis at a time: no temporary copies of every position)
            x, reach, lo = self.position[:, k], 0.0 if self.periodic[k] else self.radius, 0.5 * self.box[k] * (1.0 + 2e-12)
            out |= (x - reach < -lo) | (x + reach > lo)
        out = np.flatnonzero(out)
        if out.size:
            i = out[0]
            raise StateError(
                f"particle {i} at {self.position[i].tolist()} (radius {self.radius[i]}) lies outside the box "
                f"[-L/2, L/2) with L = {self.box.tolist()}"
            )

    def contact_ratio(self, i, j):
        """:math:`r_{ij}/(R_i + R_j)` of particles ``i`` and ``j`` (indices, or arrays of them), the
        distance by the minimum image on the periodic axes.

        Example:
            >>> import edmd
            >>> s = edmd.lattice(8, 0.1, kind="sc")       # 2 x 2 x 2 sites, spacing a: a^3 = (pi / 6) / 0.1
            >>> bool(np.isclose(s.contact_ratio(0, 1), (np.pi / 6 / 0.1) ** (1 / 3)))
            True
        """
        d = self.position[i] - self.position[j]
        if self.shear_offset != 0.0:  # the images above and below slide along x (Lees-Edwards)
            d = np.array(d, float)
            d[..., 0] -= np.round(d[..., 1] / self.box[1]) * self.shear_offset
        d = d - np.where(self.periodic, self.box * np.round(d / self.box), 0.0)
        return np.sqrt(np.sum(d * d, axis=-1)) / (self.radius[i] + self.radius[j])

    def overlapping_pair(self, rel_tol: float = OVERLAP_TOLERANCE):
        """The most overlapping pair ``(i, j, distance)`` beyond ``rel_tol``, or ``None``."""
        box, half = self.geometry()
        shear = None if self.shear_offset == 0.0 else (0.0, self.shear_offset)
        grid = overlap_grid(self.radius, box, np.r_[self.periodic, [False] * (3 - self.dim)], self.dim, shear=shear is not None)
        points = self.position if self.dim == 3 and self.position.flags.c_contiguous else self.points  # (no copy of 3D positions)
        i, j, d = worst_overlap(points, np.ascontiguousarray(self.radius), make_geo(box, half, shear=shear), grid, rel_tol)
        return None if i < 0 else (int(i), int(j), float(d))

    def check_no_overlap(self, rel_tol: float = OVERLAP_TOLERANCE):
        """Raise :class:`StateError` naming the deepest overlapping pair, if any."""
        pair = self.overlapping_pair(rel_tol)
        if pair is not None:
            i, j, d = pair
            raise StateError(
                f"particles {i} and {j} overlap: centre distance {d:.12g} < contact distance "
                f"{self.radius[i] + self.radius[j]:.12g}"
            )

    # ------------------------------------------------------------------ views
    @property
    def n(self) -> int:
        """Number of particles."""
        return self.position.shape[0]

    @property
    def dim(self) -> int:
        """Spatial dimension (2 or 3)."""
        return self.position.shape[1]

    @property
    def points(self) -> np.ndarray:
        """``(N, 3)`` positions (``z = 0`` in 2D), as freud expects them."""
        out = np.zeros((self.n, 3))
        out[:, : self.dim] = self.position
        return out

    @property
    def freud_box(self) -> list[float]:
        """Box in freud's ``Box.from_box`` form: ``[Lx, Ly]`` (2D) or ``[Lx, Ly, Lz]`` (3D).

        With Lees-Edwards images (``shear_offset`` :math:`\\delta \\ne 0`) the triclinic box
        ``[Lx, Ly, Lz, xy, 0, 0]`` (``Lz = 0`` in 2D) whose tilt :math:`xy = \\delta / L_y` places the
        images above at :math:`x + \\delta`, so freud's neighbour queries see the sliding images
        (freud wraps the points into it).

        Example:
            >>> State([[0.0, 0.0]], [[0.0, 0.0]], 0.5, 1.0, [10.0, 8.0], shear_offset=2.0).freud_box
            [10.0, 8.0, 0.0, 0.25, 0.0, 0.0]
        """
        if self.shear_offset == 0.0:
            return self.box.tolist()
        lz = float(self.box[2]) if self.dim == 3 else 0.0
        return [float(self.box[0]), float(self.box[1]), lz, self.shear_offset / float(self.box[1]), 0.0, 0.0]

    @property
    def volume(self) -> float:
        """Box volume (area in 2D)."""
        return float(np.prod(self.box))

    @property
    def unwrapped_position(self) -> np.ndarray:
        """Positions with periodic images added back (for displacements)."""
        return self.position + self.image * self.box

    def geometry(self):
        """Internal 3-component box and minimum-image half-lengths (``inf`` on open axes)."""
        box = np.ones(3)
        box[: self.dim] = self.box
        half = np.full(3, np.inf)
        half[: self.dim] = np.where(self.periodic, 0.5 * self.box, np.inf)
        return box, half

    # ------------------------------------------------------------------ observables
    def particle_volume(self) -> np.ndarray:
        """Volume (3D) or area (2D) of each particle."""
        if self.dim == 3:
            return 4.0 / 3.0 * np.pi * self.radius**3
        return np.pi * self.radius**2

    @property
    def packing_fraction(self) -> float:
        r"""Packing fraction :math:`\eta = \sum_i v_i / V`."""
        return float(self.particle_volume().sum() / self.volume)

    @property
    def has_pending(self) -> bool:
        """Whether eMD* contacts are pending (some particle awaits its B event)."""
        return bool(np.any(self.pending_partner >= 0))

    @property
    def committed_velocity(self) -> np.ndarray:
        r"""Velocities with pending eMD* increments applied, :math:`\mathbf v_i + \boldsymbol\Delta_i` (physics.md §4.8): a new array."""
        v = self._committed()
        return v.copy() if v is self.velocity else v

    def _committed(self) -> np.ndarray:
        """:attr:`committed_velocity`, or ``velocity`` itself when nothing is pending (no copy: for reading)."""
        return self.velocity if _is_filled(self.pending_velocity) and not self.pending_velocity.flat[0] else self.velocity + self.pending_velocity

    def kinetic_energy(self) -> float:
        """Translational kinetic energy (of the committed velocities)."""
        return 0.5 * float(_by_blocks(lambda m, v: np.sum(m[:, None] * v**2), self.mass, self._committed()))

    def rotational_energy(self) -> float:
        """Rotational kinetic energy."""
        w = self.angular_velocity
        if _is_filled(w) and not w.flat[0]:  # (no spins: nothing to square)
            return 0.0
        return 0.5 * float(_by_blocks(lambda inertia, w: np.sum(inertia * (w**2 if w.ndim == 1 else (w**2).sum(axis=1))), self.inertia, w))

    def rotational_temperature(self) -> float:
        r"""Rotational temperature :math:`T_{\rm rot} = \frac{1}{d_r N}\sum_i I_i\omega_i^2` (:math:`d_r` = 3 in 3D, 1 in 2D)."""
        return 2.0 * self.rotational_energy() / ((3 if self.dim == 3 else 1) * self.n)

    def potential_energy(self, gravity) -> float:
        r"""Potential energy :math:`-\sum_i m_i\,\mathbf G\cdot\mathbf r_i` in uniform gravity (unwrapped positions)."""
        if gravity is None or not np.any(gravity):  # (no positions read: -0.0, as the sum gives)
            return -0.0
        return -float(self.mass @ (self.unwrapped_position @ np.asarray(gravity, float)))

    def total_mass(self) -> float:
        """Total mass :math:`M = \\sum_i m_i`.

        Example:
            >>> import edmd
            >>> round(edmd.lattice(8, 0.1, density=2.0).total_mass(), 9)  # 8 spheres of diameter 1: 8 * 2 pi / 6
            8.37758041
        """
        return float(self.mass.sum())

    def momentum(self) -> np.ndarray:
        """Total linear momentum (of the committed velocities)."""
        return _by_blocks(lambda m, v: (m[:, None] * v).sum(axis=0), self.mass, self._committed())

    def temperature(self) -> float:
        r"""Translational granular temperature :math:`T = \frac{1}{dN}\sum_i m_i|\mathbf v_i-\mathbf u|^2` (:math:`k_B=1`)."""
        mass = self.mass
        u = self.momentum() / mass.sum()
        return float(_by_blocks(lambda m, v: np.sum(m[:, None] * (v - u) ** 2), mass, self._committed()) / (self.dim * self.n))

    def copy(self) -> State:
        """Deep copy."""
        return dataclasses.replace(self, check_overlaps=False)


#: the per-particle fields of a :class:`State`
PARTICLE_FIELDS = (
    "position", "velocity", "radius", "mass", "angular_velocity", "inertia", "image", "last_collision", "riding",
    "pending_velocity", "pending_until", "pending_partner",
)  # fmt: skip


class StateView(State):
    """A :class:`State` whose per-particle fields are made when read, a new array at every read
    (none is kept): what an engine gives the observers that read their state only while they
    fire (:attr:`edmd.run.observer.Observer.reads_once`; ``Simulation.state_view()``), instead of a
    copy of every particle. Everything a State computes works on it; an engine's view sums its
    total mass, momentum, energies and temperature over the engine's own arrays in one pass each
    (:meth:`of`'s ``sums``: equal to a copy's to round-off), without making a field. :meth:`copy` (and
    ``dataclasses.replace``) make a plain State. It is readable only as long as its source is
    unchanged (``RuntimeError`` afterwards: take ``Simulation.state`` to keep a state). An engine's
    view gives its images as the engine keeps them, int32 (a copy's are int64).

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(64, 0.2), 1.0, seed=1))
        >>> view = sim.state_view()
        >>> round(view.temperature(), 12), view.velocity is view.velocity
        (1.0, False)
    """

    def __new__(cls, *args, **fields):
        # (called with a State's fields, as dataclasses.replace does: a plain State)
        return State(*args, **fields)

    @classmethod
    def of(cls, n: int, dim: int, fixed: dict, makers: dict, valid, sums=None) -> StateView:
        """The view of ``n`` particles in ``dim`` dimensions: ``fixed`` the fields that are not
        per particle (box, time, ...), ``makers`` a function per particle field (the pending eMD*
        contacts default to none), ``valid()`` whether its source still holds.

        ``sums(u, flow, gravity)``, if given, sums over the particles in one pass of the source's
        own (the entries of :func:`edmd._core.snapshot.particle_sums`): the total mass, momentum,
        energies and temperature then read no field (a thermo row made four copies of the
        velocities, each scattered into the user's order)."""
        view = object.__new__(cls)
        view.__dict__.update(fixed)
        view.__dict__.setdefault("captured_pairs", None)
        view._n, view._dim, view._valid, view._sums, view._flow, view._summed = n, dim, valid, sums, 0.0, {}
        none = dict(zip(("pending_velocity", "pending_until", "pending_partner"), _no_pending(n, dim)))
        view._makers = {**{name: (lambda value=value: value) for name, value in none.items()}, **makers}
        return view

    def _check_valid(self):
        if not self._valid():
            raise RuntimeError("this state view is out of date (the simulation went on): take Simulation.state to keep a state")

    def _make(self, name: str) -> np.ndarray:
        self._check_valid()
        return self._makers[name]()

    def _summed_over(self, u=(0.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0)) -> np.ndarray:
        """The source's sums (:meth:`of`) relative to ``u`` and this view's flow, kept for the view's life."""
        self._check_valid()
        key = (tuple(map(float, u)), tuple(map(float, gravity)))
        if key not in self._summed:
            self._summed[key] = self._sums(u, self._flow, gravity)
        return self._summed[key]

    def in_flow(self, rate: float, velocity) -> StateView:
        r"""This view seen in a shear flow :math:`\dot\gamma y\hat{\mathbf x}` of rate ``rate``: its
        velocities made by ``velocity()`` when read (the peculiar velocities, which
        :meth:`edmd.Shear.peculiar_state` gives it) and its sums relative to the flow.

        Example:
            >>> import edmd
            >>> shear = edmd.Shear(rate=0.5)
            >>> s = shear.with_profile(edmd.maxwell_boltzmann(edmd.lattice(64, 0.2), 1.0, seed=1))
            >>> view = shear.peculiar_state(edmd.Simulation(s, shear=shear).state_view())  # (view.in_flow(0.5, ...))
            >>> round(view.temperature(), 12), bool(abs(view.velocity - s.velocity).max() > 0.1)
            (1.0, True)
        """
        fixed = {k: v for k, v in self.__dict__.items() if not k.startswith("_")}
        view = StateView.of(self._n, self._dim, fixed, {**self._makers, "velocity": velocity}, self._valid, self._sums)
        view._flow = float(rate)
        return view

    def total_mass(self) -> float:
        if self._sums is None:
            return super().total_mass()
        return float(self._summed_over()[S_MASS])

    def momentum(self) -> np.ndarray:
        if self._sums is None:
            return super().momentum()
        return self._summed_over()[S_PX : S_PX + self._dim].copy()

    def kinetic_energy(self) -> float:
        if self._sums is None:
            return super().kinetic_energy()
        return 0.5 * float(self._summed_over()[S_TWICE_KINETIC])

    def temperature(self) -> float:
        if self._sums is None:
            return super().temperature()
        s = self._summed_over()
        u = s[S_PX : S_PX + self._dim] / s[S_MASS]
        return float(self._summed_over(u)[S_TWICE_KINETIC] / (self._dim * self._n))

    def rotational_energy(self) -> float:
        if self._sums is None:
            return super().rotational_energy()
        return 0.5 * float(self._summed_over()[S_TWICE_SPIN])

    def potential_energy(self, gravity) -> float:
        if self._sums is None or gravity is None or not np.any(gravity):
            return super().potential_energy(gravity)
        return -float(self._summed_over(gravity=gravity)[S_MASS_HEIGHT])

    @property
    def n(self) -> int:
        return self._n

    @property
    def dim(self) -> int:
        return self._dim

    def copy(self) -> State:
        """A plain :class:`State` of the same fields (every one made; images as a State's, int64)."""
        fields = {name: self._make(name) for name in PARTICLE_FIELDS}
        fields["image"] = fields["image"].astype(np.int64, copy=False)
        return State.trusted(**fields, **{k: v for k, v in self.__dict__.items() if not k.startswith("_")})


def _made(name: str) -> property:
    return property(lambda self: self._make(name), doc=f"``{name}``, made when read.")


for _name in PARTICLE_FIELDS:
    setattr(StateView, _name, _made(_name))


def rescale_temperature(state: State, kT: float) -> State:
    """Scale ``state``'s velocities about their mean (and pending eMD* increments) to temperature ``kT``, in place.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), kT=2.0, seed=1)
        >>> round(rescale_temperature(s, 1.0).temperature(), 12)
        1.0
    """
    temperature = state.temperature()
    if not temperature > 0:
        raise ValueError(f"rescaling the velocities at t = {state.time}: the temperature is {temperature}, nothing to rescale")
    scale = np.sqrt(kT / temperature)
    u = state.momentum() / state.mass.sum()
    if not state.has_pending:
        state.velocity = u + scale * (state.velocity - u)
        return state
    state.velocity = u + scale * (state.velocity + state.pending_velocity - u) - scale * state.pending_velocity
    state.pending_velocity = scale * state.pending_velocity
    return state
