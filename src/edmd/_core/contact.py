r"""Soft normal contact laws in compiled form: forces, energies and scales (physics.md §2.2, §4.4, §4.7).

A contact model travels into compiled code as an integer code and two floats ``(a, b)``:

* ``MODEL_DASHPOT``: ``a = k``, ``b = gamma``; :math:`F = k\xi + \gamma\dot\xi`.
* ``MODEL_HERTZ``: ``a = 2Y/(3(1-\nu^2))``, ``b = 3A/2``;
  :math:`F = \rho\sqrt\xi\,(\xi + \tfrac32A\dot\xi)` with :math:`\rho = a\sqrt{R_{\rm eff}}`.

Pair quantities follow from the masses and radii of the two particles (polydisperse pairs):
:math:`\mu = m_1m_2/(m_1+m_2)`, :math:`R_{\rm eff} = R_1R_2/(R_1+R_2)`, :math:`\sigma = R_1+R_2`.
"""

import math

from .jit import leaf

MODEL_DASHPOT = 0
MODEL_HERTZ = 1


@leaf
def contact_force(model, a, b, reff, xi, xi_dot):
    r"""Normal force and elastic energy of a contact with overlap ``xi > 0`` (physics.md §2.2).

    Returns ``(F, F_el, U_el)``: the total repulsive force clipped at zero (the contact has
    ended once the force would turn attractive, physics.md §2.2), its elastic part
    (:math:`k\xi`, :math:`\rho\xi^{3/2}`) and the elastic energy (:math:`\tfrac12k\xi^2`,
    :math:`\tfrac25\rho\xi^{5/2}`).
    """
    if model == MODEL_HERTZ:
        rho = a * math.sqrt(reff)
        sq = math.sqrt(xi)
        f_el = rho * sq * xi
        f = f_el + rho * sq * b * xi_dot
        return (f if f > 0.0 else 0.0), f_el, 0.4 * f_el * xi
    f_el = a * xi
    f = f_el + b * xi_dot
    return (f if f > 0.0 else 0.0), f_el, 0.5 * f_el * xi


@leaf
def contact_scales(model, a, b, mu, reff, sigma, vn):
    r"""Scales of a contact with normal impact speed ``vn`` (physics.md §4.4).

    Returns ``(c, lam, t_s, l_s)``: the solver's damping :math:`c` (:math:`2\zeta_d` or
    :math:`\delta`), the softness :math:`\Lambda = \ell_s/\sigma` and the time and length scales.

    .. math::
        \text{dashpot: } \omega_0 = \sqrt{k/\mu},\ \zeta_d = \frac{\gamma}{2\sqrt{k\mu}},\ t_s = \frac1{\omega_0},\ \ell_s = \frac{v_n}{\omega_0};\qquad
        \text{Hertz: } \kappa = \frac{\rho}{\mu},\ \ell_s = \Big(\frac{v_n^2}{\kappa}\Big)^{2/5},\ t_s = \frac{\ell_s}{v_n},\ \delta = \tfrac32A\kappa^{2/5}v_n^{1/5}
    """
    if model == MODEL_HERTZ:
        kappa = a * math.sqrt(reff) / mu
        ls = (vn * vn / kappa) ** 0.4
        ts = ls / vn
        return b / ts, ls / sigma, ts, ls
    w0 = math.sqrt(a / mu)
    return b / (mu * w0), vn / (w0 * sigma), 1.0 / w0, vn / w0


@leaf
def table_coordinates(model, a, b, mu, reff, sigma, v):
    r"""Velocity-dependent table coordinates ``(u1, lam_v)`` of an impact with total speed ``v`` (physics.md §4.7).

    Dashpot: :math:`u_1 = \zeta_d`, :math:`\Lambda_v = v/(\omega_0\sigma)`; Hertz:
    :math:`u_1 = \delta_v = \tfrac32A\kappa^{2/5}v^{1/5}`, :math:`\Lambda_v = (v^2/\kappa)^{2/5}/\sigma`.
    The third coordinate is the eccentricity :math:`b = v_t/v`.
    """
    c, lam, _ts, _ls = contact_scales(model, a, b, mu, reff, sigma, v)
    if model == MODEL_HERTZ:
        return c, lam
    return 0.5 * c, lam


@leaf
def normal_damping(model, a, b, reff, xi):
    r"""Normal damping coefficient :math:`\eta_n = \partial F/\partial\dot\xi` at overlap ``xi``: :math:`\gamma` or :math:`\tfrac32A\rho\sqrt\xi`."""
    if model == MODEL_HERTZ:
        return a * math.sqrt(reff * xi) * b
    return b


@leaf
def tangential_force(law, kt, xt, mu, eta_n, fn, reff, xi, zx, zy, zz, ux, uy, uz):
    r"""Cundall–Strack tangential force of spring extension ``z`` and sliding velocity ``u`` (docs/physics.md §2.6).

    .. math::
        \mathbf F^* = -k_t\boldsymbol\zeta - x_t\eta_n\mathbf u,\qquad
        \mathbf F_t = \mathbf F^*\min\Big(1, \frac{\mu F_n}{|\mathbf F^*|}\Big)

    with :math:`k_t` constant (``law`` 1) or :math:`k_t\sqrt{R_{\rm eff}\xi}` (``law`` 2, Mindlin).
    Returns ``(Fx, Fy, Fz, k, slides)``: the force, the spring stiffness in use and whether the
    Coulomb limit cut the force (then the caller resets the spring to
    :math:`-(\mathbf F_t + x_t\eta_n\mathbf u)/k`).
    """
    k = kt if law == 1 else kt * math.sqrt(reff * xi)
    eta = xt * eta_n
    fx = -k * zx - eta * ux
    fy = -k * zy - eta * uy
    fz = -k * zz - eta * uz
    f2 = fx * fx + fy * fy + fz * fz
    lim = mu * fn if fn > 0.0 else 0.0
    if f2 > lim * lim:
        s = lim / math.sqrt(f2)
        return fx * s, fy * s, fz * s, k, True
    return fx, fy, fz, k, False
