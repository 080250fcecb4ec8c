r"""Force-based molecular dynamics (DEM) of soft spheres and disks: the ground truth of eMD*.

:class:`DEMSimulation` integrates Newton's equations of ``N`` frictionless soft particles with
the contact laws of :mod:`edmd.physics.contact` (linear dashpot, viscoelastic Hertz), in a periodic box,
by velocity Verlet with a half neighbour list built from a cell grid (compiled core:
:mod:`edmd._core.dem`). A contact ends when its force vanishes (the force is clipped at zero,
physics.md §2.2), like the two-body solver of :mod:`edmd.physics.twobody`.

It is a :class:`~edmd.run.simulation.Simulation` with a force-integrating engine: the same
:class:`~edmd.state.State`, ``run(until_time=...)``, ``add(observer)``, ``totals()``, so
:class:`~edmd.files.thermo.Thermo` and :class:`~edmd.files.trajectory.Trajectory` work unchanged. Observers
fire at their exact times: the step size is shortened evenly inside each interval that ends at
an observation time. Counters: ``events`` are time steps, ``collisions`` contact onsets; the
virial is the time integral of :math:`\sum_{\rm pairs} r_{ij}F_{ij}` (pressure as in physics.md §5.3)
and the dissipated energy the integral of :math:`\sum (F - F_{\rm el})\dot\xi`.

**Time step.** ``dt`` defaults to the shortest expected contact duration divided by
``steps_per_contact`` (50): the head-on duration of the lightest pair (dashpot, independent of
speed) or, for Hertz, of the lightest masses with the largest radii at the impact speed
``impact_speed`` (default: twice the largest particle speed, plus the free-fall speed across
the box with gravity). Velocity Verlet is second order for smooth forces; the force jump of a
dissipative dashpot at contact onset and the :math:`\sqrt\xi` onset of viscoelastic damping
lower the order of a single collision (measured in ``tests/test_dem.py``).

Example:
    >>> import edmd
    >>> from edmd.physics.contact import LinearDashpot
    >>> state = edmd.maxwell_boltzmann(edmd.lattice(108, 0.1), kT=1.0, seed=3)
    >>> sim = DEMSimulation(state, LinearDashpot.from_restitution(0.9, k=1e4, mass=1.0))
    >>> th = sim.add(edmd.Thermo(interval=0.5))
    >>> sim.run(until_time=1.0)
    >>> [r["time"] for r in th.rows], sim.collisions > 10
    ([0.0, 0.5, 1.0], True)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import dem as _dem
from .._core import layout as L
from .._core.bundles import Spins
from .._core.cells import GF_RSMALL
from .neighbours import overlap_grid
from ..physics.contact import ContactModel, Hertz
from ..physics.friction import Friction
from .engine import EngineError, check_loadable
from .simulation import Simulation
from ..state import State, StateError

#: default steps per (shortest expected) contact
STEPS_PER_CONTACT = 50
#: the fewest steps per shortest contact a run may take: at 3 an elastic gas gained 19 % of its
#: energy in 5 time units; velocity Verlet is unstable below ~1.6
MIN_STEPS_PER_CONTACT = 10
#: default neighbour-list skin in mean diameters
SKIN = 0.3


def shortest_contact(contact: ContactModel, state: State, impact_speed: float) -> float:
    r"""Duration of the shortest expected contact of ``state``'s particles (head-on, physics.md §2.2).

    Lightest pair of masses; for Hertz also the largest effective radius (the stiffest pair)
    and the impact speed ``impact_speed`` (:math:`t_c \propto v^{-1/5}`).

    Example:
        >>> import edmd
        >>> from edmd.physics.contact import LinearDashpot
        >>> s = edmd.lattice(32, 0.1)
        >>> round(shortest_contact(LinearDashpot(k=1e4), s, 1.0), 6)   # pi / sqrt(k / (m/2))
        0.022214
    """
    masses = np.sort(state.mass)
    m1 = masses[0]
    m2 = masses[1] if masses.size > 1 else masses[0]
    radii = np.sort(state.radius)[::-1]
    r1 = radii[0]
    r2 = radii[1] if radii.size > 1 else radii[0]
    return contact.central(m1, m2, r1, r2, impact_speed).t_c


def _spin_axes(dim: int) -> slice:
    """The components of the core's ``(N, 3)`` spins that a state holds (2D: about z only)."""
    return slice(2, 3) if dim == 2 else slice(0, 3)


class DEMEngine:
    """Compiled-core arrays of one DEM system (internal; see :class:`DEMSimulation`).

    Offers the interface :class:`~edmd.run.simulation.Simulation` expects of an engine: ``advance``,
    ``now``, ``snapshot``, ``load``, ``kinetic_integral``, the counters ``cnt`` and the
    accumulators ``acc``; it has no eMD* rule (``emd_rule``) and no thermostat.
    """

    mode = "dem"
    emd_rule = None
    thermostat = None
    forcing = None
    vibration = None
    well = None
    growth = None
    well_energy = 0.0  # (no square wells: the contacts' energy is the elastic energy)
    keeps_stress = keeps_energy_current = False  # (its virial is the scalar one)

    def __init__(self, state: State, contact: ContactModel, dt: float, skin: float, gravity=None, friction: Friction | None = None):
        if not np.all(state.periodic):
            raise StateError("the DEM needs a periodic box on every axis (walls are not supported)")
        if state.shear_offset != 0.0:
            raise StateError("the DEM has no Lees-Edwards images: the state's shear_offset must be 0")
        self.contact = contact
        self.model = contact.code
        self.ca, self.cb = contact.constants()
        self.friction = friction
        self.fric = (0, 0.0, 0.0, 0.0) if friction is None else friction.constants(contact)
        self.dim = state.dim
        self.n = state.n
        self.box_user = state.box.copy()
        self.periodic = state.periodic.copy()
        self.box, self.half = state.geometry()
        grav = np.zeros(3)
        if gravity is not None:
            g = np.asarray(gravity, float)
            if g.shape != (self.dim,) or not np.all(np.isfinite(g)):
                raise ValueError(f"gravity must be {self.dim} finite numbers, got {gravity!r}")
            grav[: self.dim] = g
        self.grav = grav
        self.geo = L.make_geo(self.box, self.half, grav)
        self.dt = float(dt)
        sigma_max = 2.0 * float(state.radius.max())
        limit = 0.5 * float(state.box.min()) - sigma_max
        if limit <= 0.0:
            raise StateError(f"box length {state.box.min():g} must exceed twice the largest contact distance ({2 * sigma_max:g})")
        self.skin = min(float(skin), 0.99 * limit)
        self.capacity = 0  # (set by load from the grid, grown on overflow)
        self.cnt = np.zeros(L.N_COUNTERS, np.int64)
        self.acc = np.zeros(L.N_ACC)
        self.sums = np.zeros(_dem.N_SUMS)
        self.cbuf = np.zeros(27, np.int32)
        self.load(state)

    # ------------------------------------------------------------------ set-up
    def load(self, state: State):
        """(Re)build every array from ``state`` (user order); cumulative integrals are kept, and so
        are the tangential springs of pairs in contact before and after (a State holds no springs)."""
        check_loadable(state, self)
        n, d = self.n, self.dim
        self.t = float(state.time)
        self.pos = np.zeros((n, 3))
        self.pos[:, :d] = state.position
        self.vel = np.zeros((n, 3))
        self.vel[:, :d] = state.velocity
        self.image = np.zeros((n, 3), np.int64)
        self.image[:, :d] = state.image
        self.mass = state.mass.copy()
        self.radius = state.radius.copy()
        self.spin = np.array(state.angular_velocity, copy=True)
        self.inertia = state.inertia.copy()
        self.acc3 = np.zeros((n, 3))
        self.vp = np.zeros((n, 3))
        self.dsp = np.zeros((n, 3))
        self.grid = self._grid(self.radius)
        self.capacity = max(self.capacity, self._row_estimate(state))
        rows = n if self.friction is not None else 1
        omega = np.zeros((rows, 3))
        if self.friction is not None:
            omega[:, _spin_axes(d)] = self.spin.reshape(n, -1)  # 2D: the spin about z
        old = getattr(self, "rot", None)
        if self.friction is not None and old is not None:  # a reloaded state keeps the springs of the contacts it still has
            springs = (old.hist, self.nbl, self.nbl_n)
        else:
            springs = (np.zeros((rows, 1, 3)), np.zeros((rows, 1), np.int32), np.zeros(rows, np.int32))
        self.rot = Spins(omega, omega.copy(), np.zeros((rows, 3)), self.inertia, np.zeros((rows, 1, 3)), *springs, np.zeros((rows, 3)), np.zeros((rows, 3)))
        self._setup()

    def _grid(self, radius):
        """The cell grid of the list builds: cells of the largest contact plus the skin, or of the
        others' with a few big particles taken out (:func:`.neighbours.overlap_grid`)."""
        return overlap_grid(radius, self.box, np.r_[self.periodic, [False] * (3 - self.dim)], self.dim, pad=self.skin)

    def _row_estimate(self, state: State) -> int:
        """Slots a list row needs at ``state``'s density: 1.2 times the particles within the
        largest contact the rows hold (with big particles, of the others: a row holds no big's
        partners) plus the skin, and 8."""
        r_row = min(float(self.grid.size[GF_RSMALL]), float(self.radius.max()))
        reach = 2.0 * r_row + self.skin
        ball = (4.0 / 3.0 * math.pi * reach**3) if self.dim == 3 else (math.pi * reach**2)
        return int(1.2 * state.n / state.volume * ball) + 8

    def _setup(self):
        """Allocate the list at the current capacity and build it; springs come from ``rot.nbl_old``."""
        while True:
            self.nbl = np.zeros((self.n, self.capacity), np.int32)
            self.nbl_n = np.zeros(self.n, np.int32)
            self.tch = np.zeros((self.n, self.capacity), np.int8)
            if self.friction is not None:
                self.rot = self.rot._replace(hist=np.zeros((self.n, self.capacity, 3)))
            ok = _dem.dem_setup(
                self.pos, self.vel, self.acc3, self.vp, self.dsp, self.mass, self.radius, self.nbl, self.nbl_n,
                self.tch, self.grid, self.geo, self.model, self.ca, self.cb, self.rot, self.fric, self.skin, self.sums, self.cbuf,
            )  # fmt: skip
            if ok:
                break
            self.capacity = int(self.capacity * 1.5) + 4
        if self.friction is not None:  # the scratch of the next rebuild
            self.rot = self.rot._replace(hist_old=np.zeros_like(self.rot.hist), nbl_old=np.zeros_like(self.nbl), nbl_n_old=np.zeros_like(self.nbl_n))

    # ------------------------------------------------------------------ running
    @property
    def now(self) -> float:
        """Current simulation time."""
        return self.t

    def advance(self, t_stop: float, max_events: int | float = math.inf) -> int:
        """Integrate up to absolute time ``t_stop`` (exactly) or for ``max_events`` steps.

        The steps inside ``[now, t_stop]`` all have the size ``(t_stop - now) / ceil((t_stop - now) / dt)``
        (at most ``dt``). Returns ``ST_TIME`` at ``t_stop``, ``ST_EVENTS`` when the budget (or
        an internal chunk of about a second of work) is spent.
        """
        budget = max_events
        chunk = max(1, int(4e6 // self.n))
        while True:
            if budget <= 0:
                return L.ST_EVENTS
            remaining = t_stop - self.t
            if remaining <= 1e-12 * self.dt:
                if math.isfinite(t_stop):
                    self.t = float(t_stop)
                return L.ST_TIME
            if math.isfinite(remaining):
                nseg = max(1, math.ceil(remaining / self.dt * (1.0 - 1e-12)))
                h = remaining / nseg
            else:
                nseg, h = math.inf, self.dt
            k = int(min(nseg, budget, chunk))
            status, done = _dem.dem_steps(
                self.pos, self.vel, self.acc3, self.vp, self.dsp, self.image, self.mass, self.radius, self.nbl,
                self.nbl_n, self.tch, self.grid, self.geo, self.model, self.ca, self.cb, self.rot, self.fric, self.skin, h, k,
                self.sums, self.cnt, self.cbuf,
            )  # fmt: skip
            self.t = float(t_stop) if done == nseg else self.t + done * h
            budget -= done
            self._sync()
            if status == L.ST_LIST_FULL:
                self.capacity = int(self.capacity * 1.5) + 4
                self._setup()
            elif status == _dem.ST_STEP_TOO_LARGE:
                raise EngineError(
                    f"time step {h:.3g} too large at t = {self.t!r}: a particle would move more than half the "
                    f"neighbour-list skin ({self.skin:.3g}) in one step; use a smaller dt or a larger skin"
                )
            elif done == k and k == chunk and done < nseg:
                return L.ST_EVENTS

    def _sync(self):
        self.acc[L.A_VIRIAL] = self.sums[_dem.S_VIR_INT]
        self.acc[L.A_DISSIPATED] = self.sums[_dem.S_DISS] + self.sums[_dem.S_WT] - self.sums[_dem.S_UT]
        if self.friction is not None:
            self.spin = self.rot.omega[:, _spin_axes(self.dim)].reshape(self.spin.shape).copy()
        self.acc[L.A_KE] = self.sums[_dem.S_KE]
        self.acc[L.A_NOW] = self.t

    # ------------------------------------------------------------------ observation
    def snapshot(self, t: float | None = None) -> State:
        """The state now (a DEM cannot stream: ``t`` must be the current time)."""
        if t is not None and abs(t - self.t) > 1e-9 * max(1.0, abs(self.t)):
            raise EngineError(f"a DEM state exists only at the current time {self.t!r}, not at {t!r}")
        d = self.dim
        return State(
            position=self.pos[:, :d],
            velocity=self.vel[:, :d],
            radius=self.radius,
            mass=self.mass,
            box=self.box_user,
            time=self.t if t is None else t,
            angular_velocity=self.spin,
            inertia=self.inertia,
            image=self.image[:, :d],
            periodic=self.periodic,
            check_overlaps=False,
        )

    def accumulators_at(self, t: float) -> np.ndarray:
        """The accumulators (they are current at the engine's time)."""
        return self.acc

    def kinetic_integral(self, t: float) -> float:
        r""":math:`\int E_{\rm kin}\,dt` since the start (trapezoidal over the steps), at the current time."""
        return float(self.sums[_dem.S_KE_INT])

    @property
    def elastic_energy(self) -> float:
        """Elastic energy stored in the contacts now."""
        return float(self.sums[_dem.S_U])


class DEMSimulation(Simulation):
    r"""Force-based MD of soft spheres (3D) or disks (2D) with a contact model (see module docs).

    Args:
        state: the initial :class:`~edmd.state.State` (overlaps allowed: they are contacts).
        contact: a :class:`~edmd.physics.contact.LinearDashpot` or :class:`~edmd.physics.contact.Hertz`.
        dt: time step; default: :func:`shortest_contact` / ``steps_per_contact``.
        steps_per_contact: steps per shortest contact when ``dt`` is not given.
        impact_speed: impact speed used for the Hertz contact duration (default: twice the
            largest particle speed, plus the free-fall speed across the box with gravity).
        gravity: uniform acceleration (``d`` numbers) or ``None``.
        skin: neighbour-list skin in mean diameters.
        friction: a :class:`~edmd.physics.friction.Friction` (tangential spring, damping and
            Coulomb slider; the particles' spins then evolve) or ``None`` (frictionless).

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(64, 0.2, dim=2), kT=1.0, seed=1)
        >>> sim = DEMSimulation(s, edmd.Hertz(young=1e5, poisson=0.3, A=1e-4), steps_per_contact=20)
        >>> sim.run(until_time=0.5)
        >>> sim.time, sim.state.dim, round(sim.dt / sim.contact_time, 6)
        (0.5, 2, 0.05)
    """

    def __init__(
        self,
        state: State,
        contact: ContactModel,
        *,
        dt: float | None = None,
        steps_per_contact: float = STEPS_PER_CONTACT,
        impact_speed: float | None = None,
        gravity=None,
        skin: float = SKIN,
        friction: Friction | None = None,
    ):
        if not isinstance(contact, ContactModel):
            raise TypeError(f"contact must be a LinearDashpot or Hertz model, got {contact!r}")
        if friction is not None:
            if not isinstance(friction, Friction):
                raise TypeError(f"friction must be an edmd.Friction or None, got {friction!r}")
            friction.stiffness_for(contact)  # Mindlin needs a stiffness or a Hertz law
        if not isinstance(state, State):
            raise TypeError(f"state must be an edmd.State, got {type(state).__name__}")
        if not (steps_per_contact >= MIN_STEPS_PER_CONTACT and math.isfinite(steps_per_contact)):
            raise ValueError(
                f"steps_per_contact must be a number >= {MIN_STEPS_PER_CONTACT} (fewer steps per contact give energy errors of "
                f"tens of per cent), got {steps_per_contact!r}"
            )
        if not (skin > 0 and math.isfinite(skin)):
            raise ValueError(f"skin must be a positive number, got {skin!r}")
        if impact_speed is None:
            speed = 2.0 * float(np.sqrt((state.velocity**2).sum(axis=1)).max())
            if gravity is not None:
                speed += math.sqrt(2.0 * float(np.linalg.norm(gravity)) * float(state.box.max()))
            impact_speed = speed
        self.contact = contact
        self.friction = friction
        self.impact_speed = float(impact_speed)
        if dt is None:
            if isinstance(contact, Hertz) and not self.impact_speed > 0:
                raise ValueError("all particles are at rest: give dt or impact_speed to set the Hertz time step")
            self.contact_time = shortest_contact(contact, state, self.impact_speed if self.impact_speed > 0 else 1.0)
            dt = self.contact_time / steps_per_contact
        elif not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"dt must be a positive number, got {dt!r}")
        else:
            self.contact_time = math.nan
        self._step = float(dt)
        self._skin = skin * 2.0 * float(state.radius.mean())
        super().__init__(state, gravity=gravity)

    def _build_engine(self, state, collision, walls, gravity, drivers, options, saved=None):
        """The DEM engine (the event-driven physics arguments are unused: all ``None``; DEM runs
        have no checkpoints, so never ``saved`` arrays)."""
        self.params = {
            "contact": {"type": type(self.contact).__name__, **dataclasses.asdict(self.contact)},
            "dt": self._step,
            "gravity": None if gravity is None else [float(g) for g in gravity],
            "friction": None if self.friction is None else dataclasses.asdict(self.friction),
        }
        return DEMEngine(state, self.contact, self._step, self._skin, gravity, self.friction)

    #: soft particles: a contact is an overlap (no overlap check of the states it takes)
    _hard_cores = False

    @property
    def dt(self) -> float:
        """The (largest) time step."""
        return self._engine.dt

    def add(self, observer):
        """Attach an observer (as :meth:`Simulation.add`; checkpoints are not available for the DEM)."""
        from ..files.checkpoint import Checkpoint

        if isinstance(observer, Checkpoint):
            raise TypeError("checkpoints (exact restarts) are not available for the DEM; save states with a Trajectory")
        return super().add(observer)

    @property
    def state(self) -> State:
        """A copy of the state at the current time (assign a State to replace it; overlaps allowed)."""
        return self._engine.snapshot(self._time)

    @state.setter
    def state(self, new: State):
        self._engine.load(new)
        self._time = float(new.time)

    def state_view(self) -> State:
        """The state at the current time: a copy (the DEM's arrays are its particles' own; no view)."""
        return self.state

    @property
    def elastic_energy(self) -> float:
        """Elastic energy stored in the contacts."""
        return self._engine.elastic_energy

    @property
    def steps(self) -> int:
        """Time steps so far (also counted as ``events``)."""
        return self.events
