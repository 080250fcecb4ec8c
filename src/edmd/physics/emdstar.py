r"""eMD*: event-driven molecular dynamics of soft spheres (Müller & Pöschel 2013; physics.md §4.8).

A soft contact (linear dashpot or viscoelastic Hertz, :mod:`edmd.physics.contact`) is mapped to events:

* **A** when a pair reaches :math:`|\mathbf r_{ij}| = \sigma_{ij}` approaching at :math:`t_0`: the
  matrix of restitution :math:`(\Phi, D, t_c, \hat\varepsilon)` of the contact (from a lookup table
  or the two-body solver, physics.md §4.5–§4.7) relocates the pair about its centre of mass, both
  move on with the centre-of-mass velocity :math:`\mathbf V`, and each stores its post-collisional
  increment :math:`\boldsymbol\Delta` (physics.md §4.6):

  .. math::
      \mathbf r_{i,j}^A = \mathbf R \pm \tfrac{m_{j,i}}{M}D\sigma\,\hat{\mathbf n}',\qquad
      \mathbf v_i = \mathbf v_j = \mathbf V,\qquad
      \boldsymbol\Delta_{i,j} = \pm\tfrac{m_{j,i}}{M}\big(\hat\varepsilon v_n\hat{\mathbf n}' + \tfrac{v_t}{D}\hat{\mathbf t}'\big)

* **B** per particle at :math:`t_0 + t_c`: :math:`\mathbf v \leftarrow \mathbf v + \boldsymbol\Delta`. From then
  on positions and velocities equal Newton's for the soft contact; only during the contact the
  pair follows a surrogate path. B events come before A events at equal times.

Exceptions (counted in the thermo output): **a)** the relocated pair would overlap a third
particle or a wall, and **b)** a particle with a pending B meets a third particle or a wall. a) resolves
the contact by the instantaneous rule with the contact law's central :math:`e_n(v_n)` (as
do pairs found overlapping and approaching, and failed solves: ``fallbacks``); b) executes the
pending B now (with ``communication``, also the former partner's) and re-tests the approach.
Walls use the instantaneous rule with the same force law (:math:`\mu = m_i`, :math:`R_{\rm eff} = R_i`),
on the particle's own velocity (a pending contact is completed first, exception b).
Between A and B the relative kinetic energy of the pair is not carried by velocities:
observables use the *committed* velocities :math:`\mathbf v + \boldsymbol\Delta`
(:attr:`edmd.State.committed_velocity`).

With ``friction`` (:class:`~edmd.physics.friction.Friction`) the contacts are frictional
(docs/physics.md §4.8, §4.11): the A event takes positions, velocities and spins from the
frictional two-body solver (spins set at A), and the instantaneous rule of the exceptions is
Walton's rough rule with the central :math:`e_n(v_n)`, the friction's :math:`\mu` and
``fallback_beta`` (:func:`sticking_beta`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from pathlib import Path

import numpy as np

from .._core import layout as L
from .._core import friction_lookup as _fl
from .._core import lookup as _lk
from .._core import twobody_friction as _tf
from .._core.bundles import EMDStarData
from .contact import ContactError, ContactModel, Hertz, LinearDashpot
from .friction import Friction
from .tables import NO_PAIR_TABLE, RestitutionTable, default_table, pair_tables


class EMDStarError(ValueError):
    """An inconsistent eMD* setting (the message names it)."""


#: the ``tables`` settings that are not paths
TABLE_CHOICES = ("default", "exact")
#: (contact law, friction law) pairings with a sticking restitution of their own (:func:`sticking_beta`)
STICKING_PAIRINGS = (("dashpot", "linear"), ("hertz", "mindlin"))


@dataclasses.dataclass(frozen=True)
class EMDStar:
    r"""The eMD* collision rule for soft spheres or disks, smooth or frictional (physics.md §4.8).

    Args:
        contact: the soft contact law, :class:`~edmd.physics.contact.Hertz` (viscoelastic, material
            density on the particles' masses) or :class:`~edmd.physics.contact.LinearDashpot`.
        tables: ``"default"`` (the tables shipped with edmd, the direct solver outside their
            box), ``"exact"`` (the direct solver for every contact, relative tolerance ``rtol``)
            or the path of a table built with ``edmd tables build`` for the same model.
        communication: in exception b), also execute the pending B of the former partner
            ("post-collisional communication"; keeps angular momentum exact).
        rtol: relative tolerance of the direct two-body solver.
        friction: a tangential law (:class:`~edmd.physics.friction.Friction`) for frictional
            contacts with spins (docs/physics.md §4.8, §4.11): every contact is solved directly
            (exact), and spins change at the A event.
        friction_table: frictional contacts only: take the tangential impulse from the hard-limit
            table (:func:`friction_table`, docs/physics.md §4.12) and the normal motion from the
            smooth map (``tables``) instead of solving each contact: ~100x cheaper per contact,
            exact to first order in the softness :math:`\Lambda`. Dashpot with a linear spring
            or Hertz with Mindlin; contacts the table does not cover are solved directly.
        fallback_beta: frictional contacts only: the sticking restitution :math:`\beta_0` of the
            instantaneous rough rule (Walton, Coulomb limit ``friction.mu``) that resolves the
            exceptions; default :func:`sticking_beta` of the contact and tangential laws, for solid
            spheres (3D) or disks (2D): :meth:`for_dim`, which the engine applies.

    Example:
        >>> import edmd
        >>> rule = EMDStar(edmd.Hertz(young=1e7, poisson=0.3, A=0.0))
        >>> s = edmd.State(position=[[-1.0, 0.0, 0.0], [1.0, 0.3, 0.0]], velocity=[[1.0, 0, 0], [-1.0, 0, 0]],
        ...                radius=0.5, mass=1.0, box=[10.0, 10.0, 10.0])
        >>> sim = edmd.Simulation(s, collision=rule)
        >>> sim.run(until_time=2.0)
        >>> sim.engine.emd_counters()["emd_contacts"], round(sim.state.kinetic_energy(), 12)
        (1, 1.0)
    """

    contact: ContactModel
    tables: str = "default"
    communication: bool = True
    rtol: float = 1e-10
    friction: Friction | None = None
    fallback_beta: float | None = None
    friction_table: bool = False

    def __post_init__(self):
        if not isinstance(self.contact, (Hertz, LinearDashpot)):
            raise EMDStarError(f"eMD* needs a soft contact law (edmd.Hertz or edmd.LinearDashpot), got {self.contact!r}")
        if isinstance(self.tables, os.PathLike):
            object.__setattr__(self, "tables", os.fspath(self.tables))
        if not isinstance(self.tables, str):
            raise EMDStarError(f"tables must be 'default', 'exact' or a table file path, got {self.tables!r}")
        if not isinstance(self.communication, bool):
            raise EMDStarError(f"communication must be true or false, got {self.communication!r}")
        if not (isinstance(self.rtol, float) and 1e-14 <= self.rtol <= 1e-4):
            raise EMDStarError(f"rtol must be a float in [1e-14, 1e-4], got {self.rtol!r}")
        if self.friction is not None and self.tables not in TABLE_CHOICES and not self.friction_table:
            raise EMDStarError("frictional contacts are solved directly (a table file needs friction_table = True): leave tables at 'default' or 'exact'")
        self.table()  # fail early: a missing file or a table of another model
        if self.friction is not None and not isinstance(self.friction, Friction):
            raise EMDStarError(f"friction must be an edmd.Friction, got {self.friction!r}")
        if self.fallback_beta is not None:
            if self.friction is None:
                raise EMDStarError("fallback_beta is the sticking restitution of frictional contacts: it needs friction = ...")
            if not (isinstance(self.fallback_beta, (int, float)) and -1.0 <= self.fallback_beta <= 1.0):
                raise EMDStarError(f"fallback_beta must be a number in [-1, 1], got {self.fallback_beta!r}")
            object.__setattr__(self, "fallback_beta", float(self.fallback_beta))
        if self.friction is not None:
            try:
                self.friction.constants(self.contact)
            except ContactError as exc:
                raise EMDStarError(str(exc)) from None
            if isinstance(self.contact, LinearDashpot) and self.friction.law == "mindlin" and self.friction.damping > 0.0:
                raise EMDStarError(
                    "Mindlin friction with tangential damping on a dashpot contact cannot be solved: Mindlin's stiffness vanishes at "
                    "the touch, where the dashpot's damping force is already there (the spring held at the Coulomb limit would need "
                    "an infinite extension); use damping = 0 with Mindlin, or a linear spring"
                )
            if self.fallback_beta is None:
                sticking_beta(self.contact, self.friction)  # fail early: no default for this pairing
        if not isinstance(self.friction_table, bool):
            raise EMDStarError(f"friction_table must be true or false, got {self.friction_table!r}")
        if self.friction_table:
            if self.friction is None:
                raise EMDStarError("friction_table is the tangential map of frictional contacts: it needs friction = ...")
            if (self.contact.name, self.friction.law) not in STICKING_PAIRINGS:
                raise EMDStarError(
                    f"friction_table covers a dashpot with a linear spring or Hertz with Mindlin (a scaled spring that is a constant "
                    f"of the laws), not a {self.friction.law} spring with a {self.contact.name} contact: leave friction_table off"
                )

    def for_dim(self, dim: int) -> EMDStar:
        """This rule with its default ``fallback_beta`` resolved for solid spheres (3D) or disks (2D).

        Example:
            >>> from edmd.physics.contact import LinearDashpot
            >>> from edmd.physics.friction import Friction
            >>> rule = EMDStar(LinearDashpot(k=7.0), friction=Friction(mu=0.5, stiffness=2.0))
            >>> round(rule.for_dim(3).fallback_beta, 6), round(rule.for_dim(2).fallback_beta, 6)
            (1.0, 0.972968)
        """
        if self.friction is None or self.fallback_beta is not None:
            return self
        return dataclasses.replace(self, fallback_beta=sticking_beta(self.contact, self.friction, 0.4 if dim == 3 else 0.5))

    def laws(self):
        r"""Its instantaneous fallbacks' laws: the contact law's central :math:`e_n(v_n)`; smooth, or
        with friction Walton's rough rule (:math:`\beta_0` = ``fallback_beta``, :math:`\mu` of the friction)."""
        if self.friction is None:
            return (L.NORMAL_SOFT, 1.0), L.SMOOTH
        beta = sticking_beta(self.contact, self.friction) if self.fallback_beta is None else self.fallback_beta
        return (L.NORMAL_SOFT, 1.0), (L.TANGENT_COULOMB, beta, self.friction.mu)

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write eMD*'s switches and its fallback laws into the core's parameter arrays
        (the contact law itself is packed with the walls', :func:`edmd.physics.collide.pack`)."""
        L.pack_laws(self.laws(), fp, ip)
        ip[L.IP_EMD] = 1
        ip[L.IP_EMD_TABLE] = int(self.tables != "exact")
        ip[L.IP_EMD_COMM] = int(self.communication)
        fp[L.FP_EMD_RTOL] = self.rtol
        if self.friction is not None:
            code, kt, xt, mu = self.friction.constants(self.contact)
            ip[L.IP_EMD_FRICTION] = code
            fp[L.FP_FRICTION_KT], fp[L.FP_FRICTION_XT], fp[L.FP_FRICTION_MU] = kt, xt, mu

    def table(self) -> RestitutionTable | None:
        """The lookup table used (``None`` for ``tables = "exact"``)."""
        return _load_table(self.tables, self.contact.name)

    def core(self) -> tuple:
        """``(values, tg, ctab, cgeo)`` for the compiled core (placeholders without a table)."""
        tab = self.table()
        return NO_TABLE if tab is None else tab.core()


def sticking_beta(contact: ContactModel, friction: Friction, inertia_factor: float = 0.4) -> float:
    r"""Tangential restitution :math:`\beta_0` of a sticking contact of two equal particles (docs/physics.md §2.6, §4.11).

    The contact-point velocity :math:`u` of a contact that never slides (:math:`\mu = \infty`)
    oscillates on the spring while the normal motion lasts; :math:`\beta_0 = -u'/u_0`. It is
    solved with the frictional two-body solver in the hard limit, undamped (normal and
    tangential), for :math:`I = qmR^2` (``inertia_factor`` :math:`q = 2/5` for solid spheres,
    :math:`1/2` for disks; :math:`\mu/m_t = 1 + 1/q`). It is a number of the laws alone when the
    scaled spring :math:`\tilde k` is: a linear spring with a dashpot (:math:`\tilde k = k_t/k`,
    then :math:`\beta_0 = -\cos(\pi\sqrt{\tilde k\,\mu/m_t})` exactly) or Mindlin with Hertz
    (:math:`\tilde k = k_{t0}/a`, :math:`2(1-\nu)\cdot\tfrac32/(2-\nu)` by default). Other pairings
    depend on the impact: give ``fallback_beta``. The result is clipped to :math:`[-1, 1]` (Mindlin's
    spring, stiffening while it is loaded, can return slightly more than it took).

    Example:
        >>> from edmd.physics.contact import LinearDashpot
        >>> from edmd.physics.friction import Friction
        >>> round(sticking_beta(LinearDashpot(k=7.0), Friction(mu=0.5, stiffness=2.0)), 6)   # k_t / k = 2/7: perfectly rough
        1.0
    """
    if (contact.name, friction.law) not in STICKING_PAIRINGS:
        raise EMDStarError(f"a {friction.law} spring with a {contact.name} contact has no sticking restitution of its own: give fallback_beta = ...")
    u0 = 1e-3
    K = 1.0 / inertia_factor
    j, _i, tau = _fl.hard_limit(contact.code, 0.0, friction.code, _scaled_spring(contact, friction), 0.0, math.inf, K, u0, 1e-12, _friction_scratch())
    if not tau == tau:
        raise EMDStarError(f"the sticking contact of {contact!r} with {friction!r} did not solve: give fallback_beta = ...")
    return min(1.0, max(-1.0, (1.0 + K) * j / u0 - 1.0))


def _scaled_spring(contact: ContactModel, friction: Friction) -> float:
    r"""The scaled tangential spring :math:`\tilde k` of the pairings whose spring is a constant of the laws (docs/physics.md §4.11)."""
    return friction.stiffness_for(contact) / contact.constants()[0]


def _friction_scratch() -> np.ndarray:
    return np.zeros((_tf.SCRATCH_ROWS, _tf.N_STATE))


#: the hard-limit table's nodes: damping (c for the dashpot, sqrt(c) for Hertz) x contact-point speed
FRICTION_TABLE_SHAPE = (33, 257)
#: the largest damping c the hard-limit table holds (its damping axis spans [0, 1] in c or sqrt(c))
FRICTION_TABLE_MAX_DAMPING = 1.0


@functools.lru_cache(maxsize=8)
def friction_table(contact: ContactModel, friction: Friction, inertia_factor: float = 0.4) -> tuple[np.ndarray, np.ndarray]:
    r"""The hard-limit table of frictional contacts (docs/physics.md §4.12): ``(values, grid)`` for the compiled core.

    Tabulates the tangential impulse :math:`j` and its time integral :math:`I` of a contact in the
    hard limit :math:`\Lambda\to0` over the normal damping :math:`c` and the contact-point speed
    :math:`u_0 = |\mathbf v_{c,t}|/v_n` (:mod:`edmd._core.friction_lookup`), for particles with
    :math:`I = qmR^2` (``inertia_factor`` :math:`q`: the inertia sum :math:`K = 1/q` of every pair).
    Dashpot with a linear spring or Hertz with Mindlin. Built in about two seconds (8481 solves);
    interpolation error (bicubic) in :math:`(1+K)j` per impact speed: median :math:`10^{-8}`,
    99 % below :math:`3\times10^{-5}`, at most :math:`5\times10^{-4}` next to the kinks where the
    stick-slip sequence changes.

    Example:
        >>> from edmd.physics.contact import LinearDashpot
        >>> from edmd.physics.friction import Friction
        >>> from edmd._core.friction_lookup import lookup
        >>> values, grid = friction_table(LinearDashpot(k=7.0), Friction(mu=0.5, stiffness=2.0))
        >>> j, _rate = lookup(values, grid, 0.0, 1e-3)  # elastic, sticking: beta = (1 + K) j / u0 - 1
        >>> round(3.5 * j / 1e-3 - 1.0, 6)
        1.0
    """
    if (contact.name, friction.law) not in STICKING_PAIRINGS:
        raise EMDStarError(f"no hard-limit table for a {friction.law} spring with a {contact.name} contact")
    K = 1.0 / inertia_factor
    n_c, n_s = FRICTION_TABLE_SHAPE
    mu = friction.mu
    hertz = isinstance(contact, Hertz)
    top = math.sqrt(FRICTION_TABLE_MAX_DAMPING) if hertz else FRICTION_TABLE_MAX_DAMPING
    grid = np.array([float(hertz), 0.0, top / (n_c - 1), n_c, n_s, 2.0 * mu * (1.0 + K) if math.isfinite(mu) else 1.0,
                     _scaled_spring(contact, friction), K])  # fmt: skip
    values = np.zeros((n_c, n_s, 2))
    failed = _fl.build(contact.code, friction.code, grid, friction.damping, mu, 1e-10, values, _friction_scratch())
    if failed:
        raise EMDStarError(f"{failed} hard-limit contacts of {contact!r} with {friction!r} did not solve: leave friction_table off")
    return values, grid


class FrictionTableWarning(UserWarning):
    """Contacts that the hard-limit table does not cover: they are solved directly (exact, slow)."""


def friction_table_misses(rule: EMDStar, mass: np.ndarray, radius: np.ndarray, inertia: np.ndarray, dim: int) -> list[str]:
    r"""What of a system the hard-limit table of ``rule`` does not cover (docs/physics.md §4.12), in words.

    The table holds pairs whose inertia sum is :math:`K = 1/q` (:math:`I = qmR^2` for every
    particle: :math:`q = 2/5` for spheres, :math:`1/2` for disks) and a dashpot's damping
    :math:`c = \gamma/\sqrt{k\mu} \le 1` (Hertz contacts with :math:`\delta > 1` already warn,
    :class:`~edmd.physics.contact.ContactWarning`). Contacts off the table are solved directly.

    Example:
        >>> import numpy as np
        >>> from edmd.physics.contact import LinearDashpot
        >>> from edmd.physics.friction import Friction
        >>> rule = EMDStar(LinearDashpot(k=7.0), friction=Friction(mu=0.5, stiffness=2.0), friction_table=True)
        >>> m, R = np.ones(4), np.full(4, 0.5)
        >>> friction_table_misses(rule, m, R, 0.4 * m * R**2, 3), len(friction_table_misses(rule, m, R, m * R**2, 3))
        ([], 1)
    """
    q = 0.4 if dim == 3 else 0.5
    misses = []
    off = ~np.isclose(inertia, q * mass * radius**2, rtol=1e-9, atol=0.0)
    if off.any():
        misses.append(f"{int(off.sum())} of {off.size} particles have moments of inertia other than {q} m R^2: their contacts are solved directly")
    if isinstance(rule.contact, LinearDashpot) and mass.size:
        m = float(mass.min())  # (the lightest pair is the most damped)
        c = 2.0 * rule.contact.damping_ratio(m, m)
        if c > FRICTION_TABLE_MAX_DAMPING:
            misses.append(
                f"the dashpot's damping c = gamma / sqrt(k mu) = {c:.3g} exceeds the table's {FRICTION_TABLE_MAX_DAMPING:g} (e_n below 0.16): "
                "those contacts are solved directly"
            )
    return misses


#: placeholder table arrays of the same types as a real table's (one compiled loop for all runs)
NO_TABLE = (np.zeros(1), (0.0,) * 16, np.zeros((1, 2)), (0.0, 1.0, 0.0, 0.0))
#: placeholder hard-limit table (no nodes: every frictional contact is solved directly)
NO_FRICTION_TABLE = (np.zeros((1, 1, 2)), np.zeros(_fl.N_GRID))


@functools.lru_cache(maxsize=8)
def _load_table(tables: str, model: str) -> RestitutionTable | None:
    if tables == "exact":
        return None
    if tables == "default":
        return default_table(model)
    path = Path(tables)
    if not path.is_file():
        raise EMDStarError(f"tables: no table file {tables!r} (use 'default', 'exact' or a file from `edmd tables build`)")
    try:
        tab = RestitutionTable.load(path)
    except Exception as exc:
        raise EMDStarError(f"tables: cannot read {tables!r}: {exc}") from exc
    if tab.model != model:
        raise EMDStarError(f"tables: {tables!r} is a {tab.model} table, the contact law is {model}")
    return tab


def emd_bundle(n: int, rule: EMDStar | None, pending=None, dim: int = 3, species=None) -> EMDStarData:
    """The ``emd`` bundle of :mod:`edmd._core.emdstar` for ``n`` particles (internal order).

    ``pending``: ``(dv (n, 3), t_b (n,), partner (n,))`` or ``None`` (nothing pending); ``dim``:
    solid spheres (3) or disks (2) for the hard-limit table's inertia sum; ``species``: the
    distinct ``(mass, radius)`` of the particles where they are few (their contacts then take
    the matrix of restitution from pair tables, :func:`~edmd.physics.tables.pair_tables`).
    """
    if pending is None:
        pending = (np.zeros((n, 3)), np.full(n, np.inf), np.full(n, -1, np.int32))
    dv, tb, pj = pending
    values, tg, ctab, cgeo = NO_TABLE if rule is None else rule.core()
    values, ctab = np.ascontiguousarray(values, float), np.ascontiguousarray(ctab, float)
    # (arrays, not tuples of floats: a bundle holding tuples made every call that takes it from the
    # event loop cost microseconds, and eMD* gases ran at half the event rate; measured)
    tg, cgeo = np.array(tg, float), np.array(cgeo, float)
    scratch = (np.zeros(_lk.SCRATCH_SHAPE), np.zeros((13, 3)), np.zeros((11, 3)), _friction_scratch())
    tangential = NO_FRICTION_TABLE
    if rule is not None and rule.friction_table:
        tangential = friction_table(rule.contact, rule.friction, 0.4 if dim == 3 else 0.5)
    if rule is None:  # (a 1-D array: its type tells the compiled predictors that nothing is pending, schedule.pending_of)
        dv = np.zeros(0)
    pending = (np.ascontiguousarray(dv, float), np.ascontiguousarray(tb, float), np.ascontiguousarray(pj, np.int32))
    pair = NO_PAIR_TABLE
    table = None if rule is None else rule.table()
    if table is not None and species is not None and (rule.friction is None or rule.friction_table):  # (other frictional contacts are solved)
        pair = pair_tables(table, table.code, *rule.contact.constants(), species)
    return EMDStarData(*pending, values, tg, ctab, cgeo, *scratch, *tangential, *pair)


__all__ = ["EMDStar", "EMDStarError", "FrictionTableWarning", "TABLE_CHOICES", "emd_bundle", "friction_table", "friction_table_misses", "sticking_beta"]
