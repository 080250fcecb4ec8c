"""Collision rules (physics.md §2, §3): validated parameter objects packed for the compiled core.

Pick one rule per simulation and, for boxes with walls, a :class:`Wall`:

* :class:`Inelastic` — smooth spheres, constant normal restitution (``Inelastic(1.0)`` is elastic);
* :class:`Rough` — normal and tangential restitution with rotation, optionally Coulomb-limited;
* a contact law as a rule: :class:`Viscoelastic` (the same class as the Hertz contact law
  :class:`~edmd.physics.contact.Hertz`) — smooth spheres with the velocity-dependent :math:`e_n(v_n)`
  of viscoelastic spheres from Young's modulus, Poisson ratio and the dissipative constant ``A``
  (or :class:`~edmd.physics.contact.LinearDashpot`, the dashpot's central :math:`e_n`);
* :class:`TC` — wraps any rule with the TC model against inelastic collapse.

**Tangential restitution convention**: ``beta`` is physics.md's :math:`\\beta\\in[-1, 1]`
(:math:`\\mathbf g_t' = -\\beta\\mathbf g_t`): ``-1`` perfectly smooth, ``0`` sticking, ``+1``
perfectly rough. The lecture notes' :math:`e_t = -\\beta` is accepted as ``e_t``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import layout as L
from .contact import ContactModel, Hertz, LinearDashpot, viscoelastic_table
from .emdstar import EMDStar
from .friction import Friction
from .errors import RuleError


def _check_range(name, value, lo, hi):
    if not (isinstance(value, (int, float)) and math.isfinite(value) and lo <= value <= hi):
        raise RuleError(f"{name} must be a number in [{lo}, {hi}], got {value!r}")
    return float(value)


#: the viscoelastic material is the Hertz contact law (one class per material): as a rule, smooth
#: spheres with its central :math:`e_n(v_n)`; as the ``e_n`` of :class:`Rough` or :class:`Wall`, their normal law
Viscoelastic = Hertz


def _normal_law(e_n) -> tuple[int, float]:
    if isinstance(e_n, ContactModel):
        return L.NORMAL_SOFT, 1.0
    return L.NORMAL_CONST, _check_range("e_n", e_n, 0.0, 1.0)


def _tangential_law(beta, e_t, mu) -> tuple[int, float, float]:
    if beta is not None and e_t is not None:
        raise RuleError("give either beta or e_t (= -beta), not both")
    if beta is None and e_t is None:
        beta = -1.0
    b = _check_range("beta", beta, -1.0, 1.0) if e_t is None else -_check_range("e_t", e_t, -1.0, 1.0)
    if mu is None:
        return (L.TANGENT_SMOOTH if b == -1.0 else L.TANGENT_BETA), b, 0.0
    if not (math.isfinite(mu) and mu >= 0):
        raise RuleError(f"Coulomb friction coefficient mu must be >= 0, got {mu!r}")
    return L.TANGENT_COULOMB, b, float(mu)


@dataclasses.dataclass(frozen=True)
class Inelastic:
    r"""Smooth spheres with constant normal restitution (physics.md §2.1).

    :math:`\mathbf g'\cdot\hat{\mathbf n} = -e_n\,\mathbf g\cdot\hat{\mathbf n}`, tangential
    velocity unchanged, spins untouched. ``Inelastic(1.0)`` is elastic hard spheres.

    Example:
        >>> Inelastic(0.9).e_n
        0.9
    """

    e_n: float = 1.0

    def __post_init__(self):
        _check_range("e_n", self.e_n, 0.0, 1.0)

    def laws(self):
        """``((normal_code, e_n), (tangent_code, beta, mu))`` for the core."""
        return _normal_law(self.e_n), L.SMOOTH

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write this rule's laws into the core's parameter arrays (see :func:`pack`)."""
        L.pack_laws(self.laws(), fp, ip)


@dataclasses.dataclass(frozen=True)
class _NormalTangential:
    """Normal law (a number or a contact law: :class:`Viscoelastic` = Hertz, or a dashpot) and tangential law (``beta``/``e_t``, ``mu``)."""

    e_n: float | ContactModel = 1.0
    beta: float | None = None
    e_t: float | None = None
    mu: float | None = None

    def __post_init__(self):
        _normal_law(self.e_n)
        _, b, _ = _tangential_law(self.beta, self.e_t, self.mu)
        object.__setattr__(self, "beta", b)  # one convention inside: beta
        object.__setattr__(self, "e_t", None)

    def laws(self):
        """``((normal_code, e_n), (tangent_code, beta, mu))`` for the core."""
        return _normal_law(self.e_n), _tangential_law(self.beta, None, self.mu)

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write these laws into the core's parameter arrays (see :func:`pack`)."""
        L.pack_laws(self.laws(), fp, ip)


@dataclasses.dataclass(frozen=True)
class Rough(_NormalTangential):
    r"""Rough spheres/disks: normal and tangential restitution with rotation (physics.md §2.3).

    .. math::
        \mathbf g_n' = -e_n\mathbf g_n,\qquad \mathbf g_t' = -\beta\,\mathbf g_t

    for the contact-point velocity. With ``mu`` the tangential impulse is Coulomb-limited
    (Walton): :math:`\beta_{\rm eff} = \min[\beta, -1 + \mu(1+e_n)(\mu_{ij}/m_t)|g_n|/|g_t|]`.
    ``e_n`` may be a :class:`Viscoelastic` law. Moments of inertia come from the particles
    (solid spheres :math:`\tfrac25 mR^2`, solid disks :math:`\tfrac12 mR^2` by default).

    Example:
        >>> Rough(e_n=0.9, beta=0.0).beta, Rough(e_n=0.9, e_t=0.4).beta
        (0.0, -0.4)
    """


@dataclasses.dataclass(frozen=True)
class TC:
    """The TC model against inelastic collapse (Luding & McNamara 1998, physics.md §3).

    A collision is elastic (:math:`e_n = 1`, and :math:`\\beta = -1` for rough rules) if either
    partner had a collision less than ``duration`` ago; walls use the particle's last collision.
    Choose ``duration`` about the physical contact time, much shorter than the mean free time.

    Example:
        >>> TC(Inelastic(0.5), duration=1e-5).duration
        1e-05
    """

    rule: Inelastic | Rough | ContactModel
    duration: float

    def __post_init__(self):
        if isinstance(self.rule, TC):
            raise RuleError("TC cannot wrap another TC")
        if isinstance(self.rule, EMDStar):
            raise RuleError("the TC model does not apply to eMD* (its soft contacts already last t_c)")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise RuleError(f"TC duration must be positive, got {self.duration!r}")

    def laws(self):
        """The wrapped rule's laws (TC acts at run time, see physics.md §3)."""
        return self.rule.laws()

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """The wrapped rule's parameters and the TC duration."""
        self.rule.pack(fp, ip)
        ip[L.IP_TC] = 1
        fp[L.FP_TC] = self.duration


@dataclasses.dataclass(frozen=True)
class Wall(_NormalTangential):
    """Restitution of the hard walls that close every non-periodic axis (physics.md §1.3).

    ``e_n`` (a number, :class:`Viscoelastic`, or a soft contact law :class:`~edmd.physics.contact.Hertz` /
    :class:`~edmd.physics.contact.LinearDashpot` whose central :math:`e_n(v_n)` applies; always with
    :math:`\\mu = m_i`, :math:`R_{\\rm eff} = R_i`), ``beta``/``e_t`` and ``mu`` as for :class:`Rough`;
    the default is an elastic smooth wall (with :class:`~edmd.physics.emdstar.EMDStar`: the rule's contact law).

    Example:
        >>> Wall(e_n=0.8).e_n
        0.8
    """

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write the wall's laws into the core's wall slots (see :func:`pack`)."""
        L.pack_laws(self.laws(), fp, ip, wall=True)



Rule = Inelastic | Rough | ContactModel | TC | EMDStar


def _check_rule(rule):
    if not isinstance(rule, (Inelastic, Rough, ContactModel, TC, EMDStar)):
        raise RuleError(f"not a collision rule: {rule!r} (use Inelastic, Rough, Hertz (= Viscoelastic), LinearDashpot, TC or EMDStar)")


def default_wall(rule) -> Wall:
    """Walls of a simulation that names none: elastic, or the contact law of an eMD* rule."""
    return Wall(e_n=rule.contact) if isinstance(rule, EMDStar) else Wall()


def soft_contact(rule, wall) -> ContactModel | None:
    """The contact law (material) of a rule and its walls: the rule itself (a :class:`Hertz` or
    :class:`LinearDashpot`), the ``e_n`` of a :class:`Rough` rule or of the walls, or an eMD*
    rule's ``contact``; at most one per simulation, since the core holds one."""
    inner = rule.rule if isinstance(rule, TC) else rule
    laws = (inner, getattr(inner, "contact", None), getattr(inner, "e_n", None), wall.e_n)
    found = {obj for obj in laws if isinstance(obj, ContactModel)}
    if len(found) > 1:
        raise RuleError("particles and walls must share one contact law (one material per simulation)")
    return found.pop() if found else None


def pack(rule, wall: Wall, fp: np.ndarray, ip: np.ndarray):
    """Write the codes and parameters of ``rule`` and ``wall`` into the core's ``fp``/``ip`` arrays.

    Each rule packs its own (its ``pack`` method); the contact law that rule and walls share is
    packed here.
    """
    _check_rule(rule)
    rule.pack(fp, ip)
    wall.pack(fp, ip)
    fp[L.FP_ETAB_INV] = viscoelastic_table()[1]
    soft = soft_contact(rule, wall)
    if soft is not None:
        ip[L.IP_EMD_MODEL] = soft.code
        fp[L.FP_SOFT_A], fp[L.FP_SOFT_B] = soft.constants()


def uses_rotation(rule, wall: Wall) -> bool:
    """Whether spins change in collisions (rough particles or rough walls)."""
    _check_rule(rule)
    return rule.laws()[1][0] != L.TANGENT_SMOOTH or wall.laws()[1][0] != L.TANGENT_SMOOTH


_KINDS = {cls.__name__: cls for cls in (Inelastic, Rough, TC, Wall, EMDStar, Hertz, LinearDashpot, Friction)}
_KINDS["Viscoelastic"] = Hertz  # (the name the material had as a rule of its own, in older checkpoints)


def to_dict(obj) -> dict:
    """A JSON-ready description of a rule or wall (``{"type": ..., fields...}``, nested for TC).

    Example:
        >>> to_dict(TC(Rough(0.9, beta=0.0), 1e-4))["rule"]["type"]
        'Rough'
    """
    out = {"type": type(obj).__name__}
    for field in dataclasses.fields(obj):
        value = getattr(obj, field.name)
        out[field.name] = to_dict(value) if dataclasses.is_dataclass(value) else value
    return out


def from_dict(data: dict):
    """Rebuild a rule or wall from :func:`to_dict` output."""
    data = dict(data)
    kind = _KINDS.get(data.pop("type", None))
    if kind is None:
        raise RuleError(f"unknown collision rule description {data!r}")
    return kind(**{k: from_dict(v) if isinstance(v, dict) else v for k, v in data.items()})
