r"""Two-body soft contact: the scaled polar ODE, its DOP853 integration, the lab-frame update.

physics.md §4.1–§4.6. The relative motion of two soft spheres in their collision plane, in the
scaled overlap :math:`X = (\sigma - r)/\ell_s` and time :math:`\tilde t = t/t_s` (§4.4):

.. math::
    X'' = -\tilde F(X, X') - \frac{\Lambda\tan^2\alpha}{(1-\Lambda X)^3},\qquad
    \psi' = \frac{1}{(1-\Lambda X)^2},\qquad X(0) = 0,\ X'(0) = 1,\ \psi(0) = 0,

with :math:`\tilde F = X + cX'` (linear dashpot, :math:`c = 2\zeta_d`) or
:math:`\tilde F = \sqrt X\,(X + cX')` (viscoelastic Hertz, :math:`c = \delta`), integrated until
the force vanishes (:math:`X + cX' = 0`, §4.3). The polar angle is
:math:`\varphi = \Lambda\tan\alpha\,\psi`: integrating :math:`\psi` keeps the rotation accurate
to the relative tolerance however small :math:`\Lambda\tan\alpha` is, and writing the ODE in the
overlap keeps :math:`1 - D = \Lambda X(\tau_c)` to full relative precision.

Everything here is a plain compiled function over scalars and small arrays (no allocation:
the 13 x 3 stage buffer ``K`` comes from the caller).
"""

import math

from .contact import MODEL_HERTZ
from .dop853 import A, B, N_STAGES, WEIGHTS_FROM, error_norm, error_terms, stage_from
from .jit import jit, leaf

#: step-size control of the embedded DOP853 pair (the values of Hairer's code and scipy)
_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0
_MAX_STEP = 0.25
_MAX_STEPS = 100000


@leaf
def scaled_force(model, c, X, V):
    r"""Scaled normal force :math:`\tilde F` (physics.md §4.4 table), continued smoothly to ``X < 0``."""
    g = X + c * V
    if model == MODEL_HERTZ:
        g *= math.sqrt(X) if X > 0.0 else 0.0
    return g


@leaf
def _rhs(model, c, lam, cen, X, V):
    """Derivatives ``(X', V', psi')`` of the scaled polar ODE; ``cen = Lambda tan^2 alpha``."""
    q = 1.0 / (1.0 - lam * X)
    q2 = q * q
    return V, -scaled_force(model, c, X, V) - cen * q2 * q, q2


@leaf
def _step(model, c, lam, cen, x0, v0, p0, h, K, rtol, atol):
    """One DOP853 step of size ``h`` from ``(x0, v0, p0)`` with ``K[0]`` = derivatives there.

    Fills ``K[1:13]`` (``K[12]`` = derivatives at the new point, first-same-as-last) and returns
    the new state and the scaled error norm of Hairer's 5(3) estimator.
    """
    for s in range(1, N_STAGES):
        a = A[s, 0]
        dx = a * K[0, 0]
        dv = a * K[0, 1]
        dp = a * K[0, 2]
        for j in range(stage_from(s), s):
            a = A[s, j]
            dx += a * K[j, 0]
            dv += a * K[j, 1]
            dp += a * K[j, 2]
        K[s, 0], K[s, 1], K[s, 2] = _rhs(model, c, lam, cen, x0 + h * dx, v0 + h * dv)
    b = B[0]
    sx = b * K[0, 0]
    sv = b * K[0, 1]
    sp = b * K[0, 2]
    for j in range(WEIGHTS_FROM, N_STAGES):
        b = B[j]
        sx += b * K[j, 0]
        sv += b * K[j, 1]
        sp += b * K[j, 2]
    x1 = x0 + h * sx
    v1 = v0 + h * sv
    p1 = p0 + h * sp
    K[12, 0], K[12, 1], K[12, 2] = _rhs(model, c, lam, cen, x1, v1)
    e5 = 0.0
    e3 = 0.0
    for comp in range(3):
        y0 = x0 if comp == 0 else (v0 if comp == 1 else p0)
        y1 = x1 if comp == 0 else (v1 if comp == 1 else p1)
        a5, a3 = error_terms(K, comp, atol + rtol * max(abs(y0), abs(y1)))
        e5 += a5 * a5
        e3 += a3 * a3
    err = error_norm(e5, e3, h, 3.0)
    return x1, v1, p1, err


@jit
def solve_scaled(model, c, lam, tan_a, rtol, K):
    r"""Integrate one contact in scaled polar form (physics.md §4.3–§4.5).

    Adaptive DOP853 (Hairer's 8th-order pair with the 5(3) error estimator) at relative
    tolerance ``rtol``; the termination root of :math:`g = X + cX'` (the force vanishes,
    physics.md §2.2) is found by Newton iteration on the size of the last step, each iterate a
    full DOP853 step from the last accepted point, so the end state is as accurate as the
    steps themselves.

    Args:
        model: ``MODEL_DASHPOT`` or ``MODEL_HERTZ``.
        c: damping, :math:`2\zeta_d` (dashpot) or :math:`\delta` (Hertz), ``>= 0``.
        lam: softness :math:`\Lambda` (``>= 0``, ``< 1``).
        tan_a: :math:`\tan\alpha = v_t/v_n` (``>= 0``).
        rtol: relative tolerance (``1e-12`` gives ~1e-12 in every output).
        K: scratch ``(13, 3)`` float64 array.

    Returns:
        ``(Phi, D, tau_c, eps_hat, X_c, psi_c)``: rotation of the inter-centre vector (rad),
        distance ratio :math:`D = 1 - \Lambda X_c`, scaled duration,
        :math:`\hat\varepsilon = -X'(\tau_c)`, the scaled residual overlap :math:`X_c` (so
        ``1 - D`` is available without cancellation) and :math:`\psi_c = \Phi/(\Lambda\tan\alpha)`
        (finite for central collisions). NaNs if the integration fails.
    """
    cen = lam * tan_a * tan_a
    atol = 1e-3 * rtol
    t = 0.0
    x, v, p = 0.0, 1.0, 0.0
    K[0, 0], K[0, 1], K[0, 2] = _rhs(model, c, lam, cen, x, v)
    g = c  # X + c X' at t = 0
    h = 0.05 * rtol ** 0.125 if model == MODEL_HERTZ else 0.1 * rtol ** 0.125
    for _ in range(_MAX_STEPS):
        h = min(h, _MAX_STEP)
        x1, v1, p1, err = _step(model, c, lam, cen, x, v, p, h, K, rtol, atol)
        if err > 1.0:
            h *= max(_MIN_FACTOR, _SAFETY * err ** -0.125)
            continue
        g1 = x1 + c * v1
        # g starts at c > 0; elastic (c = 0): at 0 with g' = 1 > 0, so g1 <= 0 after the first step
        # means the whole (grazing) contact fits in it
        if g1 <= 0.0 and (g > 0.0 or t > 0.0 or c == 0.0):
            return _terminate(model, c, lam, tan_a, cen, t, x, v, p, g, h, g1, K, rtol, atol)
        t += h
        x, v, p, g = x1, v1, p1, g1
        K[0, 0], K[0, 1], K[0, 2] = K[12, 0], K[12, 1], K[12, 2]
        h *= _MAX_FACTOR if err == 0.0 else min(_MAX_FACTOR, _SAFETY * err ** -0.125)
    nan = math.nan
    return nan, nan, nan, nan, nan, nan


@leaf
def _terminate(model, c, lam, tan_a, cen, t, x, v, p, g0, h, g1, K, rtol, atol):
    """Root of ``g = X + cX'`` inside the step ``[t, t + h]`` (``g(t) = g0 >= 0 >= g1``).

    Newton on the step size ``s``, safeguarded by the bracket ``[lo, hi]``; each iterate is a
    full DOP853 step from ``t`` and ``g'(s) = X' + cX''`` comes from its first-same-as-last
    derivative. Once the Newton correction is below ``1e-9`` of the elapsed time the end state is
    moved onto the root by a second-order Taylor step (relative error ~1e-18).
    """
    lo, hi = 0.0, h
    s = h * g0 / (g0 - g1)
    x1, v1, p1 = x, v, p
    for _ in range(100):
        if not (lo < s < hi):
            s = 0.5 * (lo + hi)
        x1, v1, p1, _err = _step(model, c, lam, cen, x, v, p, s, K, rtol, atol)
        gs = x1 + c * v1
        if gs > 0.0:
            lo = s
        else:
            hi = s
        dx, dv, dp = K[12, 0], K[12, 1], K[12, 2]
        dg = dx + c * dv
        step = -gs / dg if dg < 0.0 else 0.5 * (lo + hi) - s
        if abs(step) <= 1e-9 * (t + s) or hi - lo <= 1e-15 * (t + s):
            if dg < 0.0:
                x1 += (dx + 0.5 * dv * step) * step
                v1 += dv * step
                p1 += dp * step
                s += step
            break
        s += step
    return lam * tan_a * p1, 1.0 - lam * x1, t + s, -v1, x1, p1


@jit
def dashpot_central(zeta):
    r"""Central linear-dashpot collision in closed form (physics.md §2.2.1).

    Returns ``(omega0 t_c, e_n, X_c0)`` for damping ratio :math:`\zeta_d \ge 0`, with
    :math:`X_{c0} = \xi_c\omega_0/v_n = 2\zeta_d e_n` (all regimes; the overdamped branch is the
    analytic continuation of the underdamped one).
    """
    if zeta == 0.0:
        return math.pi, 1.0, 0.0
    if zeta < 1.0:
        wd = math.sqrt((1.0 - zeta) * (1.0 + zeta))
        tau = 2.0 * math.atan2(wd, zeta) / wd
    elif zeta == 1.0:
        tau = 2.0
    else:
        om = math.sqrt((zeta - 1.0) * (zeta + 1.0))
        tau = math.log((zeta + om) / (zeta - om)) / om
    e = math.exp(-zeta * tau)
    return tau, e, 2.0 * zeta * e


@leaf
def collision_frame(r1, r2, v1, v2):
    r"""The collision frame of two touching spheres (physics.md §4.2) and the impact speeds.

    :math:`\hat{\mathbf e}_x = (\mathbf r_1 - \mathbf r_2)/r`, :math:`\hat{\mathbf e}_y` along the
    tangential relative velocity (for a central collision any unit vector perpendicular to
    :math:`\hat{\mathbf e}_x`, in the plane ``z = 0`` when :math:`\hat{\mathbf e}_x` is).
    Returns ``(ex, ey, ez, fx, fy, fz, v_n, v_t)``: :math:`\hat{\mathbf e}_x`, :math:`\hat{\mathbf e}_y`
    and :math:`v_n = -\mathbf g\cdot\hat{\mathbf e}_x`, :math:`v_t = |\mathbf g_t|` (0 if central).
    """
    rx, ry, rz = r1[0] - r2[0], r1[1] - r2[1], r1[2] - r2[2]
    gx, gy, gz = v1[0] - v2[0], v1[1] - v2[1], v1[2] - v2[2]
    inv = 1.0 / math.sqrt(rx * rx + ry * ry + rz * rz)
    ex, ey, ez = rx * inv, ry * inv, rz * inv
    gn = gx * ex + gy * ey + gz * ez
    tx, ty, tz = gx - gn * ex, gy - gn * ey, gz - gn * ez
    vt = math.sqrt(tx * tx + ty * ty + tz * tz)
    if vt > 1e-14 * abs(gn):
        return ex, ey, ez, tx / vt, ty / vt, tz / vt, -gn, vt
    if abs(ez) < 0.9:  # central
        nrm = 1.0 / math.sqrt(ex * ex + ey * ey)
        return ex, ey, ez, -ey * nrm, ex * nrm, 0.0, -gn, 0.0
    nrm = 1.0 / math.sqrt(ex * ex + ez * ez)
    return ex, ey, ez, ez * nrm, 0.0, -ex * nrm, -gn, 0.0


@leaf
def lab_frame_update(r1, r2, v1, v2, m1, m2, sigma, Phi, D, eps_hat, out):
    r"""eMD* relocation and post-collisional velocities in the lab frame (physics.md §4.6).

    For two spheres touching at :math:`t_0` (``|r1 - r2| = sigma``, ``r2`` the image closest to
    ``r1``; 2D: ``z = 0`` components, which stay exactly zero) and the matrix of restitution
    :math:`(\Phi, D, \hat\varepsilon)`:

    .. math::
        \hat{\mathbf n}' = \cos\Phi\,\hat{\mathbf e}_x + \sin\Phi\,\hat{\mathbf e}_y,\quad
        \mathbf r_{1,2}^A = \mathbf R \pm \tfrac{m_{2,1}}{M} D\sigma\,\hat{\mathbf n}',\quad
        \dot{\mathbf r}' = \hat\varepsilon v_n\hat{\mathbf n}' + \frac{v_t}{D}\hat{\mathbf t}',\quad
        \boldsymbol\Delta_1 = \tfrac{m_2}{M}\dot{\mathbf r}',\ \boldsymbol\Delta_2 = -\tfrac{m_1}{M}\dot{\mathbf r}'

    with :math:`\hat{\mathbf t}' = -\sin\Phi\,\hat{\mathbf e}_x + \cos\Phi\,\hat{\mathbf e}_y` and the
    collision frame of §4.2 (:math:`\hat{\mathbf e}_x = \mathbf r/\sigma`, :math:`\hat{\mathbf e}_y` along the
    tangential relative velocity; any perpendicular for a central collision). The velocities
    after the contact are :math:`\mathbf V + \boldsymbol\Delta_{1,2}` (plus :math:`\mathbf G t_c` with gravity).

    Args:
        r1, r2, v1, v2: length-3 positions and velocities at first contact.
        m1, m2: masses; sigma: contact distance ``R1 + R2``.
        Phi, D, eps_hat: matrix of restitution (from :func:`solve_scaled` or a table).
        out: ``(5, 3)`` array, filled with ``r1A, r2A, V, Delta1, Delta2``.

    Returns:
        ``(v_n, v_t)``, the normal and tangential impact speeds.
    """
    M = m1 + m2
    w1 = m1 / M
    w2 = m2 / M
    ex, ey, ez, fx, fy, fz, vn, vt = collision_frame(r1, r2, v1, v2)
    cp, sp = math.cos(Phi), math.sin(Phi)
    nx, ny, nz = cp * ex + sp * fx, cp * ey + sp * fy, cp * ez + sp * fz
    ux, uy, uz = -sp * ex + cp * fx, -sp * ey + cp * fy, -sp * ez + cp * fz
    Rx = w1 * r1[0] + w2 * r2[0]
    Ry = w1 * r1[1] + w2 * r2[1]
    Rz = w1 * r1[2] + w2 * r2[2]
    ds = D * sigma
    out[0, 0], out[0, 1], out[0, 2] = Rx + w2 * ds * nx, Ry + w2 * ds * ny, Rz + w2 * ds * nz
    out[1, 0], out[1, 1], out[1, 2] = Rx - w1 * ds * nx, Ry - w1 * ds * ny, Rz - w1 * ds * nz
    out[2, 0] = w1 * v1[0] + w2 * v2[0]
    out[2, 1] = w1 * v1[1] + w2 * v2[1]
    out[2, 2] = w1 * v1[2] + w2 * v2[2]
    a = eps_hat * vn
    b = vt / D
    qx, qy, qz = a * nx + b * ux, a * ny + b * uy, a * nz + b * uz
    out[3, 0], out[3, 1], out[3, 2] = w2 * qx, w2 * qy, w2 * qz
    out[4, 0], out[4, 1], out[4, 2] = -w1 * qx, -w1 * qy, -w1 * qz
    return vn, vt
