r"""The hard-limit table of frictional contacts: build, lookup and the eMD* A event (docs/physics.md §4.12).

In the hard limit :math:`\Lambda\to0` the tangential problem of a frictional contact (§4.11)
decouples from the normal one and is one-dimensional along the contact-point velocity at the
touch, :math:`\tilde{\mathbf v}_{c0} = u_0 v_n\hat{\mathbf s}`: every tangential force stays parallel
to :math:`\hat{\mathbf s}` and the contact point moves as a body of mass
:math:`m_t = \mu/(1 + K)`, :math:`K = \kappa_1 + \kappa_2 = \mu(R_1^2/I_1 + R_2^2/I_2)`. Its outcome
is the tangential impulse :math:`j = |\int\tilde{\mathbf F}_t\,d\tau|` (in units of :math:`\mu v_n`;
the tangential restitution is :math:`\beta = (1+K)j/u_0 - 1`) and its time integral
:math:`I = \int_0^{\tau_c}j(\tau)\,d\tau`, which shifts the relocated pair. Both depend on
:math:`u_0` and the normal damping :math:`c` alone, given the laws' constants
(:math:`\tilde k`, :math:`x_t`, :math:`\mu`) and :math:`K`.

The table holds, on a grid uniform in :math:`s = u_0/(u_0 + u_r)` (:math:`u_r = 2\mu(1+K)`, where
contacts start to slide throughout; 1 for :math:`\mu = \infty`) and in :math:`c` (dashpot) or :math:`\sqrt c` (Hertz, whose
central values are series in :math:`\sqrt\delta`, §2.2.2), the two bounded outputs
:math:`(1+K)j/w` and :math:`(1+K)I/(\tau_cw)`, :math:`w = u_0 + u_r`: both vanish at :math:`s = 0`
and :math:`s = 1` and are linear in :math:`1 - s` once the contact slides throughout. It is
interpolated by bicubic Lagrange polynomials. Geometry ``grid`` (float array): ``(c-map, x0,
h, n_c, n_s, u_r, k_scaled, K)``; ``n_c = 0``: no table.
"""

import math

from .contact import contact_scales
from .jit import jit, leaf
from .lookup import species_restitution
from .twobody import collision_frame, lab_frame_update
from .twobody_friction import (
    I_TAU, INFO_AT, N_STATE, P, P_C, P_KAPPA1, P_KAPPA2, P_KT, P_LAM, P_LAMBDA1, P_LAMBDA2, P_LAW, P_MODEL, P_MU, P_XT, ROW_PRM,
    ROW_STATE, U1, Y, cross, scaled_spring, solve_frictional,
)  # fmt: skip

#: geometry entries
G_CMAP, G_X0, G_H, G_NC, G_NS, G_UREF, G_KT, G_K = range(8)
N_GRID = 8
#: the softness of the hard-limit solves (their results agree with 1e-12 to 1e-9, measured)
HARD_LAMBDA = 1e-10
#: relative mismatch of a pair's scaled spring or inertia sum beyond which the table does not apply
MATCH_TOL = 1e-9


@jit
def hard_limit(model, c, law, k_scaled, xt, mu, K, u0, rtol, F):
    r"""The hard-limit frictional contact: ``(j, I, tau_c)`` at contact-point speed ``u0`` (NaN if the solve failed).

    Solves §4.11's equations at :math:`\Lambda = 10^{-10}` with the centres' tangential velocity
    zero and the contact-point velocity :math:`u_0\hat{\mathbf e}_y` carried by the first spin.
    ``F``: scratch ``(SCRATCH_ROWS, N_STATE)`` of :mod:`.twobody_friction`.
    """
    prm, s, info = F[ROW_PRM, :INFO_AT], F[ROW_STATE], F[ROW_PRM, INFO_AT : INFO_AT + 4]
    prm[P_MODEL], prm[P_C], prm[P_LAM], prm[P_LAW] = model, c, HARD_LAMBDA, law
    prm[P_KT], prm[P_XT], prm[P_MU] = k_scaled, xt, mu
    prm[P_KAPPA1], prm[P_KAPPA2] = 0.5 * K, 0.5 * K
    prm[P_LAMBDA1], prm[P_LAMBDA2] = 1.0, 1.0
    for q in range(N_STATE):
        s[q] = 0.0
    s[P] = -1.0
    s[U1 + 2] = -u0  # (u_1 x e_x = -u0 e_y: the contact point moves at +u0 e_y)
    if not solve_frictional(prm, s, rtol, F[0:13], F[13:16], info):
        return math.nan, math.nan, math.nan
    return -s[P + 1], -s[Y + 1], info[I_TAU]


@leaf
def axis_damping(cmap, x):
    """The damping ``c`` at mapped coordinate ``x`` (``cmap`` 1: ``x = sqrt(c)``)."""
    return x * x if cmap == 1 else x


@jit
def build(model, law, grid, xt, mu, rtol, out, F):
    """Fill ``out (n_c, n_s, 2)`` with the table's outputs at its nodes (see the module docs).

    Returns the number of failed solves (their nodes hold NaN).
    """
    cmap, x0, h = int(grid[G_CMAP]), grid[G_X0], grid[G_H]
    n_c, n_s, ur, kt, K = int(grid[G_NC]), int(grid[G_NS]), grid[G_UREF], grid[G_KT], grid[G_K]
    failed = 0
    for a in range(n_c):
        c = axis_damping(cmap, x0 + a * h)
        for b in range(n_s):
            out[a, b, 0] = 0.0
            out[a, b, 1] = 0.0
            if b == 0 or (b == n_s - 1 and mu < math.inf):
                continue  # (u0 = 0, and u0 = inf with a finite Coulomb limit: both outputs vanish)
            sb = b / (n_s - 1.0)
            u0 = ur * sb / (1.0 - sb) if b < n_s - 1 else 1.0  # (mu = inf never slides: j and I are linear in u0)
            j, i_j, tau = hard_limit(model, c, law, kt, xt, mu, K, u0, rtol, F)
            if not tau == tau:
                failed += 1
            w = (1.0 + K) / (u0 + ur) if b < n_s - 1 else 1.0 + K
            out[a, b, 0] = j * w
            out[a, b, 1] = i_j / tau * w
    return failed


@leaf
def _cubic(t):
    """Lagrange weights of the nodes 0..3 at ``t``."""
    a, b, c, d = t, t - 1.0, t - 2.0, t - 3.0
    return -b * c * d / 6.0, a * c * d / 2.0, -a * b * d / 2.0, a * b * c / 6.0


@leaf
def _node(x, n):
    """First node of the 4-node stencil around ``x`` (nodes ``0..n-1``) and the offset of ``x`` from it."""
    k = min(max(int(math.floor(x)) - 1, 0), n - 4)
    return k, x - k


@leaf
def lookup(values, grid, c, u0):
    r"""``(j, I / tau_c)`` of a hard-limit contact with damping ``c`` and contact-point speed ``u0`` (NaN off the table)."""
    n_c = int(grid[G_NC])
    x = ((math.sqrt(c) if grid[G_CMAP] == 1 else c) - grid[G_X0]) / grid[G_H]
    if n_c == 0 or not (x >= -1e-12 and x <= (n_c - 1) * (1.0 + 1e-12)):
        return math.nan, math.nan
    ur, K = grid[G_UREF], grid[G_K]
    w = u0 + ur
    y = u0 / w * (grid[G_NS] - 1.0)
    ka, ta = _node(x, n_c)
    kb, tb = _node(y, int(grid[G_NS]))
    wa, wb = _cubic(ta), _cubic(tb)
    j, i_j = 0.0, 0.0
    for a in range(4):
        ja, ia = 0.0, 0.0
        for b in range(4):
            ja += wb[b] * values[ka + a, kb + b, 0]
            ia += wb[b] * values[ka + a, kb + b, 1]
        j += wa[a] * ja
        i_j += wa[a] * ia
    scale = w / (1.0 + K)
    return j * scale, i_j * scale


@jit
def tabled_update(model, ca, cb, law, kt, xt, muf, m1, m2, R1, R2, I1, I2, r1, r2, v1, v2, w1, w2, smooth, values, grid, rtol, W, K, out):
    r"""The frictional contact of two spheres touching now, from the smooth matrix of restitution and the hard-limit table.

    As :func:`.twobody_friction.frictional_update` (the same arguments and ``out (7, 3)``), to
    first order in :math:`\Lambda` (docs/physics.md §4.12): the smooth map of §4.5–4.6
    (``smooth = (use_table, values, tg, ctab, cgeo, pair_values, pair_grid)`` of :func:`.lookup.species_restitution`)
    relocates the pair and restitutes the normal motion, and the tangential impulse
    :math:`\mathbf J = -\mu v_nj\hat{\mathbf s}` on particle 1 at the contact point,

    .. math::
        \Delta\boldsymbol\Delta_{1,2} = \pm\frac{\mathbf J}{m_{1,2}},\quad
        \Delta\mathbf r^A_{1,2} = \pm\frac{\mathbf J}{m_{1,2}}\,t_c\frac{I}{\tau_cj},\quad
        \Delta\boldsymbol\omega_{1,2} = -\frac{R_{1,2}}{\sigma I_{1,2}}\big[(\mathbf r^A_1 - \mathbf r^A_2)\times\mathbf J
            + t_c\frac{I}{\tau_cj}\,\mathbf J\times\mathbf g'\big]

    (:math:`\mathbf r^A` the smooth map's relocation, :math:`\mathbf g'` the relative velocity after the
    contact; to leading order :math:`-\tfrac{R}{I}\hat{\mathbf n}\times\mathbf J`, and the total angular
    momentum is conserved exactly), with :math:`\hat{\mathbf n} = (\mathbf r_1 - \mathbf r_2)/\sigma` and :math:`\hat{\mathbf s}` along the tangential
    contact-point velocity :math:`\mathbf g - (R_1\boldsymbol\omega_1 + R_2\boldsymbol\omega_2)\times\hat{\mathbf n}`.
    Returns :math:`t_c`, or NaN where the table does not apply (damping off its range, another
    scaled spring or inertia sum: the caller solves such contacts directly).
    """
    M = m1 + m2
    mu = m1 * m2 / M
    sigma = R1 + R2
    reff = R1 * R2 / sigma
    K_pair = mu * (R1 * R1 / I1 + R2 * R2 / I2)
    if abs(K_pair - grid[G_K]) > MATCH_TOL * grid[G_K]:
        return math.nan
    nx, ny, nz, _tx, _ty, _tz, vn, vt = collision_frame(r1, r2, v1, v2)
    c, _lam, ts, ls = contact_scales(model, ca, cb, mu, reff, sigma, vn)
    if abs(scaled_spring(law, kt, mu, reff, ts, ls) - grid[G_KT]) > MATCH_TOL * grid[G_KT]:
        return math.nan
    rx, ry, rz = cross(R1 * w1[0] + R2 * w2[0], R1 * w1[1] + R2 * w2[1], R1 * w1[2] + R2 * w2[2], nx, ny, nz)
    vc = (v1[0] - v2[0] - rx, v1[1] - v2[1] - ry, v1[2] - v2[2] - rz)
    vcn = vc[0] * nx + vc[1] * ny + vc[2] * nz
    vct = (vc[0] - vcn * nx, vc[1] - vcn * ny, vc[2] - vcn * nz)
    speed = math.sqrt(vct[0] * vct[0] + vct[1] * vct[1] + vct[2] * vct[2])
    j, i_rate = lookup(values, grid, c, speed / vn)
    if not j == j:
        return math.nan
    phi, d, tc, eps = species_restitution(model, ca, cb, m1, m2, R1, R2, vn, vt, *smooth, rtol, W, K)
    if not tc == tc:
        return math.nan
    lab_frame_update(r1, r2, v1, v2, m1, m2, sigma, phi, d, eps, out[0:5])
    # J = -mu vn j s_hat, s_hat = vct / speed; its time integral over the contact is J tc I / (tau_c j)
    f = -mu * vn * j / speed if speed > 0.0 else 0.0
    shift = tc * i_rate / j if j > 0.0 else 0.0
    J = (f * vct[0], f * vct[1], f * vct[2])
    arm = (out[0, 0] - out[1, 0], out[0, 1] - out[1, 1], out[0, 2] - out[1, 2])
    for k in range(3):
        out[0, k] += J[k] / m1 * shift
        out[1, k] -= J[k] / m2 * shift
        out[3, k] += J[k] / m1
        out[4, k] -= J[k] / m2
    torque = cross(arm[0], arm[1], arm[2], J[0], J[1], J[2])
    drift = cross(J[0], J[1], J[2], out[3, 0] - out[4, 0], out[3, 1] - out[4, 1], out[3, 2] - out[4, 2])
    for k in range(3):
        t = (torque[k] + shift * drift[k]) / sigma  # (the spins take what the translation's angular momentum lost)
        out[5, k] = w1[k] - R1 / I1 * t
        out[6, k] = w2[k] - R2 / I2 * t
    return tc
