r"""Matrix-of-restitution lookup tables: node values and compiled interpolation (physics.md §4.7).

A table is a tensor-product grid over the three coordinates of physics.md §4.7,

* damping :math:`u_1` (:math:`\zeta_d` for the dashpot, :math:`\delta_v = \beta_v v^{1/5}` for Hertz),
* velocity softness :math:`\Lambda_v` (the table's box is given in :math:`\log_{10}\Lambda_v`),
* eccentricity :math:`b = \sin\alpha`,

holding three normalised, :math:`O(1)` outputs: :math:`\psi_c/\tau_{c0} = \Phi/(\Lambda\tan\alpha\,\tau_{c0})`,
:math:`\tau_c/\tau_{c0}` and :math:`\hat\varepsilon/e_n`, where :math:`\tau_{c0}, e_n` are the central values at
the same damping. The fourth element needs no table: the termination condition
:math:`X + cX' = 0` gives :math:`X_c = c\,\hat\varepsilon` exactly, hence :math:`D = 1 - \Lambda c\,\hat\varepsilon`.

Each axis is uniform in a mapped coordinate (``AX_LINEAR``: :math:`x = u`; ``AX_GRAZING``:
:math:`x = a\,b - \ln(1-b)`, nodes denser towards grazing contacts, where the centrifugal
parameter :math:`\Lambda\tan^2\alpha` diverges, yet not sparse at central ones) and values are
interpolated by tensor-product Lagrange polynomials of odd degree ``p`` on the ``p + 1`` nodes
around the point. Geometry of a table (tuple ``tg`` of 16 numbers): for each axis
``(map, a, x0, h, n)``, then ``p``.
"""

import math

import numpy as np

from .jit import jit, leaf
from .contact import MODEL_HERTZ, contact_scales, table_coordinates
from .twobody import dashpot_central, solve_scaled

AX_LINEAR = 0
AX_GRAZING = 1
AX_LOGSHIFT = 2

#: outputs per node: psi_c / tau_c0, tau_c / tau_c0, eps_hat / e_n
N_OUT = 3
#: largest interpolation degree
MAX_DEGREE = 9
#: shape of the scratch array ``W`` of the lookups (the stencil weights of the three axes)
SCRATCH_SHAPE = (3, MAX_DEGREE + 1)


def _inverse_denominators():
    """``1 / prod_{m != j} (j - m)`` for the nodes ``0..p`` (row ``p``, column ``j``)."""
    out = np.zeros((MAX_DEGREE + 1, MAX_DEGREE + 1))
    for p in range(MAX_DEGREE + 1):
        for j in range(p + 1):
            out[p, j] = (-1.0) ** (p - j) / (math.factorial(j) * math.factorial(p - j))
    return out


_INV_DEN = _inverse_denominators()


@leaf
def axis_map(kind, a, u):
    """Mapped coordinate of an axis (see module docstring)."""
    if kind == AX_GRAZING:
        return a * u - math.log1p(-u)
    if kind == AX_LOGSHIFT:
        return math.log(u + a)
    return u


@leaf
def solver_parameters(model, u1, lam_v, b):
    r"""From table coordinates to the §4.4 parameters ``(c, Lambda, tan_alpha)`` (physics.md §4.7).

    Dashpot: :math:`c = 2\zeta_d`, :math:`\Lambda = \Lambda_v\sqrt{1-b^2}`; Hertz:
    :math:`c = \delta_v(1-b^2)^{1/10}`, :math:`\Lambda = \Lambda_v(1-b^2)^{2/5}`; both
    :math:`\tan\alpha = b/\sqrt{1-b^2}`.
    """
    cb2 = (1.0 - b) * (1.0 + b)
    cb = math.sqrt(cb2)
    if model == MODEL_HERTZ:
        return u1 * cb2 ** 0.1, lam_v * cb2 ** 0.4, b / cb
    return 2.0 * u1, lam_v * cb, b / cb


@leaf
def central_values(model, c, ctab, cgeo):
    r"""Central :math:`(\tau_{c0}, e_n)` at damping ``c`` (physics.md §2.2).

    Dashpot: closed form (§2.2.1, :math:`\zeta_d = c/2`). Hertz: the 1-D table ``ctab`` over
    :math:`s = \sqrt\delta` (uniform, geometry ``cgeo = (s0, h, n, p)``), in which
    :math:`\varepsilon(\delta)` and :math:`\tau_c(\delta)` are analytic (physics.md §2.2.2 series in
    :math:`\delta^{1/2}`).
    """
    if model != MODEL_HERTZ:
        tau, e, _x = dashpot_central(0.5 * c)
        return tau, e
    s0, h = cgeo[0], cgeo[1]
    n, p = int(cgeo[2]), int(cgeo[3])
    x = (math.sqrt(c) - s0) / h
    k = int(math.floor(x)) - (p - 1) // 2
    k = min(max(k, 0), n - p - 1)
    t = x - k
    # Lagrange weights on the nodes 0..p, accumulated on the fly (no scratch array here)
    tau = 0.0
    e = 0.0
    for j in range(p + 1):
        w = _INV_DEN[p, j]
        for m in range(p + 1):
            if m != j:
                w *= t - m
        tau += w * ctab[k + j, 0]
        e += w * ctab[k + j, 1]
    return tau, e


@leaf
def _weights(t, p, W, row):
    """Lagrange weights of the nodes ``0..p`` at ``t`` into ``W[row, :p+1]`` (prefix/suffix products)."""
    W[row, 0] = 1.0
    for m in range(p):
        W[row, m + 1] = W[row, m] * (t - m)
    suffix = 1.0
    for j in range(p, -1, -1):
        W[row, j] *= suffix * _INV_DEN[p, j]
        suffix *= t - j


@leaf
def _stencil(kind, a, u, x0, h, n, p, W, row):
    """First node of the stencil around ``u`` on one axis; its weights go to ``W[row, :p+1]``.

    Returns ``-1`` outside the axis range (a relative margin of ``1e-12`` is tolerated).
    """
    x = (axis_map(kind, a, u) - x0) / h
    if not (x >= -1e-12 and x <= (n - 1) * (1.0 + 1e-12)):
        return -1
    k = int(math.floor(x)) - (p - 1) // 2
    k = min(max(k, 0), n - p - 1)
    _weights(x - k, p, W, row)
    return k


@leaf
def _row18(a, w, v, q):
    """``a + w * v[q:q+18]`` for an 18-tuple ``a`` (one stencil row of a degree-5 table, in registers)."""
    return (
        a[0] + w * v[q + 0],
        a[1] + w * v[q + 1],
        a[2] + w * v[q + 2],
        a[3] + w * v[q + 3],
        a[4] + w * v[q + 4],
        a[5] + w * v[q + 5],
        a[6] + w * v[q + 6],
        a[7] + w * v[q + 7],
        a[8] + w * v[q + 8],
        a[9] + w * v[q + 9],
        a[10] + w * v[q + 10],
        a[11] + w * v[q + 11],
        a[12] + w * v[q + 12],
        a[13] + w * v[q + 13],
        a[14] + w * v[q + 14],
        a[15] + w * v[q + 15],
        a[16] + w * v[q + 16],
        a[17] + w * v[q + 17],
    )


@jit
def lookup_normalised(values, tg, u1, lam_v, b, W):
    """Interpolated normalised outputs at ``(u1, lam_v, b)``; NaNs outside the table.

    ``values``: the node values flattened from C-order ``(n0, n1, n2, 3)``; ``tg``: table
    geometry; ``W``: scratch ``(3, p + 1)`` float64 (:data:`SCRATCH_SHAPE`). The sum is
    contracted over the first two axes (each of the ``(p+1)^2`` stencil rows is ``3 (p + 1)``
    contiguous numbers), then over the last. Degree 5 (the default tables) keeps the 18 partial
    sums in registers; other degrees accumulate in memory.
    """
    p = int(tg[15])
    n1 = int(tg[9])
    n2 = int(tg[14])
    k0 = _stencil(tg[0], tg[1], u1, tg[2], tg[3], int(tg[4]), p, W, 0)
    k1 = _stencil(tg[5], tg[6], lam_v, tg[7], tg[8], n1, p, W, 1)
    k2 = _stencil(tg[10], tg[11], b, tg[12], tg[13], n2, p, W, 2)
    if k0 < 0 or k1 < 0 or k2 < 0:
        return math.nan, math.nan, math.nan
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    if p == 5:
        acc = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        for i in range(6):
            wi = W[0, i]
            for j in range(6):
                acc = _row18(acc, wi * W[1, j], values, (((k0 + i) * n1 + k1 + j) * n2 + k2) * N_OUT)
        for k in range(6):
            w = W[2, k]
            a0 += w * acc[N_OUT * k]
            a1 += w * acc[N_OUT * k + 1]
            a2 += w * acc[N_OUT * k + 2]
        return a0, a1, a2
    for i in range(p + 1):
        wi = W[0, i]
        for j in range(p + 1):
            wij = wi * W[1, j]
            base = (((k0 + i) * n1 + k1 + j) * n2 + k2) * N_OUT
            for k in range(p + 1):
                w = wij * W[2, k]
                q = base + N_OUT * k
                a0 += w * values[q]
                a1 += w * values[q + 1]
                a2 += w * values[q + 2]
    return a0, a1, a2


#: fields of a row of pair tables' geometry (:func:`pair_restitution`): the two species' masses and
#: radii, the contact constants the table was built for, ``(map, a, x0, h, n)`` of the speed axis
#: and of the b axis, and the table's first value in the concatenated values
PG_SPECIES, PG_A, PG_B, PG_SPEED, PG_B_AXIS, PG_OFFSET = 0, 4, 5, 6, 11, 16
PAIR_GRID = 17


@leaf
def _pair_row(pg, ca, cb, mi, mj, ri, rj):
    """The row of ``pg`` built for this pair of species (either order) and contact law (exact compares), or -1."""
    for t in range(pg.shape[0]):
        m1, r1, m2, r2 = pg[t, PG_SPECIES], pg[t, PG_SPECIES + 1], pg[t, PG_SPECIES + 2], pg[t, PG_SPECIES + 3]
        same = (mi == m1 and ri == r1 and mj == m2 and rj == r2) or (mi == m2 and ri == r2 and mj == m1 and rj == r1)
        if same and ca == pg[t, PG_A] and cb == pg[t, PG_B]:
            return t
    return -1


@leaf
def pair_restitution(model, ca, cb, mi, mj, ri, rj, vn, vt, pv, pg, W):
    r"""Matrix of restitution from the pair table of the pair's two species (physics.md §4.7).

    For a pair of given species (masses and radii) and one contact law, both velocity-dependent
    coordinates :math:`u_1` and :math:`\Lambda_v` of a table are functions of the impact speed
    :math:`v` alone, so the matrix of restitution is a function of two numbers: a pair table holds
    it on a grid of the speed axis (:math:`\delta_v` for Hertz, :math:`\Lambda_v` for the dashpot,
    mapped as the three-dimensional table's axes) and the b axis, interpolated by degree-5 Lagrange
    polynomials (36 nodes where a three-dimensional table takes 216, and no central values).
    Its nodes hold :math:`(\psi_c g, \tau_c, \hat\varepsilon)` with :math:`g = (1-b^2)^{-1/10}`
    (Hertz) or 1 (dashpot), from which (physics.md §4.5)

    .. math::
        \Phi = \Lambda_v b\,\psi_c g,\qquad D = 1 - \Lambda_v\,k\,u_1\sqrt{1-b^2}\,\hat\varepsilon,\qquad t_c = \tau_c t_s(v_n)

    with :math:`k = 1` (Hertz) or 2 (dashpot). ``pg``: one row per table (:data:`PAIR_GRID`
    fields), ``pv``: their values, concatenated. Returns ``(Phi, D, t_c, eps_hat)``; NaNs for a
    pair or law no table was built for, or outside the grid (the caller then takes
    :func:`matrix_of_restitution`).
    """
    nan = math.nan
    t = _pair_row(pg, ca, cb, mi, mj, ri, rj)
    if t < 0:
        return nan, nan, nan, nan
    sigma = ri + rj
    mu = mi * mj / (mi + mj)
    reff = ri * rj / sigma
    v = math.sqrt(vn * vn + vt * vt)
    u1, lam_v = table_coordinates(model, ca, cb, mu, reff, sigma, v)
    b = vt / v
    q, a = PG_SPEED, PG_B_AXIS
    nb = int(pg[t, a + 4])
    k0 = _stencil(pg[t, q], pg[t, q + 1], u1 if model == MODEL_HERTZ else lam_v, pg[t, q + 2], pg[t, q + 3], int(pg[t, q + 4]), 5, W, 0)
    k1 = _stencil(pg[t, a], pg[t, a + 1], b, pg[t, a + 2], pg[t, a + 3], nb, 5, W, 1)
    if k0 < 0 or k1 < 0:
        return nan, nan, nan, nan
    first = int(pg[t, PG_OFFSET])
    acc = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for i in range(6):
        acc = _row18(acc, W[0, i], pv, first + ((k0 + i) * nb + k1) * N_OUT)
    t0 = t1 = t2 = 0.0
    for k in range(6):
        w = W[1, k]
        t0 += w * acc[N_OUT * k]
        t1 += w * acc[N_OUT * k + 1]
        t2 += w * acc[N_OUT * k + 2]
    _c, _lam, ts, _ls = contact_scales(model, ca, cb, mu, reff, sigma, vn)
    kc = u1 if model == MODEL_HERTZ else 2.0 * u1
    return lam_v * b * t0, 1.0 - lam_v * kc * math.sqrt((1.0 - b) * (1.0 + b)) * t2, t1 * ts, t2


@jit
def pair_node_values(model, u1s, lvs, bs, rtol, out, K):
    """Node values of a pair table (:func:`pair_restitution`) by direct solves at relative tolerance
    ``rtol``: ``out[k, m] = (psi_c g, tau_c, eps_hat)`` at the speed node ``(u1s[k], lvs[k])`` and ``bs[m]``."""
    for k in range(u1s.shape[0]):
        for m in range(bs.shape[0]):
            c, lam, tan_a = solver_parameters(model, u1s[k], lvs[k], bs[m])
            _phi, _d, tau, eps, _xc, psi = solve_scaled(model, c, lam, tan_a, rtol, K)
            g = ((1.0 - bs[m]) * (1.0 + bs[m])) ** -0.1 if model == MODEL_HERTZ else 1.0
            out[k, m, 0] = psi * g
            out[k, m, 1] = tau
            out[k, m, 2] = eps if c > 0.0 else 1.0


@jit
def pair_restitution_many(model, ca, cb, mi, mj, ri, rj, vns, vts, pv, pg, out, W):
    """:func:`pair_restitution` at many impacts; ``out[k] = (Phi, D, t_c, eps_hat)``."""
    for k in range(vns.shape[0]):
        r = pair_restitution(model, ca, cb, mi, mj, ri, rj, vns[k], vts[k], pv, pg, W)
        for q in range(4):
            out[k, q] = r[q]


@jit
def lookup(model, values, tg, ctab, cgeo, u1, lam_v, b, W):
    r"""Matrix of restitution from a table at table coordinates ``(u1, lam_v, b)`` (physics.md §4.5, §4.7).

    Returns ``(Phi, D, tau_c, eps_hat, X_c, psi_c)`` like :func:`~edmd._core.twobody.solve_scaled`
    (NaNs outside the table's box), with :math:`X_c = c\hat\varepsilon`, :math:`D = 1 - \Lambda X_c`.
    Elastic contacts (``u1 = 0``) get the exact :math:`\hat\varepsilon = D = 1` (energy conservation).
    """
    n0, n1, n2 = lookup_normalised(values, tg, u1, lam_v, b, W)
    c, lam, tan_a = solver_parameters(model, u1, lam_v, b)
    tau0, e0 = central_values(model, c, ctab, cgeo)
    psi = n0 * tau0
    eps = n2 * e0 if c > 0.0 else 1.0 + 0.0 * n2  # (keeps the NaN of a point outside the box)
    xc = c * eps
    return lam * tan_a * psi, 1.0 - lam * xc, n1 * tau0, eps, xc, psi


@jit
def lookup_many(model, values, tg, ctab, cgeo, u1s, lvs, bs, out, W):
    """:func:`lookup` at many points; ``out[k] = (Phi, D, tau_c, eps_hat, X_c, psi_c)``."""
    for k in range(u1s.shape[0]):
        r = lookup(model, values, tg, ctab, cgeo, u1s[k], lvs[k], bs[k], W)
        for q in range(6):
            out[k, q] = r[q]


@jit
def matrix_of_restitution(model, a, b, mu, reff, sigma, vn, vt, use_table, values, tg, ctab, cgeo, rtol, W, K):
    r"""Matrix of restitution of a physical impact, from a table or the direct solver (physics.md §4.5, §4.7).

    The entry point of event-driven callers: contact constants ``(a, b)`` (see
    :mod:`edmd._core.contact`), pair constants, normal and tangential impact speeds. With
    ``use_table`` the table is interpolated and the direct solver (tolerance ``rtol``) takes
    over outside its box; otherwise the solver is used. ``W``: scratch ``(3, p + 1)``; ``K``:
    scratch ``(13, 3)``.

    Returns ``(Phi, D, t_c, eps_hat, from_table)`` with the physical contact duration ``t_c``;
    elastic contacts have :math:`D = \hat\varepsilon = 1` exactly (physics.md §4.5).
    """
    c, lam, ts, _ls = contact_scales(model, a, b, mu, reff, sigma, vn)
    if use_table:
        v = math.sqrt(vn * vn + vt * vt)
        u1, lam_v = table_coordinates(model, a, b, mu, reff, sigma, v)
        r = lookup(model, values, tg, ctab, cgeo, u1, lam_v, vt / v, W)
        if r[2] == r[2]:
            return r[0], r[1], r[2] * ts, r[3], True
    r = solve_scaled(model, c, lam, vt / vn, rtol, K)
    eps = r[3] if c > 0.0 else 1.0 + 0.0 * r[3]  # elastic: exactly 1 (energy), NaN kept
    return r[0], r[1], r[2] * ts, eps, False


@leaf
def species_restitution(model, ca, cb, mi, mj, ri, rj, vn, vt, use_table, values, tg, ctab, cgeo, pv, pg, rtol, W, K):
    """``(Phi, D, t_c, eps_hat)`` of a physical impact: from the pair table ``(pv, pg)`` where it serves
    the pair (:func:`pair_restitution`), else from :func:`matrix_of_restitution` (NaN ``t_c``: the solver failed)."""
    phi, d, tc, eps = pair_restitution(model, ca, cb, mi, mj, ri, rj, vn, vt, pv, pg, W)
    if tc == tc:
        return phi, d, tc, eps
    sigma = ri + rj
    phi, d, tc, eps, _tab = matrix_of_restitution(model, ca, cb, mi * mj / (mi + mj), ri * rj / sigma, sigma, vn, vt, use_table, values, tg, ctab, cgeo, rtol, W, K)
    return phi, d, tc, eps


@jit
def direct_many(model, u1s, lvs, bs, rtol, out, K):
    """Direct solves at table coordinates ``(u1s[k], lvs[k], bs[k])``; ``out[k]`` as in :func:`lookup_many`."""
    for k in range(u1s.shape[0]):
        c, lam, tan_a = solver_parameters(model, u1s[k], lvs[k], bs[k])
        r = solve_scaled(model, c, lam, tan_a, rtol, K)
        for q in range(6):
            out[k, q] = r[q]


@jit
def node_values(model, u1s, lvs, bs, rtol, out, K):
    """Normalised outputs at the nodes ``u1s x lvs x bs`` (a slab of a table's grid) into ``out``.

    Direct solves at relative tolerance ``rtol``; central values from the direct solver
    (Hertz) or the closed form (dashpot).
    """
    for i in range(u1s.shape[0]):
        for j in range(lvs.shape[0]):
            for k in range(bs.shape[0]):
                c, lam, tan_a = solver_parameters(model, u1s[i], lvs[j], bs[k])
                _phi, _d, tau, eps, _xc, psi = solve_scaled(model, c, lam, tan_a, rtol, K)
                if model == MODEL_HERTZ:
                    _p0, _d0, tau0, e0, _x0, _s0 = solve_scaled(model, c, 0.0, 0.0, rtol, K)
                else:
                    tau0, e0, _x0 = dashpot_central(0.5 * c)
                out[i, j, k, 0] = psi / tau0
                out[i, j, k, 1] = tau / tau0
                out[i, j, k, 2] = eps / e0
