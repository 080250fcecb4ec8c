r"""Tangential contact laws with Coulomb friction for soft spheres and disks (docs/physics.md §2.6).

A :class:`Friction` adds a tangential force to a normal contact law of :mod:`.contact`
(linear dashpot or viscoelastic Hertz). With the overlap :math:`\xi_n`, the lever arms to the
centre of the overlap region :math:`\ell_{i,j} = R_{i,j} - \xi_n/2` and the unit normal
:math:`\hat{\mathbf n} = (\mathbf r_i - \mathbf r_j)/r`, the contact point slides at

.. math::
    \mathbf v_c = \mathbf g - (\ell_i\boldsymbol\omega_i + \ell_j\boldsymbol\omega_j)\times\hat{\mathbf n},\qquad
    \mathbf v_t = \mathbf v_c - (\mathbf v_c\cdot\hat{\mathbf n})\hat{\mathbf n},

and a tangential spring of extension :math:`\boldsymbol\zeta` (the contact's history) obeys

.. math::
    \dot{\boldsymbol\zeta} = \mathbf v_t - (\dot{\hat{\mathbf n}}\cdot\boldsymbol\zeta)\,\hat{\mathbf n}
    \quad(\text{kept in the tangent plane, its length unchanged by the rotation}),

.. math::
    \mathbf F_t^* = -k_t\boldsymbol\zeta - \eta_t\mathbf v_t,\qquad
    \mathbf F_t = \mathbf F_t^*\ \text{if}\ |\mathbf F_t^*| \le \mu F_n,\ \text{else}\
    \mathbf F_t = \mu F_n\frac{\mathbf F_t^*}{|\mathbf F_t^*|},\ \
    \boldsymbol\zeta = -\frac{\mathbf F_t + \eta_t\mathbf v_t}{k_t}

(Cundall–Strack; the spring is shortened to the Coulomb limit while sliding). ``law="linear"``
has :math:`k_t` constant; ``law="mindlin"`` has the Hertz–Mindlin no-slip stiffness
:math:`k_t = k_{t0}\,a` with the contact radius :math:`a = \sqrt{R_{\rm eff}\xi_n}`, by default
:math:`k_{t0} = 8G_{\rm eff}`, :math:`G_{\rm eff} = Y/(4(2-\nu)(1+\nu))` from the Hertz law's
Young's modulus and Poisson ratio. The tangential damping is :math:`\eta_t = x_t\eta_n`, a
multiple of the normal damping coefficient (:math:`\gamma` of the dashpot,
:math:`\tfrac32A\rho\sqrt{\xi_n}` of viscoelastic Hertz). :math:`F_n` is the total normal
force (clipped at zero). The force :math:`\mathbf F_n\hat{\mathbf n} + \mathbf F_t` acts on
:math:`i` at its contact point, the opposite on :math:`j`; the torques are
:math:`\boldsymbol\tau_{i,j} = -\ell_{i,j}\,\hat{\mathbf n}\times\mathbf F_t`. The lever arms add up
to :math:`r`, so linear and angular momentum are conserved, and the same arms in
:math:`\mathbf v_c` make :math:`\mathbf F_t\cdot\mathbf v_t` the power of the tangential force.
These are the laws of LAMMPS ``pair granular`` (``tangential linear_history`` / ``mindlin``),
which applies the torque at the same point but computes :math:`\mathbf v_c` with the full radii.

Example:
    >>> from edmd.physics.contact import Hertz
    >>> f = Friction(mu=0.3, law="mindlin", damping=1.0)
    >>> glass = Hertz(young=63e9, poisson=0.2, A=1e-7)
    >>> round(f.stiffness_for(glass) / 1e9, 4)          # 8 G_eff = 2Y / ((2 - nu)(1 + nu))
    58.3333
"""

from __future__ import annotations

import dataclasses
import math

from .contact import ContactError, ContactModel, Hertz, _positive

#: tangential laws and their compiled-core codes (0: frictionless)
LAWS = {"linear": 1, "mindlin": 2}


@dataclasses.dataclass(frozen=True)
class Friction:
    r"""Tangential spring, dashpot and Coulomb slider of a soft contact (see the module docs).

    Args:
        mu: Coulomb friction coefficient, >= 0 (``math.inf``: the contact never slides).
        law: ``"linear"`` (Cundall–Strack, constant :math:`k_t`) or ``"mindlin"``
            (:math:`k_t = k_{t0}\sqrt{R_{\rm eff}\xi_n}`).
        stiffness: :math:`k_t` [force/length] for ``linear`` (required); :math:`k_{t0}`
            [force/length²] for ``mindlin`` (default :math:`8G_{\rm eff}` of a Hertz law).
        damping: :math:`x_t`, the tangential damping as a multiple of the normal damping
            coefficient, >= 0.

    Example:
        >>> Friction(mu=0.5, stiffness=2e3).law, Friction(mu=0.5, stiffness=2e3).code
        ('linear', 1)
    """

    mu: float
    law: str = "linear"
    stiffness: float | None = None
    damping: float = 0.0

    def __post_init__(self):
        try:
            mu = float(self.mu)
        except (TypeError, ValueError):
            raise ContactError(f"friction coefficient mu must be a number, got {self.mu!r}") from None
        if math.isnan(mu) or mu < 0.0:
            raise ContactError(f"friction coefficient mu must be >= 0 (inf: no sliding), got {self.mu!r}")
        object.__setattr__(self, "mu", mu)
        if self.law not in LAWS:
            raise ContactError(f"unknown tangential law {self.law!r}; choose from {sorted(LAWS)}")
        if self.stiffness is None:
            if self.law == "linear":
                raise ContactError("the linear tangential law needs its stiffness k_t (stiffness = ...)")
        else:
            object.__setattr__(self, "stiffness", _positive("tangential stiffness", self.stiffness))
        object.__setattr__(self, "damping", _positive("tangential damping multiplier", self.damping, allow_zero=True))

    @property
    def code(self) -> int:
        """Compiled-core code of the law (1 linear, 2 Mindlin)."""
        return LAWS[self.law]

    def stiffness_for(self, contact: ContactModel) -> float:
        r"""The stiffness constant with ``contact``'s normal law: :math:`k_t` or :math:`k_{t0}`.

        Mindlin without an explicit stiffness takes :math:`k_{t0} = 8G_{\rm eff} = 2Y/((2-\nu)(1+\nu))`
        from a :class:`~edmd.physics.contact.Hertz` law (equal materials).
        """
        if self.stiffness is not None:
            return self.stiffness
        if not isinstance(contact, Hertz):
            raise ContactError("Mindlin friction takes its stiffness from a Hertz law's Young's modulus and Poisson ratio; give stiffness = ... for a dashpot")
        nu = contact.poisson
        return 2.0 * contact.young / ((2.0 - nu) * (1.0 + nu))

    def constants(self, contact: ContactModel) -> tuple[int, float, float, float]:
        """``(code, k_t or k_t0, x_t, mu)`` for the compiled core."""
        return self.code, self.stiffness_for(contact), self.damping, self.mu


__all__ = ["LAWS", "Friction"]
