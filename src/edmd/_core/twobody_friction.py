r"""Two-body frictional soft contact: the scaled Cartesian ODE with stick and slip, its DOP853 integration.

docs/physics.md §4.11. Two spheres touch at :math:`\tau = 0` with the inter-centre vector
:math:`\sigma\hat{\mathbf e}_x`; in the scales of the smooth solver (:math:`\ell_s`,
:math:`t_s`, :math:`\ell_s/t_s = v_n`, :math:`\Lambda = \ell_s/\sigma`, §4.4) the state is

* :math:`\mathbf y`: the relative position :math:`\mathbf r = \sigma(\hat{\mathbf e}_x + \Lambda\mathbf y)`,
* :math:`\mathbf p = \dot{\mathbf r}/v_n` (``p = (-1, tan(alpha), 0)`` at the start),
* :math:`\mathbf u_i = R_i\boldsymbol\omega_i/v_n`, the rim speeds of the two spins,
* the tangential spring :math:`\mathbf z = \boldsymbol\zeta/\ell_s` while the contact sticks, or the
  scaled tangential force :math:`\mathbf S = \tilde{\mathbf F}_t` while it slides.

With :math:`\rho = |\hat{\mathbf e}_x + \Lambda\mathbf y|`, :math:`\hat{\mathbf n} = (\hat{\mathbf e}_x + \Lambda\mathbf y)/\rho`, the overlap
:math:`X = (1-\rho)/\Lambda = -(2y_x + \Lambda|\mathbf y|^2)/(1+\rho)` (no cancellation),
:math:`X' = -\mathbf p\cdot\hat{\mathbf n}`, the lever factors :math:`f_i = 1 - \lambda_i\Lambda X`
(:math:`\lambda_i = \sigma/2R_i`: arms :math:`R_i - \xi/2`) and the sliding velocity
:math:`\tilde{\mathbf v}_t` (tangential part of :math:`\mathbf p - (f_1\mathbf u_1 + f_2\mathbf u_2)\times\hat{\mathbf n}`):

.. math::
    \mathbf y' = \mathbf p,\quad \mathbf p' = \tilde F_n\hat{\mathbf n} + \tilde{\mathbf F}_t,\quad
    \mathbf u_i' = -\kappa_if_i\,\hat{\mathbf n}\times\tilde{\mathbf F}_t,\quad
    \hat{\mathbf n}' = \frac\Lambda\rho\big(\mathbf p - (\mathbf p\cdot\hat{\mathbf n})\hat{\mathbf n}\big)

(:math:`\kappa_i = \mu R_i^2/I_i`). Sticking: :math:`\tilde{\mathbf F}_t = -\tilde k\mathbf z - \tilde\eta\tilde{\mathbf v}_t`,
:math:`\mathbf z' = \tilde{\mathbf v}_t - (\hat{\mathbf n}'\cdot\mathbf z)\hat{\mathbf n}`, until
:math:`|\tilde{\mathbf F}_t| = \mu\tilde F_n`. Sliding: :math:`\tilde{\mathbf F}_t = \mu\tilde F_n\hat{\mathbf s}`,
:math:`\hat{\mathbf s} = \mathbf S/|\mathbf S|`, with the spring held at the Coulomb limit,
:math:`\mathbf z = -(\tilde{\mathbf F}_t + \tilde\eta\tilde{\mathbf v}_t)/\tilde k`, so the force the spring
would reach, :math:`\mathbf F^* = -\tilde k\mathbf z - \tilde\eta\tilde{\mathbf v}_t`, changes at
:math:`\mathbf Q = \tfrac{d}{d\tau}\mathbf F^*` (with :math:`\mathbf z'` of sticking) and

.. math::
    \mathbf S' = \mu\tilde F_n'\hat{\mathbf s} + \mathbf Q_\perp - (\hat{\mathbf n}'\cdot\mathbf S)\hat{\mathbf n},

:math:`\mathbf Q_\perp` the part of :math:`\mathbf Q` normal to :math:`\hat{\mathbf s}` and :math:`\hat{\mathbf n}`, while
:math:`\hat{\mathbf s}\cdot\mathbf Q > \mu\tilde F_n'` (the spring would outgrow the limit). This is the
continuous-time limit of the DEM's spring update (:mod:`edmd._core.dem`, LAMMPS ``pair granular``).
:math:`\tilde k = \tilde k_t` (linear) or :math:`\tilde k_t\sqrt X` (Mindlin), :math:`\tilde\eta = x_t\,\partial\tilde F_n/\partial X'`.
The contact ends when :math:`\tilde F_n = 0` (:math:`X + cX' = 0`, §4.3).

Everything is a plain compiled function over scalars and caller-provided scratch arrays.
"""

import math

from .contact import MODEL_HERTZ, contact_scales
from .dop853 import A, B, N_STAGES, WEIGHTS_FROM, error_norm, error_terms, stage_from
from .jit import jit, leaf
from .twobody import collision_frame

#: the packed parameters ``prm`` (float64 array)
P_MODEL, P_C, P_LAM, P_LAW, P_KT, P_XT, P_MU, P_KAPPA1, P_KAPPA2, P_LAMBDA1, P_LAMBDA2 = range(11)
#: the state: y, p, u1, u2 and z (sticking) or S (sliding)
Y, P, U1, U2, Z = 0, 3, 6, 9, 12
N_STATE = 15
STICK, SLIDE, FROZEN = 0, 1, 2
#: what solve_frictional returns in ``info``: duration, switches, final mode, steps
I_TAU, I_SWITCHES, I_MODE, I_STEPS = range(4)
#: the scratch of :func:`frictional_update` ``(SCRATCH_ROWS, N_STATE)``: rows 0-12 the stages ``K``,
#: 13-15 ``W``, 16 the state, 17 the parameters (``prm``, 11 numbers) followed by ``info`` (4)
SCRATCH_ROWS = 18
ROW_STATE, ROW_PRM, INFO_AT = 16, 17, 11

_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0
_MAX_STEP = 0.25
_MAX_STEPS = 200000
_MAX_SWITCHES = 10000
#: :func:`_root`'s first bracket: this many step sizes either side of the interpolant's root
_ROOT_BRACKET = 1e-5
#: :func:`_root` stops when its bracket is this many times ``rtol`` wide (relative): the state at
#: the root then errs by far less than a step's tolerance (closing the bracket to round-off took
#: half the steps of a contact, most of them halvings near the root)
_ROOT_TOL = 1e-3
#: a switching function this far below zero at the start of a step means the mode has ended there
_SWITCH_TOL = 1e-9
#: a contact at the margin (the trial force tracks the Coulomb limit: both modes give the limit
#: force, and rounding flips between them at one instant) slides until its switching function
#: falls this far below zero
_MARGIN = 1e-6


@leaf
def cross(ax, ay, az, bx, by, bz):
    r""":math:`\mathbf a\times\mathbf b` of two vectors given by their components."""
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@leaf
def scaled_spring(law, kt, mu, reff, ts, ls):
    r"""The scaled tangential spring of a pair (physics.md §4.11): :math:`\tilde k = k_tt_s^2/\mu` (linear) or
    :math:`k_{t0}\sqrt{R_{\rm eff}\ell_s}\,t_s^2/\mu` (Mindlin, ``law`` 2; times :math:`\sqrt X` in the equations)."""
    return kt * ts * ts / mu * (math.sqrt(reff * ls) if law == 2 else 1.0)


@leaf
def _normal_law(model, c, X, V):
    r"""Scaled normal force :math:`\tilde F_n` and its damping coefficient :math:`\partial\tilde F_n/\partial X'` (not clipped)."""
    if model == MODEL_HERTZ:
        q = math.sqrt(X) if X > 0.0 else 0.0
        return q * (X + c * V), q * c
    return X + c * V, c


@leaf
def _normal_rate(model, c, X, V, A_):
    r""":math:`d\tilde F_n/d\tau` for :math:`X' = V`, :math:`X'' = A_`."""
    if model == MODEL_HERTZ:
        q = math.sqrt(X) if X > 0.0 else 0.0
        dq = 0.5 * V / q if q > 0.0 else 0.0
        return dq * (X + c * V) + q * (V + c * A_)
    return V + c * A_


@leaf
def _spring(law, kt, X, V):
    r"""Scaled spring stiffness :math:`\tilde k` and its rate over itself :math:`\tilde k'/\tilde k`."""
    if law == 2:
        q = math.sqrt(X) if X > 0.0 else 0.0
        return kt * q, (0.5 * V / X if X > 0.0 else 0.0)
    return kt, 0.0


@leaf
def _kinematics(prm, s):
    """Geometry, normal force and sliding velocity of state ``s``: ``(n, rho, X, X', F_n, eta_t,
    f1, f2, W, v_c, v_c.n, v_t, k, k'/k)`` (vectors as three numbers)."""
    lam = prm[P_LAM]
    yx, yy, yz = s[Y], s[Y + 1], s[Y + 2]
    ax, ay, az = 1.0 + lam * yx, lam * yy, lam * yz
    rho = math.sqrt(ax * ax + ay * ay + az * az)
    nx, ny, nz = ax / rho, ay / rho, az / rho
    X = -(2.0 * yx + lam * (yx * yx + yy * yy + yz * yz)) / (1.0 + rho)
    V = -(s[P] * nx + s[P + 1] * ny + s[P + 2] * nz)
    fn, eta_n = _normal_law(int(prm[P_MODEL]), prm[P_C], X, V)
    # lever factors and the rim speed of the pair W = f1 u1 + f2 u2
    f1 = 1.0 - prm[P_LAMBDA1] * lam * X
    f2 = 1.0 - prm[P_LAMBDA2] * lam * X
    wx = f1 * s[U1] + f2 * s[U2]
    wy = f1 * s[U1 + 1] + f2 * s[U2 + 1]
    wz = f1 * s[U1 + 2] + f2 * s[U2 + 2]
    cx, cy, cz = cross(wx, wy, wz, nx, ny, nz)
    vcx, vcy, vcz = s[P] - cx, s[P + 1] - cy, s[P + 2] - cz
    vcn = vcx * nx + vcy * ny + vcz * nz
    kk, krate = _spring(int(prm[P_LAW]), prm[P_KT], X, V)
    return (nx, ny, nz, rho, X, V, fn, prm[P_XT] * eta_n, f1, f2, wx, wy, wz, vcx, vcy, vcz, vcn,
            vcx - vcn * nx, vcy - vcn * ny, vcz - vcn * nz, kk, krate)  # fmt: skip


@jit
def rhs(prm, mode, s, ds):
    """Derivatives of the state ``s`` (mode ``STICK``, ``SLIDE`` or ``FROZEN``: sliding with the direction held) into ``ds``.

    Returns ``(g_end, g_switch)``: :math:`X + cX'` (the contact ends at its root) and the
    switching function, positive while the mode holds, scaled into ``[-1, 1]`` (sticking:
    :math:`(\\mu\\tilde F_n - |\\mathbf F^*|)/(\\mu\\tilde F_n + |\\mathbf F^*|)`; sliding:
    :math:`(\\hat{\\mathbf s}\\cdot\\mathbf Q - \\mu\\tilde F_n')/(|\\hat{\\mathbf s}\\cdot\\mathbf Q| + \\mu|\\tilde F_n'|)`).
    """
    model = int(prm[P_MODEL])
    c, lam, mu = prm[P_C], prm[P_LAM], prm[P_MU]
    px, py, pz = s[P], s[P + 1], s[P + 2]
    nx, ny, nz, rho, X, V, fn, eta, f1, f2, wx, wy, wz, vcx, vcy, vcz, vcn, vx, vy, vz, kk, krate = _kinematics(prm, s)
    pn = -V
    g_end = X + c * V
    # n' (scaled)
    k = lam / rho
    dnx, dny, dnz = k * (px - pn * nx), k * (py - pn * ny), k * (pz - pn * nz)
    zx, zy, zz = s[Z], s[Z + 1], s[Z + 2]
    sx, sy, sz = 0.0, 0.0, 0.0
    if mode == STICK:
        ftx, fty, ftz = -kk * zx - eta * vx, -kk * zy - eta * vy, -kk * zz - eta * vz
        ft = math.sqrt(ftx * ftx + fty * fty + ftz * ftz)
        lim = mu * fn
        g_switch = (lim - ft) / (lim + ft) if lim + ft > 0.0 and mu < math.inf else 1.0
    else:  # (frozen: z holds the force's fixed direction, kept in the tangent plane)
        zn = zx * nx + zy * ny + zz * nz if mode == FROZEN else 0.0
        zx, zy, zz = zx - zn * nx, zy - zn * ny, zz - zn * nz
        sm = math.sqrt(zx * zx + zy * zy + zz * zz)
        if sm > 0.0:
            sx, sy, sz = zx / sm, zy / sm, zz / sm
        lim = mu * fn
        ftx, fty, ftz = lim * sx, lim * sy, lim * sz
    # translational and rotational accelerations
    dpx, dpy, dpz = fn * nx + ftx, fn * ny + fty, fn * nz + ftz
    tx, ty, tz = cross(nx, ny, nz, ftx, fty, ftz)
    k1, k2 = prm[P_KAPPA1] * f1, prm[P_KAPPA2] * f2
    ds[Y], ds[Y + 1], ds[Y + 2] = px, py, pz
    ds[P], ds[P + 1], ds[P + 2] = dpx, dpy, dpz
    ds[U1], ds[U1 + 1], ds[U1 + 2] = -k1 * tx, -k1 * ty, -k1 * tz
    ds[U2], ds[U2 + 1], ds[U2 + 2] = -k2 * tx, -k2 * ty, -k2 * tz
    if mode == STICK:
        zn = dnx * zx + dny * zy + dnz * zz
        ds[Z], ds[Z + 1], ds[Z + 2] = vx - zn * nx, vy - zn * ny, vz - zn * nz
        return g_end, g_switch
    if mu == 0.0:  # smooth: no tangential force, nothing to follow
        ds[Z], ds[Z + 1], ds[Z + 2] = 0.0, 0.0, 0.0
        return g_end, 1.0
    # sliding: the rate Q of the spring's trial force, with z held at the Coulomb limit
    A_ = -(dpx * nx + dpy * ny + dpz * nz) - (px * dnx + py * dny + pz * dnz)  # X''
    dfn = _normal_rate(model, c, X, V, A_)
    deta = prm[P_XT] * (0.5 * c * V / math.sqrt(X) if model == MODEL_HERTZ and X > 0.0 else 0.0)
    # v_t' from p', u_i', f_i' and n'
    df = -lam * V
    dwx = prm[P_LAMBDA1] * df * s[U1] + f1 * ds[U1] + prm[P_LAMBDA2] * df * s[U2] + f2 * ds[U2]
    dwy = prm[P_LAMBDA1] * df * s[U1 + 1] + f1 * ds[U1 + 1] + prm[P_LAMBDA2] * df * s[U2 + 1] + f2 * ds[U2 + 1]
    dwz = prm[P_LAMBDA1] * df * s[U1 + 2] + f1 * ds[U1 + 2] + prm[P_LAMBDA2] * df * s[U2 + 2] + f2 * ds[U2 + 2]
    ax1, ay1, az1 = cross(dwx, dwy, dwz, nx, ny, nz)
    ax2, ay2, az2 = cross(wx, wy, wz, dnx, dny, dnz)
    dvcx, dvcy, dvcz = dpx - ax1 - ax2, dpy - ay1 - ay2, dpz - az1 - az2
    dvcn = dvcx * nx + dvcy * ny + dvcz * nz + vcx * dnx + vcy * dny + vcz * dnz
    dvx = dvcx - dvcn * nx - vcn * dnx
    dvy = dvcy - dvcn * ny - vcn * dny
    dvz = dvcz - dvcn * nz - vcn * dnz
    # Q = -k' z - k z' - eta' v - eta v', z = -(F_t + eta v) / k, z' = v (tangential parts)
    qx = krate * (ftx + eta * vx) - kk * vx - deta * vx - eta * dvx
    qy = krate * (fty + eta * vy) - kk * vy - deta * vy - eta * dvy
    qz = krate * (ftz + eta * vz) - kk * vz - deta * vz - eta * dvz
    qn = qx * nx + qy * ny + qz * nz
    qx, qy, qz = qx - qn * nx, qy - qn * ny, qz - qn * nz
    if sx == 0.0 and sy == 0.0 and sz == 0.0:  # S = 0 (no normal force yet): it grows along Q
        qm = math.sqrt(qx * qx + qy * qy + qz * qz)
        if qm > 0.0:
            sx, sy, sz = qx / qm, qy / qm, qz / qm
    qs = qx * sx + qy * sy + qz * sz
    dl = mu * dfn
    scale = abs(qs) + abs(dl)
    g_switch = (qs - dl) / scale if scale > 0.0 else 1.0
    if mode == FROZEN:  # the direction held (see _freeze)
        ds[Z], ds[Z + 1], ds[Z + 2] = 0.0, 0.0, 0.0
        return g_end, g_switch
    sn = dnx * zx + dny * zy + dnz * zz
    ds[Z] = dl * sx + (qx - qs * sx) - sn * nx
    ds[Z + 1] = dl * sy + (qy - qs * sy) - sn * ny
    ds[Z + 2] = dl * sz + (qz - qs * sz) - sn * nz
    return g_end, g_switch


@leaf
def _step(prm, mode, x0, h, K, xs, x1, rtol, atol):
    """One DOP853 step of size ``h`` from ``x0`` (``K[0]`` = its derivatives) into ``x1``.

    Fills ``K[1:13]`` (``K[12]`` = derivatives at ``x1``) and returns ``(err, g_end, g_switch)``
    at ``x1``: the scaled error norm of Hairer's 5(3) estimator and the two event functions.
    """
    n = x0.shape[0]
    for st in range(1, N_STAGES):
        start = stage_from(st)
        for q in range(n):
            acc = A[st, 0] * K[0, q]
            for j in range(start, st):
                acc += A[st, j] * K[j, q]
            xs[q] = x0[q] + h * acc
        rhs(prm, mode, xs, K[st])
    for q in range(n):
        acc = B[0] * K[0, q]
        for j in range(WEIGHTS_FROM, N_STAGES):
            acc += B[j] * K[j, q]
        x1[q] = x0[q] + h * acc
    g_end, g_sw = rhs(prm, mode, x1, K[12])
    e5 = 0.0
    e3 = 0.0
    for q in range(n):
        # the spring / tangential force against its own scale (O(1)): near the end of a sliding
        # contact the force shrinks with F_n while its direction turns ever faster, which moves
        # nothing else once the force is small
        floor = 1.0 if q >= Z else 0.0
        a5, a3 = error_terms(K, q, atol + rtol * max(abs(x0[q]), abs(x1[q]), floor))
        e5 += a5 * a5
        e3 += a3 * a3
    return error_norm(e5, e3, h, n), g_end, g_sw


@leaf
def _illinois(lo, hi, glo, ghi, side, s, gv):
    """One update of the Illinois-modified regula falsi bracket ``[lo, hi]`` (``g(lo) > 0 >= g(hi)``)
    by the value ``gv`` at ``s``; returns ``(lo, hi, glo, ghi, side)``."""
    if gv > 0.0:
        if side == 1:
            ghi *= 0.5
        return s, hi, gv, ghi, 1
    if side == -1:
        glo *= 0.5
    return lo, s, glo, gv, -1


@leaf
def _secant(lo, hi, glo, ghi):
    """The regula falsi point of the bracket, or its middle where that falls outside."""
    s = hi - ghi * (hi - lo) / (ghi - glo)
    return s if lo < s < hi else 0.5 * (lo + hi)


@leaf
def _event(which, shift, ge, gs):
    """The event function :func:`_root` follows: the end's (``which = 0``) or the switch's plus ``shift``."""
    return ge if which == 0 else gs + shift


@leaf
def _hermite_root(prm, mode, x0, h, g0, g1, which, shift, K, xs, x1):
    r"""Where event function ``which`` crosses zero along the cubic Hermite interpolant of the step
    (``x0``, ``K[0]``; ``x1``, ``K[12]``): each trial costs one derivative evaluation (into
    ``K[1]``) instead of a step. Its error, :math:`O(h^4)`, leaves the root within :math:`10^{-5}h`
    for about 90 % of the roots (median :math:`10^{-9}h`, 99th percentile :math:`2\times10^{-4}h`;
    measured); :func:`_root` polishes it with full steps."""
    lo, hi, glo, ghi = 0.0, 1.0, g0, g1
    side = 0
    f0, f1 = K[0], K[12]
    for _ in range(100):
        th = _secant(lo, hi, glo, ghi)
        for q in range(N_STATE):
            d = x1[q] - x0[q]
            xs[q] = x0[q] + th * d + th * (th - 1.0) * ((1.0 - 2.0 * th) * d + (th - 1.0) * h * f0[q] + th * h * f1[q])
        ge, gs = rhs(prm, mode, xs, K[1])
        lo, hi, glo, ghi, side = _illinois(lo, hi, glo, ghi, side, th, _event(which, shift, ge, gs))
        if hi - lo <= 1e-13:
            break
    return 0.5 * (lo + hi) * h


@jit
def _root(prm, mode, x0, h, g0, g1, which, shift, K, xs, x1, rtol, atol):
    """Step size in ``(0, h]`` at which event function ``which`` (0: end, 1: switch, plus ``shift``) crosses zero.

    Illinois-modified regula falsi on full DOP853 steps from ``x0`` (``g0 > 0 >= g1``), until the
    bracket is :data:`_ROOT_TOL` ``rtol`` wide (relative; absolute, that times ``h``, for a root at
    the start of the step, where the relative width never shrinks). It starts from two steps
    :data:`_ROOT_BRACKET` ``h`` either side of the root of the step's interpolant
    (:func:`_hermite_root`; when they do not bracket the root, what they tell still narrows the
    search), and once an iterate is estimated within half the tolerance of the root, the next
    steps just past it to close the bracket (regula falsi alone closes it from one side only).
    A step where the function is zero ends the search: the root to round-off (a flat function is
    zero over a range of sizes, where the secant degenerates). Returns ``(s, g_end, g_switch)`` at
    the root (the smallest size found on the far side); ``x1`` and ``K[12]`` hold the state and
    derivatives there.
    """
    lo, hi, glo, ghi = 0.0, h, g0, g1
    side = 0
    guess = _hermite_root(prm, mode, x0, h, g0, g1, which, shift, K, xs, x1)
    tol = max(4e-16, _ROOT_TOL * rtol)
    near = False
    s = h
    ge, gs = 0.0, 0.0
    for probe in range(202):
        if probe < 2:
            s = guess + (2 * probe - 1) * _ROOT_BRACKET * h
        elif near:  # just past the end that moved last
            s = lo + 0.5 * tol * hi if side == 1 else hi - 0.5 * tol * hi
        else:
            s = _secant(lo, hi, glo, ghi)
        if not (lo < s < hi):
            if probe < 2:
                continue
            s = 0.5 * (lo + hi)
        _err, ge, gs = _step(prm, mode, x0, s, K, xs, x1, rtol, atol)
        gv = _event(which, shift, ge, gs)
        lo, hi, glo, ghi, side = _illinois(lo, hi, glo, ghi, side if probe >= 2 else 0, s, gv)
        if gv == 0.0 or (probe >= 1 and (hi - lo <= tol * hi or (lo == 0.0 and hi <= tol * h))):  # (a zero: the root, to round-off)
            break
        near = probe >= 2 and not near and abs(gv) * (hi - lo) < 0.5 * tol * hi * abs(ghi - glo)
    if s != hi:
        _err, ge, gs = _step(prm, mode, x0, hi, K, xs, x1, rtol, atol)
    return hi, ge, gs


@leaf
def _switch(prm, mode, s):
    """Change the mode at a switching point: sticking -> sliding keeps the trial force as ``S``,
    sliding (or a held direction) -> sticking sets the spring to the Coulomb limit. Returns the new mode."""
    _project(prm, s)
    _n0, _n1, _n2, _r, _X, _V, fn, eta, _f1, _f2, _w0, _w1, _w2, _c0, _c1, _c2, _cn, vx, vy, vz, kk, _kr = _kinematics(prm, s)
    if mode == STICK:
        for q, v in ((0, vx), (1, vy), (2, vz)):
            s[Z + q] = -kk * s[Z + q] - eta * v
        return SLIDE
    sm = math.sqrt(s[Z] ** 2 + s[Z + 1] ** 2 + s[Z + 2] ** 2)
    lim = prm[P_MU] * fn
    for q, v in ((0, vx), (1, vy), (2, vz)):
        ft = lim * s[Z + q] / sm if sm > 0.0 else 0.0
        s[Z + q] = -(ft + eta * v) / kk if kk > 0.0 else 0.0
    return STICK


@leaf
def _start_mode(prm, s, K, xs):
    """Sticking or sliding at first contact, and the initial ``S`` when sliding.

    The trial force is compared with the Coulomb limit a moment (``1e-9``) after the start, in a
    state advanced to first order; sliding starts with :math:`\\mathbf S = \\mu\\tilde F_n(0)\\hat{\\mathbf s}`
    along that trial force, or, for Hertz (no force at the touch), in mode ``FROZEN`` with that
    direction held (see :func:`_thaw`).
    """
    if prm[P_MU] == 0.0:  # smooth: no tangential force at all
        return SLIDE
    eps = 1e-9
    for q in range(N_STATE):
        xs[q] = s[q]
    for q in range(3):
        xs[Y + q] = eps * s[P + q]
    rhs(prm, STICK, xs, K[0])  # dz/dtau at the start: the sliding velocity
    for q in range(3):
        xs[Z + q] = eps * K[0, Z + q]
    _ge, g_sw = rhs(prm, STICK, xs, K[1])
    if g_sw >= 0.0:
        return STICK
    _switch(prm, STICK, xs)  # xs[Z:] = the trial force
    fm = math.sqrt(xs[Z] ** 2 + xs[Z + 1] ** 2 + xs[Z + 2] ** 2)
    if int(prm[P_MODEL]) == MODEL_HERTZ:  # no force yet: its direction held while it is small
        for q in range(3):
            s[Z + q] = xs[Z + q] / fm
        return FROZEN
    for q in range(3):
        s[Z + q] = prm[P_MU] * prm[P_C] * xs[Z + q] / fm  # F_n = c at X = 0, X' = 1
    return SLIDE


@leaf
def _project(prm, s):
    """Remove the normal component from ``s[Z:]`` (a held direction leaves the tangent plane as the normal turns)."""
    nx, ny, nz = _kinematics(prm, s)[0:3]
    zn = s[Z] * nx + s[Z + 1] * ny + s[Z + 2] * nz
    s[Z] -= zn * nx
    s[Z + 1] -= zn * ny
    s[Z + 2] -= zn * nz


@leaf
def _freeze(s, limit):
    r"""Whether a sliding force ``s[Z:]`` is below ``limit``; if so, ``s[Z:]`` becomes its direction.

    Near the end of a sliding contact the force :math:`\mu\tilde F_n` vanishes while its
    direction turns at a rate ~ :math:`|\mathbf Q|/|\mathbf S|`: resolving that costs ever smaller
    steps (most of a contact's steps) and moves little. Kept fixed from a force :math:`f` on,
    the direction errs by :math:`O(1)` at worst over the time :math:`O(f)` the force takes to
    vanish: an impulse :math:`O(f^2)` (measured), so the caller's limit is
    :math:`\mu\,\mathrm{rtol}^{1/2}`.
    """
    m = math.sqrt(s[Z] ** 2 + s[Z + 1] ** 2 + s[Z + 2] ** 2)
    if not 0.0 < m < limit:
        return False
    for q in range(Z, N_STATE):
        s[q] /= m
    return True


@leaf
def _thaw(prm, s, limit):
    r"""Whether the sliding force of a contact that started sliding (Hertz: no force at the touch,
    its direction held) has reached ``limit``; if so, ``s[Z:]`` becomes the force.

    Held from the touch for the time :math:`T \sim (f/\mu)^{2/3}` the force :math:`f` takes to
    grow (:math:`\tilde F_n \sim \tau^{3/2}`), the direction errs by :math:`O(T)`: an impulse
    :math:`\sim f^{7/3}\mu^{-4/3}`, so the caller's limit is :math:`\mu\,\mathrm{rtol}^{3/7}`.
    """
    fn = _kinematics(prm, s)[6]
    f = prm[P_MU] * fn
    if f < limit:
        return False
    _project(prm, s)
    m = math.sqrt(s[Z] ** 2 + s[Z + 1] ** 2 + s[Z + 2] ** 2)
    for q in range(Z, N_STATE):
        s[q] *= f / m
    return True


@leaf
def _switch_at(prm, mode, s, t, t_switch, repeats):
    """Switch the mode at ``t``; returns ``(mode, repeats, margin)``. Switches that keep coming at
    one instant mark a contact at the margin of sliding: it then slides, with :data:`_MARGIN`."""
    repeats = repeats + 1 if t <= t_switch + 1e-14 * (1.0 + t) else 0
    mode = _switch(prm, mode, s)
    if repeats >= 2:
        if mode == STICK:
            mode = _switch(prm, mode, s)
        return mode, repeats, _MARGIN
    return mode, repeats, 0.0


@jit
def solve_frictional(prm, s, rtol, K, W, info):
    """Integrate one frictional contact from first touch (``s``: the initial state, ``z = 0``) to its end.

    Adaptive DOP853 at relative tolerance ``rtol``; the end (:math:`\\tilde F_n = 0`) and every
    stick/slip switch are located by regula falsi on full steps, to :data:`_ROOT_TOL` ``rtol``
    (docs/physics.md §4.11, "Roots"). ``s`` is overwritten with the final state (sliding:
    ``s[Z:]`` the scaled tangential force). ``K``: ``(13, 15)`` scratch, ``W``: ``(3, 15)``
    scratch. ``info`` receives the scaled duration, the number of switches, the final mode and
    the number of steps. Returns ``False``
    if the integration failed (too many steps or switches).
    """
    atol = 1e-3 * rtol
    xs, x1, x0 = W[0], W[1], W[2]
    mode = _start_mode(prm, s, K, xs)
    t = 0.0
    switches = 0
    t_switch = -1.0  # time of the last switch, and how many came at that very time
    repeats = 0
    margin = 0.0  # how far below zero the switching function may go (nonzero at a margin)
    freeze = prm[P_MU] * math.sqrt(rtol)  # a sliding force this small keeps its direction to the end
    thaw = prm[P_MU] * rtol ** (3.0 / 7.0)  # a Hertz contact sliding from the start: its direction held until the force is this large
    fmax = 0.0  # the largest X + cX' so far (the force decreases once below it)
    g_end, g_sw = rhs(prm, mode, s, K[0])
    h = 0.05 * rtol**0.125 if int(prm[P_MODEL]) == MODEL_HERTZ else 0.1 * rtol**0.125
    c = prm[P_C]
    for step in range(_MAX_STEPS):
        if g_sw < -max(_SWITCH_TOL, margin):  # the mode does not hold from here on (e.g. a slide that sticks at once)
            mode, repeats, margin = _switch_at(prm, mode, s, t, t_switch, repeats)
            t_switch = t
            switches += 1
            if switches > _MAX_SWITCHES:
                return False
            g_end, g_sw = rhs(prm, mode, s, K[0])
        h = min(h, _MAX_STEP)
        for q in range(N_STATE):
            x0[q] = s[q]
        err, ge1, gs1 = _step(prm, mode, x0, h, K, xs, x1, rtol, atol)
        if not err <= 1.0:  # (NaN too)
            h *= max(_MIN_FACTOR, _SAFETY * err**-0.125) if err == err else _MIN_FACTOR
            if h < 1e-14 * (1.0 + t):  # the step size has collapsed: the contact cannot be resolved
                return False
            continue
        h_next = h * (_MAX_FACTOR if err == 0.0 else min(_MAX_FACTOR, _SAFETY * err**-0.125))
        ends = ge1 <= 0.0 and (g_end > 0.0 or t > 0.0 or c == 0.0)
        flips = gs1 < -margin
        if ends:  # where does the force vanish, and does the mode hold until then?
            h, ge1, gs1 = _root(prm, mode, x0, h, max(g_end, 1e-300), ge1, 0, 0.0, K, xs, x1, rtol, atol)
            flips = gs1 < -margin
            if not flips:
                for q in range(N_STATE):
                    s[q] = x1[q]
                if mode == FROZEN:  # the force, zero at the end, along its direction
                    mode = SLIDE
                    for q in range(Z, N_STATE):
                        s[q] = 0.0
                info[I_TAU], info[I_SWITCHES], info[I_MODE], info[I_STEPS] = t + h, switches, mode, step + 1
                return True
        if flips:  # the switch, then the other mode from there
            h, ge1, gs1 = _root(prm, mode, x0, h, max(g_sw + margin, 1e-300), gs1 + margin, 1, margin, K, xs, x1, rtol, atol)
        t += h
        for q in range(N_STATE):
            s[q] = x1[q]
        if flips:
            mode, repeats, margin = _switch_at(prm, mode, s, t, t_switch, repeats)
            t_switch = t
            switches += 1
            if switches > _MAX_SWITCHES:
                return False
            g_end, g_sw = rhs(prm, mode, s, K[0])
        else:
            if gs1 >= 0.0:
                margin = 0.0
            g_end, g_sw = ge1, gs1
            for q in range(N_STATE):
                K[0, q] = K[12, q]
            if mode == SLIDE and g_end < fmax and _freeze(s, freeze):
                mode = FROZEN
                g_end, g_sw = rhs(prm, mode, s, K[0])
            elif mode == FROZEN and g_end >= fmax and _thaw(prm, s, thaw):
                mode = SLIDE
                g_end, g_sw = rhs(prm, mode, s, K[0])
        fmax = max(fmax, g_end)
        h = h_next
    return False


@leaf
def _to_frame(ex, ey, ez, fx, fy, fz, hx, hy, hz, v, scale, s, at):
    """Components of the lab vector ``v`` along the frame's axes, times ``scale``, into ``s[at:at+3]``."""
    s[at] = scale * (v[0] * ex + v[1] * ey + v[2] * ez)
    s[at + 1] = scale * (v[0] * fx + v[1] * fy + v[2] * fz)
    s[at + 2] = scale * (v[0] * hx + v[1] * hy + v[2] * hz)


@leaf
def _to_lab(ex, ey, ez, fx, fy, fz, hx, hy, hz, a, b, c):
    return a * ex + b * fx + c * hx, a * ey + b * fy + c * hy, a * ez + b * fz + c * hz


@jit
def frictional_update(model, ca, cb, law, kt, xt, muf, m1, m2, R1, R2, I1, I2, r1, r2, v1, v2, w1, w2, rtol, F, out):
    r"""The frictional contact of two spheres touching now, as eMD* needs it (docs/physics.md §4.8, §4.11).

    ``model, ca, cb``: the normal law (:mod:`.contact`); ``law, kt, xt, muf``: the tangential law
    (:mod:`edmd.physics.friction`: code, :math:`k_t` or :math:`k_{t0}`, :math:`x_t`, :math:`\mu`);
    ``r1, r2, v1, v2, w1, w2``: positions (``|r1 - r2| = R1 + R2``), velocities and spins (3
    numbers each; 2D: planar, spins along z). Solves the contact in its collision frame
    (:func:`.twobody.collision_frame`, :func:`solve_frictional`) and fills ``out (7, 3)`` with
    the eMD* A event's relocated positions :math:`\mathbf r_{1,2}^A = \mathbf R \pm \tfrac{m_{2,1}}{M}\mathbf r(t_c)`,
    the centre-of-mass velocity :math:`\mathbf V`, the increments :math:`\boldsymbol\Delta_{1,2} = \pm\tfrac{m_{2,1}}{M}\dot{\mathbf r}(t_c)`
    and the spins at the end. Returns the contact duration :math:`t_c` (NaN if the integration
    failed). ``F``: scratch ``(SCRATCH_ROWS, N_STATE)``; afterwards ``F[ROW_STATE]`` holds the final
    scaled state and ``F[ROW_PRM, INFO_AT:]`` the solver's ``info``.
    """
    ex, ey, ez, fx, fy, fz, vn, _vt = collision_frame(r1, r2, v1, v2)
    hx, hy, hz = cross(ex, ey, ez, fx, fy, fz)
    M = m1 + m2
    mu = m1 * m2 / M
    sigma = R1 + R2
    reff = R1 * R2 / sigma
    c, lam, ts, ls = contact_scales(model, ca, cb, mu, reff, sigma, vn)
    prm, s, info = F[ROW_PRM, :INFO_AT], F[ROW_STATE], F[ROW_PRM, INFO_AT : INFO_AT + 4]
    prm[P_MODEL], prm[P_C], prm[P_LAM], prm[P_LAW] = model, c, lam, law
    prm[P_KT] = scaled_spring(law, kt, mu, reff, ts, ls)
    prm[P_XT], prm[P_MU] = xt, muf
    prm[P_KAPPA1], prm[P_KAPPA2] = mu * R1 * R1 / I1, mu * R2 * R2 / I2
    prm[P_LAMBDA1], prm[P_LAMBDA2] = sigma / (2.0 * R1), sigma / (2.0 * R2)
    for q in range(N_STATE):
        s[q] = 0.0
    g = (v1[0] - v2[0], v1[1] - v2[1], v1[2] - v2[2])
    _to_frame(ex, ey, ez, fx, fy, fz, hx, hy, hz, g, 1.0 / vn, s, P)
    _to_frame(ex, ey, ez, fx, fy, fz, hx, hy, hz, w1, R1 / vn, s, U1)
    _to_frame(ex, ey, ez, fx, fy, fz, hx, hy, hz, w2, R2 / vn, s, U2)
    if not solve_frictional(prm, s, rtol, F[0:13], F[13:16], info):
        return math.nan
    a1, a2 = m2 / M, m1 / M
    rx, ry, rz = _to_lab(ex, ey, ez, fx, fy, fz, hx, hy, hz, sigma * (1.0 + lam * s[Y]), sigma * lam * s[Y + 1], sigma * lam * s[Y + 2])
    gx, gy, gz = _to_lab(ex, ey, ez, fx, fy, fz, hx, hy, hz, vn * s[P], vn * s[P + 1], vn * s[P + 2])
    o1 = _to_lab(ex, ey, ez, fx, fy, fz, hx, hy, hz, s[U1] * vn / R1, s[U1 + 1] * vn / R1, s[U1 + 2] * vn / R1)
    o2 = _to_lab(ex, ey, ez, fx, fy, fz, hx, hy, hz, s[U2] * vn / R2, s[U2 + 1] * vn / R2, s[U2 + 2] * vn / R2)
    r = (rx, ry, rz)
    gend = (gx, gy, gz)
    for k in range(3):
        R = (m1 * r1[k] + m2 * r2[k]) / M
        out[0, k] = R + a1 * r[k]
        out[1, k] = R - a2 * r[k]
        out[2, k] = (m1 * v1[k] + m2 * v2[k]) / M
        out[3, k] = a1 * gend[k]
        out[4, k] = -a2 * gend[k]
        out[5, k] = o1[k]
        out[6, k] = o2[k]
    return info[I_TAU] * ts
