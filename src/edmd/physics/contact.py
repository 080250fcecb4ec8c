r"""Soft-sphere contact models with physical parameters (physics.md §2.2, §4.4, §4.7).

Two normal force laws, both frictionless, acting while the overlap
:math:`\xi = R_1 + R_2 - |\mathbf r_1 - \mathbf r_2| > 0` and the force is repulsive:

* :class:`LinearDashpot`: :math:`F = k\xi + \gamma\dot\xi` (physics.md §2.2.1);
* :class:`Hertz` (viscoelastic spheres): :math:`F = \rho\xi^{3/2} + \tfrac32A\rho\xi^{1/2}\dot\xi`,
  :math:`\rho = \frac{2Y\sqrt{R_{\rm eff}}}{3(1-\nu^2)}` (physics.md §2.2.2).

Masses come from the particles (a :class:`~edmd.state.State`; give them a material density
with ``edmd.lattice(..., density=...)``), so polydisperse pairs mix through the reduced mass
:math:`\mu = m_1m_2/(m_1+m_2)`, the effective radius :math:`R_{\rm eff} = R_1R_2/(R_1+R_2)` and the
contact distance :math:`\sigma = R_1+R_2`. SI units are natural, any consistent units work.

Example:
    >>> from edmd.physics.contact import LinearDashpot, Hertz
    >>> m = 1e-3                                                  # physics.md W8
    >>> dashpot = LinearDashpot(k=1e4, gamma=0.4472136)
    >>> c = dashpot.central(m, m, 1e-3, 1e-3, v_n=1.0)
    >>> round(c.e_n, 6), round(c.t_c * 1e4, 5)
    (0.744079, 6.60999)
    >>> glass = Hertz(young=63e9, poisson=0.2, A=1e-7)            # physics.md W9
    >>> m = 2500 * 4 / 3 * 3.141592653589793 * 1e-9
    >>> round(glass.central(m, m, 1e-3, 1e-3, v_n=1.0).e_n, 6)
    0.916405
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from .._core import contact as _c
from .._core.twobody import dashpot_central, solve_scaled


class ContactError(ValueError):
    """Invalid contact-model parameters or impact (the message names the problem)."""


class ContactWarning(UserWarning):
    """A contact outside the validity range of its force law (e.g. viscoelastic delta > 1)."""


def _positive(name, value, allow_zero=False):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ContactError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        need = "non-negative" if allow_zero else "positive"
        raise ContactError(f"{name} must be a finite {need} number, got {value!r}")
    return v


def pair_constants(m1, m2, R1, R2):
    r"""Reduced mass, effective radius and contact distance of a pair.

    .. math:: \mu = \frac{m_1m_2}{m_1+m_2},\quad R_{\rm eff} = \frac{R_1R_2}{R_1+R_2},\quad \sigma = R_1+R_2

    Example:
        >>> pair_constants(1.0, 3.0, 0.5, 0.5)
        (0.75, 0.25, 1.0)
    """
    m1, m2 = _positive("mass m1", m1), _positive("mass m2", m2)
    R1, R2 = _positive("radius R1", R1), _positive("radius R2", R2)
    return m1 * m2 / (m1 + m2), R1 * R2 / (R1 + R2), R1 + R2


@dataclasses.dataclass(frozen=True)
class Scales:
    r"""Dimensionless parameters and scales of one impact (physics.md §4.4).

    Attributes:
        damping: :math:`\zeta_d` (dashpot) or :math:`\delta = \beta_v v_n^{1/5}` (Hertz).
        softness: :math:`\Lambda = \ell_s/\sigma`.
        tan_alpha: :math:`v_t/v_n`.
        t_s, l_s: time and length scales (:math:`t_c = \tau_c t_s`, :math:`\xi = X\ell_s`).
    """

    damping: float
    softness: float
    tan_alpha: float
    t_s: float
    l_s: float


@dataclasses.dataclass(frozen=True)
class CentralCollision:
    r"""Outcome of a head-on contact (physics.md §2.2): restitution, duration, residual overlap.

    Attributes:
        e_n: normal coefficient of restitution :math:`-\dot\xi(t_c)/v_n`.
        t_c: contact duration (until the force vanishes).
        xi_c: overlap left when the force vanishes (:math:`\ge 0`, delayed recovery).
    """

    e_n: float
    t_c: float
    xi_c: float


class ContactModel:
    """Common interface of the contact laws (see :class:`LinearDashpot`, :class:`Hertz`)."""

    #: short name used in configuration files and table files
    name: str = ""
    #: integer code of the compiled core
    code: int = -1

    def constants(self) -> tuple[float, float]:
        """The two floats ``(a, b)`` that carry the model into compiled code (:mod:`edmd._core.contact`)."""
        raise NotImplementedError

    def _check_impact(self, m1, m2, R1, R2, v_n, v_t):
        mu, reff, sigma = pair_constants(m1, m2, R1, R2)
        v_n = _positive("normal impact speed v_n", v_n)
        v_t = _positive("tangential impact speed v_t", v_t, allow_zero=True)
        return mu, reff, sigma, v_n, v_t

    def scales(self, m1, m2, R1, R2, v_n, v_t=0.0) -> Scales:
        """Dimensionless parameters of an impact with normal and tangential speeds ``v_n, v_t``.

        Example:
            >>> s = LinearDashpot(k=1e4, gamma=0.0).scales(1.0, 1.0, 0.5, 0.5, v_n=1.0)
            >>> round(s.softness, 6), s.damping
            (0.007071, 0.0)
        """
        mu, reff, sigma, v_n, v_t = self._check_impact(m1, m2, R1, R2, v_n, v_t)
        a, b = self.constants()
        c, lam, ts, ls = _c.contact_scales(self.code, a, b, mu, reff, sigma, v_n)
        damping = 0.5 * c if self.code == _c.MODEL_DASHPOT else c
        self._warn_validity(damping)
        return Scales(damping, lam, v_t / v_n, ts, ls)

    def table_coordinates(self, m1, m2, R1, R2, v, b) -> tuple[float, float, float]:
        r"""Coordinates :math:`(u_1, \Lambda_v, b)` of an impact with total speed ``v`` and eccentricity ``b`` (physics.md §4.7).

        Example:
            >>> LinearDashpot(k=1e4, gamma=0.0).table_coordinates(1.0, 1.0, 0.5, 0.5, v=2.0, b=0.5)[2]
            0.5
        """
        mu, reff, sigma = pair_constants(m1, m2, R1, R2)
        v = _positive("impact speed v", v)
        b = float(b)
        if not 0.0 <= b < 1.0:
            raise ContactError(f"eccentricity b must be in [0, 1), got {b!r}")
        a, bb = self.constants()
        u1, lam_v = _c.table_coordinates(self.code, a, bb, mu, reff, sigma, v)
        return u1, lam_v, b

    def central(self, m1, m2, R1, R2, v_n) -> CentralCollision:
        """Restitution coefficient, duration and residual overlap of a head-on impact (physics.md §2.2).

        Example:
            >>> c = Hertz(young=1e7, poisson=0.5, A=0.0).central(1.0, 1.0, 0.5, 0.5, v_n=1.0)
            >>> round(c.e_n, 12), c.xi_c
            (1.0, 0.0)
        """
        s = self.scales(m1, m2, R1, R2, v_n)
        if self.code == _c.MODEL_DASHPOT:
            tau, e, xc = dashpot_central(s.damping)
        else:
            _phi, _d, tau, e, xc, _psi = solve_scaled(self.code, s.damping, 0.0, 0.0, 1e-12, np.zeros((13, 3)))
        return CentralCollision(float(e), float(tau * s.t_s), float(xc * s.l_s))

    def force(self, xi, xi_dot, R1, R2):
        """Normal force at overlap ``xi`` (> 0) and overlap rate ``xi_dot``, clipped at zero (array-friendly).

        Example:
            >>> float(LinearDashpot(k=100.0, gamma=1.0).force(0.01, -0.5, 0.5, 0.5))
            0.5
        """
        a, b = self.constants()
        xi = np.asarray(xi, float)
        xi_dot = np.asarray(xi_dot, float)
        if self.code == _c.MODEL_HERTZ:
            rho = a * math.sqrt(R1 * R2 / (R1 + R2))
            f = rho * np.sqrt(np.maximum(xi, 0.0)) * (xi + b * xi_dot)
        else:
            f = a * xi + b * xi_dot
        return np.where(xi > 0, np.maximum(f, 0.0), 0.0)

    def _warn_validity(self, damping):
        """Hook: warn when an impact leaves the model's range of validity."""


@dataclasses.dataclass(frozen=True)
class LinearDashpot(ContactModel):
    r"""Linear spring-dashpot contact :math:`F = k\xi + \gamma\dot\xi` (physics.md §2.2.1, §4.4).

    The restitution coefficient is independent of the impact speed:
    :math:`e_n = \exp(-\zeta_d\omega_0t_c)` with :math:`\omega_0 = \sqrt{k/\mu}`,
    :math:`\zeta_d = \gamma/(2\sqrt{k\mu})` and the force-based contact duration :math:`t_c`.

    Args:
        k: spring constant [N/m], > 0.
        gamma: damping constant [kg/s], >= 0.

    Example:
        >>> d = LinearDashpot.from_restitution(0.9, k=1e4, mass=1.0)   # equal masses 1
        >>> round(d.central(1.0, 1.0, 0.5, 0.5, v_n=3.0).e_n, 12)
        0.9
    """

    k: float
    gamma: float = 0.0
    name = "dashpot"
    code = _c.MODEL_DASHPOT

    def __post_init__(self):
        object.__setattr__(self, "k", _positive("spring constant k (stiffness)", self.k))
        object.__setattr__(self, "gamma", _positive("damping constant gamma", self.gamma, allow_zero=True))

    def constants(self):
        return self.k, self.gamma

    def damping_ratio(self, m1, m2) -> float:
        r""":math:`\zeta_d = \gamma/(2\sqrt{k\mu})` of a pair of masses ``m1, m2``."""
        mu = m1 * m2 / (m1 + m2)
        return self.gamma / (2.0 * math.sqrt(self.k * mu))

    def restitution_rule(self, mass: float, mass2: float | None = None):
        """The event-driven rule with this dashpot's (constant) :math:`e_n` for a pair of masses (:class:`edmd.physics.collide.Inelastic`).

        Example:
            >>> round(LinearDashpot.from_restitution(0.9, k=1e4, mass=1.0).restitution_rule(1.0).e_n, 12)
            0.9
        """
        from .collide import Inelastic

        m2 = mass if mass2 is None else mass2
        return Inelastic(dashpot_central(self.damping_ratio(mass, m2))[1])

    @classmethod
    def from_restitution(cls, e_n: float, k: float, mass: float, mass2: float | None = None) -> LinearDashpot:
        r"""The dashpot with restitution ``e_n`` for a pair of masses ``mass``, ``mass2`` (default equal).

        Solves the monotonic relation :math:`e_n(\zeta_d)` of physics.md §2.2.1 by bisection.
        """
        e_n = float(e_n)
        if not 0.0 < e_n <= 1.0:
            raise ContactError(f"restitution coefficient e_n must be in (0, 1], got {e_n!r}")
        k = _positive("spring constant k (stiffness)", k)
        m1 = _positive("mass", mass)
        m2 = m1 if mass2 is None else _positive("mass2", mass2)
        mu = m1 * m2 / (m1 + m2)
        if e_n == 1.0:
            return cls(k, 0.0)
        lo, hi = 0.0, 1.0
        while dashpot_central(hi)[1] > e_n:
            hi *= 2.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if dashpot_central(mid)[1] > e_n:
                lo = mid
            else:
                hi = mid
            if hi - lo <= 1e-16 * hi:
                break
        zeta = 0.5 * (lo + hi)
        return cls(k, 2.0 * zeta * math.sqrt(k * mu))


@dataclasses.dataclass(frozen=True)
class Hertz(ContactModel):
    r"""Viscoelastic Hertz contact (physics.md §2.2.2, §4.4).

    .. math::
        F = \rho\,\xi^{3/2} + \tfrac32A\rho\,\xi^{1/2}\dot\xi,\qquad
        \rho = \frac{2Y\sqrt{R_{\rm eff}}}{3(1-\nu^2)}

    The restitution coefficient depends on the impact speed only through
    :math:`\delta = \tfrac32A(\rho/\mu)^{2/5}v_n^{1/5}`; the quasi-static model is valid for
    :math:`\delta \lesssim 1` (a :class:`ContactWarning` is issued beyond).

    Args:
        young: Young's modulus :math:`Y` [Pa], > 0.
        poisson: Poisson ratio :math:`\nu`, in :math:`(-1, 0.5]`.
        A: dissipative time constant [s], >= 0 (0: elastic Hertz).

    Example:
        >>> h = Hertz(young=63e9, poisson=0.2, A=0.0)
        >>> round(h.central(1.0, 1.0, 0.5, 0.5, v_n=1.0).e_n, 12)
        1.0
    """

    young: float
    poisson: float
    A: float = 0.0
    name = "hertz"
    code = _c.MODEL_HERTZ

    def __post_init__(self):
        object.__setattr__(self, "young", _positive("Young's modulus young", self.young))
        try:
            nu = float(self.poisson)
        except (TypeError, ValueError):
            raise ContactError(f"Poisson ratio must be a number, got {self.poisson!r}") from None
        if not -1.0 < nu <= 0.5:
            raise ContactError(f"Poisson ratio must be in (-1, 0.5], got {self.poisson!r}")
        object.__setattr__(self, "poisson", nu)
        object.__setattr__(self, "A", _positive("dissipative constant A", self.A, allow_zero=True))

    def constants(self):
        return 2.0 * self.young / (3.0 * (1.0 - self.poisson**2)), 1.5 * self.A

    def restitution_rule(self):
        """The event-driven rule with this material's :math:`e_n(v_n)` (:class:`edmd.physics.collide.Viscoelastic`).

        Example:
            >>> h = Hertz(young=63e9, poisson=0.2, A=1e-7)
            >>> m = 2500 * 4 / 3 * 3.141592653589793 * 1e-9
            >>> round(h.restitution_rule().restitution(1.0, mu=m / 2, r_eff=0.5e-3), 4), round(h.central(m, m, 1e-3, 1e-3, 1.0).e_n, 4)
            (0.9164, 0.9164)
        """
        from .collide import Viscoelastic

        return Viscoelastic(young=self.young, poisson=self.poisson, A=self.A)

    def prefactor(self, R1, R2) -> float:
        r"""Hertz prefactor :math:`\rho = \frac{2Y\sqrt{R_{\rm eff}}}{3(1-\nu^2)}` of a pair [N m^-3/2]."""
        return self.constants()[0] * math.sqrt(R1 * R2 / (R1 + R2))

    def _warn_validity(self, damping):
        if damping > 1.0:
            warnings.warn(
                f"viscoelastic contact with delta = {damping:.3g} > 1: the dissipative force exceeds the "
                "elastic one, outside the quasi-static viscoelastic model (physics.md §2.2.2)",
                ContactWarning,
                stacklevel=3,
            )


MODELS = {"dashpot": LinearDashpot, "hertz": Hertz}
