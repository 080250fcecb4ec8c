r"""Two-body soft collisions: the matrix of restitution and the eMD* lab-frame update (physics.md §4).

A contact of two soft spheres is reduced to the relative motion in its collision plane
(§4.1–§4.3), scaled to three dimensionless parameters (damping, softness :math:`\Lambda`,
:math:`\tan\alpha`, §4.4) and integrated in compiled code (adaptive DOP853) until the force
vanishes. The result is the *matrix of restitution* (§4.5):

* :math:`\Phi`: rotation of the inter-centre unit vector during the contact (rad),
* :math:`D = r(t_c)/\sigma`: distance ratio at the end (:math:`< 1` for dissipative contacts),
* :math:`\tau_c = t_c/t_s`: scaled contact duration,
* :math:`\hat\varepsilon = \dot r(t_c)/v_n`: normal restitution including centrifugal effects.

:func:`lab_frame_update` turns it into the eMD* relocation of the two spheres and their
post-collisional velocities (§4.6).

Example:
    >>> from edmd.physics.twobody import solve
    >>> r = solve("dashpot", damping=0.1, softness=0.01, tan_alpha=0.9 / (1 - 0.81) ** 0.5)
    >>> [round(x, 6) for x in (r.Phi, r.D, r.tau_c, r.eps_hat)]    # physics.md §4.10(c)
    [0.059619, 0.9985, 2.855258, 0.750013]
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import contact as _c
from .._core import twobody_friction as _tf
from .._core.twobody import lab_frame_update as _lab_frame_update
from .._core.twobody import solve_scaled
from ..state import default_inertia
from .contact import MODELS, ContactError, ContactModel, _positive, pair_constants

#: default relative tolerance of the direct solver
RTOL = 1e-12


@dataclasses.dataclass(frozen=True)
class Restitution:
    r"""The matrix of restitution of one contact (physics.md §4.5), with its scales.

    Attributes:
        Phi: rotation of the inter-centre vector [rad].
        D: distance ratio :math:`r(t_c)/\sigma = 1 - \Lambda X_c`.
        tau_c: scaled contact duration :math:`t_c/t_s`.
        eps_hat: :math:`\hat\varepsilon = \dot r(t_c)/v_n`.
        X_c: scaled residual overlap :math:`\xi_c/\ell_s` (:math:`1 - D = \Lambda X_c` without cancellation).
        t_s, l_s: time and length scales (1 for a purely scaled solve).

    Example:
        >>> r = solve("dashpot", 0.0, 0.0)
        >>> [round(x, 9) for x in r.as_tuple()], r.t_c == r.tau_c
        ([0.0, 1.0, 3.141592654, 1.0], True)
    """

    Phi: float
    D: float
    tau_c: float
    eps_hat: float
    X_c: float
    t_s: float = 1.0
    l_s: float = 1.0

    @property
    def t_c(self) -> float:
        """Contact duration :math:`\\tau_c t_s`."""
        return self.tau_c * self.t_s

    @property
    def xi_c(self) -> float:
        """Residual overlap :math:`X_c\\ell_s` when the force vanishes."""
        return self.X_c * self.l_s

    def as_tuple(self) -> tuple[float, float, float, float]:
        """``(Phi, D, tau_c, eps_hat)``."""
        return self.Phi, self.D, self.tau_c, self.eps_hat


def model_code(model) -> int:
    """Compiled-core code of a model given as a :class:`~edmd.physics.contact.ContactModel`, its class or its name.

    Example:
        >>> model_code("dashpot"), model_code("hertz")
        (0, 1)
    """
    if isinstance(model, ContactModel) or (isinstance(model, type) and issubclass(model, ContactModel)):
        return model.code
    if isinstance(model, str) and model in MODELS:
        return MODELS[model].code
    raise ContactError(f"unknown contact model {model!r}; choose from {sorted(MODELS)}")


def solve(model, damping: float, softness: float, tan_alpha: float = 0.0, rtol: float = RTOL) -> Restitution:
    r"""Matrix of restitution for the three scaled parameters (physics.md §4.4, §4.5).

    Integrates

    .. math::
        X'' = -\tilde F(X, X') - \frac{\Lambda\tan^2\alpha}{(1-\Lambda X)^3},\qquad
        \varphi' = \frac{\Lambda\tan\alpha}{(1-\Lambda X)^2}

    with :math:`\tilde F = X + 2\zeta_dX'` (dashpot) or :math:`\sqrt X(X + \delta X')` (Hertz) from
    :math:`X = 0, X' = 1` until :math:`\tilde F = 0`.

    Args:
        model: ``"dashpot"``, ``"hertz"`` or a contact model.
        damping: :math:`\zeta_d` (dashpot) or :math:`\delta` (Hertz), >= 0.
        softness: :math:`\Lambda = \ell_s/\sigma`, in ``[0, 1)``.
        tan_alpha: :math:`v_t/v_n` >= 0.
        rtol: relative tolerance of the integrator.

    Example:
        >>> round(solve("hertz", 0.0, 0.0).tau_c, 7)     # elastic Hertz, physics.md §2.2.2
        3.2180655
    """
    code = model_code(model)
    damping = _positive("damping", damping, allow_zero=True)
    softness = _positive("softness", softness, allow_zero=True)
    tan_alpha = _positive("tan_alpha", tan_alpha, allow_zero=True)
    if softness >= 1.0:
        raise ContactError(f"softness must be below 1 (overlap scale below the contact distance), got {softness!r}")
    if not 0.0 < rtol < 1e-3:
        raise ContactError(f"rtol must be in (0, 1e-3), got {rtol!r}")
    c = 2.0 * damping if code == _c.MODEL_DASHPOT else damping
    Phi, D, tau, eps, xc, _psi = solve_scaled(code, c, softness, tan_alpha, rtol, np.zeros((13, 3)))
    if not math.isfinite(tau):
        raise ContactError(f"the contact integration did not terminate (damping={damping}, softness={softness}, tan_alpha={tan_alpha})")
    return Restitution(float(Phi), float(D), float(tau), float(eps), float(xc))


def collide(contact: ContactModel, m1, m2, R1, R2, v_n, v_t=0.0, table=None, outside: str = "error") -> Restitution:
    r"""Matrix of restitution of a physical impact: speeds ``v_n > 0`` (normal), ``v_t`` (tangential).

    Args:
        contact: a :class:`~edmd.physics.contact.LinearDashpot` or :class:`~edmd.physics.contact.Hertz`.
        m1, m2, R1, R2: masses and radii.
        v_n, v_t: normal and tangential relative speeds at first contact.
        table: ``None`` (direct solver), ``"default"`` (the shipped table of the model) or a
            :class:`~edmd.physics.tables.RestitutionTable`.
        outside: with a table, what to do outside its box: ``"error"`` or ``"solve"`` (direct solver).

    Example:
        >>> from edmd.physics.contact import LinearDashpot
        >>> r = collide(LinearDashpot(k=1e4, gamma=0.0), 1.0, 1.0, 0.5, 0.5, v_n=1.0, v_t=1.0)
        >>> r.D, round(r.eps_hat, 12), round(r.t_c, 6)
        (1.0, 1.0, 0.022113)
    """
    if not isinstance(contact, ContactModel):
        raise ContactError(f"contact must be a LinearDashpot or Hertz model, got {contact!r}")
    s = contact.scales(m1, m2, R1, R2, v_n, v_t)
    if table is None:
        r = solve(contact, s.damping, s.softness, s.tan_alpha)
    else:
        from .tables import default_table

        tab = default_table(contact.name) if isinstance(table, str) and table == "default" else table
        if tab.model != contact.name:
            raise ContactError(f"a {tab.model!r} table cannot serve a {contact.name!r} contact")
        v = math.hypot(v_n, v_t)
        u1, lam_v, b = contact.table_coordinates(m1, m2, R1, R2, v, v_t / v)
        r = tab.lookup(u1, lam_v, b, outside=outside)
    return dataclasses.replace(r, t_s=s.t_s, l_s=s.l_s)


@dataclasses.dataclass(frozen=True)
class LabUpdate:
    """Result of :func:`lab_frame_update`: relocated positions at :math:`t_0`, centre-of-mass
    velocity and the post-collisional velocity increments (arrays of the input dimension)."""

    r1: np.ndarray
    r2: np.ndarray
    V: np.ndarray
    delta1: np.ndarray
    delta2: np.ndarray
    v_n: float
    v_t: float


def _vec3(name, x):
    a = np.asarray(x, float).ravel()
    if a.shape not in ((2,), (3,)) or not np.all(np.isfinite(a)):
        raise ContactError(f"{name} must be 2 or 3 finite numbers, got {x!r}")
    out = np.zeros(3)
    out[: a.size] = a
    return out, a.size


def _pair_vectors(r1, r2, v1, v2):
    """The four vectors as length-3 arrays (2D: z = 0) and their common dimension."""
    (a1, d), (a2, d2), (u1, d3), (u2, d4) = (_vec3(name, x) for name, x in (("r1", r1), ("r2", r2), ("v1", v1), ("v2", v2)))
    if len({d, d2, d3, d4}) != 1:
        raise ContactError("r1, r2, v1, v2 must all have the same dimension")
    return a1, a2, u1, u2, d


def _touching(a1, a2, u1, u2, sigma):
    """Refuse a pair that does not touch (``|r1 - r2| = sigma``) or does not approach; returns the unit normal ``(r1 - r2) / |r1 - r2|``."""
    rel = a1 - a2
    dist = float(np.linalg.norm(rel))
    if abs(dist - sigma) > 1e-9 * sigma:
        raise ContactError(f"the spheres must touch: |r1 - r2| = {dist!r} but R1 + R2 = {sigma!r}")
    if float(rel @ (u1 - u2)) >= 0.0:
        raise ContactError("the spheres must approach each other ((r1 - r2).(v1 - v2) < 0)")
    return rel / dist


def lab_frame_update(r1, r2, v1, v2, m1, m2, R1, R2, restitution: Restitution) -> LabUpdate:
    r"""eMD* map in the lab frame (physics.md §4.6) for two spheres touching at :math:`t_0`.

    .. math::
        \mathbf r_{1,2}^A = \mathbf R \pm \tfrac{m_{2,1}}{M} D\sigma\,\hat{\mathbf n}',\qquad
        \mathbf v_{1,2}(t_0+t_c) = \mathbf V + \mathbf G t_c + \boldsymbol\Delta_{1,2},\qquad
        \boldsymbol\Delta_{1,2} = \pm\tfrac{m_{2,1}}{M}\big(\hat\varepsilon v_n\hat{\mathbf n}' + \tfrac{v_t}{D}\hat{\mathbf t}'\big)

    ``r2`` must be the image of particle 2 closest to ``r1``, at contact distance ``R1 + R2``
    and approaching. The compiled kernel (:func:`edmd._core.twobody.lab_frame_update`) is what
    the event loop calls; this wrapper validates and accepts 2D or 3D vectors.

    Example:
        >>> from edmd.physics.contact import LinearDashpot
        >>> c = LinearDashpot(k=1e4, gamma=0.0)
        >>> r = collide(c, 1.0, 1.0, 0.5, 0.5, v_n=1.0)
        >>> u = lab_frame_update([0, 0], [1, 0], [0, 0], [-1, 0], 1.0, 1.0, 0.5, 0.5, r)
        >>> (u.V + u.delta1).round(12).tolist(), (u.V + u.delta2).round(12).tolist() == [0, 0]  # exchanged
        ([-1.0, 0.0], True)
    """
    a1, a2, u1, u2, d = _pair_vectors(r1, r2, v1, v2)
    m1, m2 = _positive("mass m1", m1), _positive("mass m2", m2)
    sigma = _positive("radius R1", R1) + _positive("radius R2", R2)
    _touching(a1, a2, u1, u2, sigma)
    out = np.zeros((5, 3))
    vn, vt = _lab_frame_update(a1, a2, u1, u2, m1, m2, sigma, restitution.Phi, restitution.D, restitution.eps_hat, out)
    out = out[:, :d].copy()
    return LabUpdate(out[0], out[1], out[2], out[3], out[4], float(vn), float(vt))


@dataclasses.dataclass(frozen=True)
class FrictionalCollision:
    r"""The end of one frictional contact (docs/physics.md §4.11), in the lab frame.

    Attributes:
        t_c: contact duration (the normal force vanishes).
        r1, r2: positions at :math:`t_0 + t_c` (the centre of mass in free flight, no gravity).
        v1, v2: velocities at :math:`t_0 + t_c`.
        omega1, omega2: spins at :math:`t_0 + t_c` (2D: scalars).
        switches: stick/slip switches during the contact.
        sliding: whether the contact ended sliding.
        spring_energy: energy left in the tangential spring at the end (lost with the contact).
    """

    t_c: float
    r1: np.ndarray
    r2: np.ndarray
    v1: np.ndarray
    v2: np.ndarray
    omega1: np.ndarray | float
    omega2: np.ndarray | float
    switches: int
    sliding: bool
    spring_energy: float


def _spin3(name, w, d):
    if d == 2:
        try:
            return np.array([0.0, 0.0, float(w)])
        except (TypeError, ValueError):
            raise ContactError(f"{name} of a disk must be a number (the spin about z), got {w!r}") from None
    a, dw = _vec3(name, w)
    if dw != 3:
        raise ContactError(f"{name} of a sphere must be 3 numbers, got {w!r}")
    return a


def collide_frictional(contact: ContactModel, friction, r1, r2, v1, v2, omega1, omega2, m1, m2, R1, R2, I1=None, I2=None, rtol: float = 1e-10) -> FrictionalCollision:
    r"""Integrate one frictional contact of two spheres (3D) or disks (2D) touching now (docs/physics.md §4.11).

    The normal law of ``contact`` plus the tangential spring, damping and Coulomb slider of
    ``friction`` (:class:`~edmd.physics.friction.Friction`), with spins, from first touch until
    the normal force vanishes: the same equations as the DEM (:mod:`edmd.run.dem`) in continuous
    time, in the scaled Cartesian form of :mod:`edmd._core.twobody_friction`.

    Args:
        contact, friction: the laws.
        r1, r2, v1, v2: positions (touching: ``|r1 - r2| = R1 + R2``, ``r2`` the closest image) and
            velocities (approaching), 2 or 3 numbers each.
        omega1, omega2: spins (3 numbers; a disk's: one number, about z).
        m1, m2, R1, R2: masses and radii; I1, I2: moments of inertia (default solid spheres/disks).
        rtol: relative tolerance of the integration.

    Example:
        >>> from edmd.physics.contact import LinearDashpot
        >>> from edmd.physics.friction import Friction
        >>> end = collide_frictional(LinearDashpot(k=1e6), Friction(mu=0.5, stiffness=2e6 / 7),
        ...                          [0, 0, 0], [1, 0, 0], [1, 0.2, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], 1.0, 1.0, 0.5, 0.5)
        >>> round(float(end.v2[0]), 4), end.sliding      # the normal motion exchanged, the contact ends sliding
        (1.0, True)
    """
    from .friction import Friction

    if not isinstance(contact, ContactModel):
        raise ContactError(f"contact must be a LinearDashpot or Hertz model, got {contact!r}")
    if not isinstance(friction, Friction):
        raise ContactError(f"friction must be an edmd.Friction, got {friction!r}")
    a1, a2, u1, u2, d = _pair_vectors(r1, r2, v1, v2)
    w1, w2 = _spin3("omega1", omega1, d), _spin3("omega2", omega2, d)
    m1, m2 = _positive("mass m1", m1), _positive("mass m2", m2)
    R1, R2 = _positive("radius R1", R1), _positive("radius R2", R2)
    solid = default_inertia(np.array([m1, m2]), np.array([R1, R2]), d)
    I1 = float(solid[0]) if I1 is None else _positive("inertia I1", I1)
    I2 = float(solid[1]) if I2 is None else _positive("inertia I2", I2)
    sigma = R1 + R2
    ex = _touching(a1, a2, u1, u2, sigma)
    v_n = -float((u1 - u2) @ ex)
    ca, cb = contact.constants()
    code, kt, xt, mu_c = friction.constants(contact)
    F = np.zeros((_tf.SCRATCH_ROWS, _tf.N_STATE))
    out = np.zeros((7, 3))
    t_c = _tf.frictional_update(contact.code, ca, cb, code, kt, xt, mu_c, m1, m2, R1, R2, I1, I2, a1, a2, u1, u2, w1, w2, rtol, F, out)
    state, prm, info = F[_tf.ROW_STATE], F[_tf.ROW_PRM, : _tf.INFO_AT], F[_tf.ROW_PRM, _tf.INFO_AT :]
    if not math.isfinite(t_c) or not np.all(np.isfinite(out)):
        why = ""
        if code == 2 and xt > 0.0:
            why = ("; Mindlin's stiffness vanishes at the touch, so while the tangential damping force exceeds the Coulomb "
                   "limit the spring held at that limit would need an infinite extension: use damping = 0 with Mindlin")  # fmt: skip
        raise ContactError(f"the frictional contact integration did not finish (v_n = {v_n!r}, friction = {friction!r}){why}")
    sliding = int(info[_tf.I_MODE]) == _tf.SLIDE
    if sliding:  # the spring held at the Coulomb limit (zero force at the end: -eta v_t / k)
        _tf._switch(prm, _tf.SLIDE, state)
    _n0, _n1, _n2, _rho, _X, _V, _fn, _eta, _f1, _f2, _w0, _w1, _w2, _c0, _c1, _c2, _cn, _v0, _v1, _v2, kk, _kr = _tf._kinematics(prm, state)
    mu = m1 * m2 / (m1 + m2)
    spring = 0.5 * kk * float(state[_tf.Z : _tf.Z + 3] @ state[_tf.Z : _tf.Z + 3]) * mu * v_n * v_n  # k z^2 / 2 in units of mu v_n^2
    r1e, r2e, V = out[0] + out[2] * t_c, out[1] + out[2] * t_c, out[2]
    o1, o2 = out[5], out[6]
    cut = slice(0, d)
    spin = (lambda o: float(o[2])) if d == 2 else (lambda o: o)
    return FrictionalCollision(
        t_c=float(t_c),
        r1=r1e[cut],
        r2=r2e[cut],
        v1=(V + out[3])[cut],
        v2=(V + out[4])[cut],
        omega1=spin(o1),
        omega2=spin(o2),
        switches=int(info[_tf.I_SWITCHES]),
        sliding=sliding,
        spring_energy=spring,
    )


__all__ = ["FrictionalCollision", "LabUpdate", "Restitution", "collide", "collide_frictional", "lab_frame_update", "model_code", "pair_constants", "solve"]
