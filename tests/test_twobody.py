"""Two-body solver and eMD* lab-frame update against physics.md §2.2 (T8, T9), §4.5, §4.10 and scipy.

Reference values: the closed forms of §2.2.1, the tables of §2.2.1, §2.2.2 and §4.10(c) (printed
to 7 significant digits, hence tolerances of a few 1e-7), the small-delta series of §2.2.2, and
independent integrations with scipy's DOP853 at rtol 1e-13: of the same scaled polar ODE
(solver accuracy) and of the full Cartesian two-sphere problem (lab-frame update, T11).
"""

import doctest
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import gamma as Gamma

import edmd.physics.twobody
from edmd._core.twobody import dashpot_central
from edmd.physics.contact import ContactError, Hertz, LinearDashpot
from edmd.physics.twobody import collide, lab_frame_update, solve

from reference import direct_two_spheres, random_contact

# physics.md §2.2.1 table: zeta, omega0 t_c, e_n, xi_c omega0 / v_n
DASHPOT_TABLE = [
    (0.01, 3.1217484, 0.9692648, 0.019385),
    (0.05, 3.0453600, 0.8587581, 0.085876),
    (0.1, 2.9560753, 0.7440794, 0.148816),
    (0.3, 2.6544746, 0.4509755, 0.270585),
    (0.5, 2.4183992, 0.2984361, 0.298436),
    (1 / math.sqrt(2), 2.2214415, 0.2078796, 0.293986),
    (1.0, 2.0000000, 0.1353353, 0.270671),
    (3.0, 1.2464505, 0.0237695, 0.142617),
]

# physics.md §2.2.2 table: delta, epsilon, tau_c, X_c
HERTZ_TABLE = [
    (0.001, 0.99884736, 3.217437, 0.000999),
    (0.01, 0.98854744, 3.211798, 0.009885),
    (0.05, 0.94439678, 3.187147, 0.047220),
    (0.1, 0.89285888, 3.157256, 0.089286),
    (0.2, 0.80096547, 3.100413, 0.160193),
    (0.5, 0.59525150, 2.950445, 0.297626),
    (1.0, 0.39393060, 2.752027, 0.393931),
    (2.0, 0.21164605, 2.470628, 0.423292),
    (5.0, 0.06889966, 2.005130, 0.344498),
    (10.0, 0.02509570, 1.630715, 0.250957),
]

# physics.md §4.10(c): model, damping, Lambda, b, Phi, D, tau_c, eps_hat
OBLIQUE_TABLE = [
    ("dashpot", 0, 0.001, 0.5, 1.815724e-3, 1, 3.140924, 1),
    ("dashpot", 0, 0.01, 0.9, 6.384646e-2, 1, 3.054452, 1),
    ("dashpot", 0, 0.1, 0.5, 2.009274e-1, 1, 3.057217, 1),
    ("dashpot", 0, 0.1, 0.9, 5.012582e-1, 1, 2.228930, 1),
    ("dashpot", 0.1, 0.001, 0, 0, 0.999851184, 2.956075, 0.7440794),
    ("dashpot", 0.1, 0.01, 0.5, 1.721979e-2, 0.998510835, 2.948108, 0.7445825),
    ("dashpot", 0.1, 0.01, 0.9, 5.961939e-2, 0.998499975, 2.855258, 0.7500127),
    ("dashpot", 0.1, 0.1, 0.5, 1.857585e-1, 0.985005066, 2.861237, 0.7497467),
    ("dashpot", 0.1, 0.1, 0.9, 4.447118e-1, 0.984597380, 1.985932, 0.7701310),
    ("dashpot", 0.3, 0.01, 0.9, 5.253879e-2, 0.997232929, 2.520657, 0.4611784),
    ("dashpot", 0.3, 0.1, 0.9, 3.524620e-1, 0.971478961, 1.590294, 0.4753506),
    ("hertz", 0, 0.01, 0.5, 1.880944e-2, 1, 3.213525, 1),
    ("hertz", 0, 0.1, 0.9, 5.500750e-1, 1, 2.424197, 1),
    ("hertz", 0.1, 0.001, 0.9, 6.514418e-3, 0.999910677, 3.150847, 0.8932292),
    ("hertz", 0.1, 0.01, 0, 0, 0.999107141, 3.157256, 0.8928589),
    ("hertz", 0.1, 0.1, 0.5, 2.048189e-1, 0.991036238, 3.090300, 0.8963762),
    ("hertz", 0.5, 0.01, 0.9, 5.958054e-2, 0.996971388, 2.850654, 0.6057224),
    ("hertz", 0.5, 0.1, 0.9, 4.422401e-1, 0.968769581, 1.954068, 0.6246084),
]


def tan_of(b):
    return b / math.sqrt(1 - b * b)


# ------------------------------------------------------------------ central collisions (T8, T9)
@pytest.mark.parametrize("zeta, tau, e_n, xc", DASHPOT_TABLE)
def test_t8_dashpot_central(zeta, tau, e_n, xc):
    r = solve("dashpot", zeta, 0.0)
    closed = dashpot_central(zeta)
    # integrator vs closed form to 1e-10 (physics.md T8); closed form vs the printed table
    assert r.tau_c == pytest.approx(closed[0], rel=1e-10)
    assert r.eps_hat == pytest.approx(closed[1], rel=1e-10)
    assert r.X_c == pytest.approx(closed[2], rel=1e-10)
    assert closed[0] == pytest.approx(tau, abs=6e-8)
    assert closed[1] == pytest.approx(e_n, abs=6e-8)
    assert closed[2] == pytest.approx(xc, abs=6e-7)
    assert r.Phi == 0.0 and r.D == 1.0  # Lambda = 0: hard limit


def test_dashpot_zeta_zero_and_critical():
    assert solve("dashpot", 0.0, 0.0).tau_c == pytest.approx(math.pi, rel=1e-11)
    assert solve("dashpot", 1.0, 0.0).eps_hat == pytest.approx(math.exp(-2), rel=1e-11)


@pytest.mark.parametrize("delta, eps, tau, xc", HERTZ_TABLE)
def test_t9_hertz_central(delta, eps, tau, xc):
    r = solve("hertz", delta, 0.0)
    assert r.eps_hat == pytest.approx(eps, abs=6e-9)
    assert r.tau_c == pytest.approx(tau, abs=6e-7)
    assert r.X_c == pytest.approx(xc, abs=6e-7)
    # termination X + delta X' = 0 gives X_c = delta * eps exactly (physics.md §2.2.2)
    assert r.X_c == pytest.approx(delta * r.eps_hat, rel=1e-10)


def test_t9_elastic_hertz_duration():
    # tau_c(0) = 2 (5/4)^(2/5) sqrt(pi) Gamma(7/5) / Gamma(9/10) = 3.2180655
    exact = 2 * 1.25**0.4 * math.sqrt(math.pi) * Gamma(1.4) / Gamma(0.9)
    r = solve("hertz", 0.0, 0.0)
    assert exact == pytest.approx(3.2180655, abs=5e-8)
    assert r.tau_c == pytest.approx(exact, rel=1e-10)
    assert r.eps_hat == pytest.approx(1.0, abs=1e-11)


@pytest.mark.parametrize("delta", [1e-4, 3e-4, 1e-3])
def test_hertz_small_delta_series(delta):
    # physics.md §2.2.2: eps = 1 - C1 d + C2 d^2 + (4/15) d^(5/2) + h6 d^3, h6 ~ -0.49
    c1 = Gamma(0.6) * math.sqrt(math.pi) / (2**0.2 * 5**0.4 * Gamma(2.1))
    assert c1 == pytest.approx(1.1534489, abs=1e-7)
    series = 1 - c1 * delta + 0.6 * c1**2 * delta**2 + 4 / 15 * delta**2.5
    # the remainder is h6 d^3 (|h6| < 0.6) plus the solver error (~1e-12 at rtol 1e-12)
    assert solve("hertz", delta, 0.0).eps_hat == pytest.approx(series, abs=0.6 * delta**3 + 3e-12)


# ------------------------------------------------------------------ oblique collisions (§4.10 c)
@pytest.mark.parametrize("model, damping, lam, b, Phi, D, tau, eps", OBLIQUE_TABLE)
def test_oblique_table(model, damping, lam, b, Phi, D, tau, eps):
    r = solve(model, damping, lam, tan_of(b))
    assert r.Phi == pytest.approx(Phi, rel=6e-7, abs=1e-15)
    assert r.D == pytest.approx(D, abs=6e-10)
    assert r.tau_c == pytest.approx(tau, abs=6e-7)
    assert r.eps_hat == pytest.approx(eps, abs=6e-8)
    if damping == 0:
        # elastic contacts: D = 1 and eps_hat = 1 to the integrator's tolerance
        assert r.D == 1.0
        assert r.eps_hat == pytest.approx(1.0, abs=1e-11)


def test_hard_limit():
    # physics.md §4.5: Lambda -> 0 gives Phi -> Lambda tan(alpha) tau_c0, D -> 1, eps_hat -> e_n,
    # with corrections O(Lambda tan^2 alpha)
    for model, damping in [("dashpot", 0.2), ("hertz", 0.3)]:
        central = solve(model, damping, 0.0)
        ta = tan_of(0.7)
        for lam in [1e-4, 1e-5]:
            r = solve(model, damping, lam, ta)
            assert r.Phi / (lam * ta * central.tau_c) == pytest.approx(1.0, abs=3 * lam * ta * ta)
            assert r.eps_hat == pytest.approx(central.eps_hat, abs=3 * lam * ta * ta)
            assert 1 - r.D == pytest.approx(lam * central.X_c, rel=3 * lam * ta * ta)


# ------------------------------------------------------------------ against scipy DOP853
def scipy_reference(model, c, lam, ta):
    """The scaled polar ODE of physics.md §4.4 integrated by scipy (DOP853, rtol 1e-13)."""
    cen = lam * ta * ta

    def rhs(t, y):
        x, v, phi = y
        q = 1.0 / (1.0 - lam * x)
        f = x + c * v
        if model == "hertz":
            f *= math.sqrt(max(x, 0.0))
        return [v, -f - cen * q**3, lam * ta * q * q]

    def force_vanishes(t, y):
        return y[0] + c * y[1] if t > 1e-9 else 1.0

    force_vanishes.terminal = True
    force_vanishes.direction = -1
    sol = solve_ivp(rhs, (0, 50), [0.0, 1.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-16, events=force_vanishes)
    (t,), ((x, v, phi),) = sol.t_events[0], sol.y_events[0]
    return phi, lam * x, t, -v


@pytest.mark.parametrize("model", ["dashpot", "hertz"])
def test_against_scipy_dop853(model, rng):
    for _ in range(6):
        damping = rng.uniform(0, 0.5 if model == "dashpot" else 1.0)
        lam = 10 ** rng.uniform(-5, -0.7)
        ta = tan_of(rng.uniform(0, 0.98))
        c = 2 * damping if model == "dashpot" else damping
        phi, one_minus_d, tau, eps = scipy_reference(model, c, lam, ta)
        r = solve(model, damping, lam, ta)
        assert r.Phi == pytest.approx(phi, rel=1e-10)
        assert r.tau_c == pytest.approx(tau, rel=1e-10)
        assert r.eps_hat == pytest.approx(eps, rel=1e-10)
        assert lam * r.X_c == pytest.approx(one_minus_d, rel=1e-9, abs=1e-300)


@pytest.mark.parametrize("model", ["dashpot", "hertz"])
def test_grazing_contacts(model):
    # b -> 1: the contact (duration ~ 2 / (Lambda tan^2 alpha)) can fit in the first trial step;
    # elastic contacts must still end at X = 0 with eps_hat = D = 1, and Phi -> 2 / tan(alpha)
    for ta in [30.0, 1e4, 1e6]:
        r = solve(model, 0.0, 0.1, ta)
        assert r.eps_hat == pytest.approx(1.0, abs=1e-10) and r.D == pytest.approx(1.0, abs=1e-14)
        if ta > 1e3:
            assert r.Phi == pytest.approx(2.0 / ta, rel=1e-6)
    phi, one_minus_d, tau, eps = scipy_reference(model, 0.0, 0.1, 30.0)
    r = solve(model, 0.0, 0.1, 30.0)
    assert (r.Phi, r.tau_c, r.eps_hat) == pytest.approx((phi, tau, eps), rel=1e-10)


def test_bad_solver_input():
    with pytest.raises(ContactError, match="softness must be below 1"):
        solve("dashpot", 0.1, 1.5)
    with pytest.raises(ContactError, match="unknown contact model"):
        solve("maxwell", 0.1, 0.1)
    with pytest.raises(ContactError, match="damping must be"):
        solve("hertz", -0.1, 0.1)


# ------------------------------------------------------------------ lab frame (§4.6, T11, T12)
def emd_star_two_spheres(contact, m, R, r0, v0, gravity, t_end):
    """eMD*: event A at t0 = 0 (relocate, both move with V), event B at t_c, free flight to t_end."""
    g = v0[0] - v0[1]
    n = (r0[0] - r0[1]) / (R[0] + R[1])
    vn = -float(g @ n)
    vt = float(np.linalg.norm(g + vn * n))
    res = collide(contact, m[0], m[1], R[0], R[1], vn, vt)
    upd = lab_frame_update(r0[0], r0[1], v0[0], v0[1], m[0], m[1], R[0], R[1], res)
    tc = res.t_c
    dt = t_end - tc
    pos, vel = [], []
    for r_a, delta in [(upd.r1, upd.delta1), (upd.r2, upd.delta2)]:
        r_b = r_a + upd.V * tc + 0.5 * gravity * tc**2
        v_b = upd.V + gravity * tc + delta
        pos.append(r_b + v_b * dt + 0.5 * gravity * dt**2)
        vel.append(v_b + gravity * dt)
    return tc, pos, vel, upd


LAB_CASES = [
    (LinearDashpot(k=1e4, gamma=0.0), 1.0),
    (LinearDashpot(k=1e4, gamma=20.0), 1.0),
    (LinearDashpot(k=500.0, gamma=8.0), 3.0),  # very soft: Lambda ~ 0.1
    (Hertz(young=1e6, poisson=0.3, A=0.0), 1.0),
    (Hertz(young=1e6, poisson=0.3, A=1e-3), 1.0),
    (Hertz(young=600.0, poisson=0.3, A=2e-2), 2.0),  # very soft: Lambda ~ 0.13, delta ~ 0.35
]


@pytest.mark.parametrize("contact, speed", LAB_CASES, ids=[f"{c.name}-{i}" for i, (c, _s) in enumerate(LAB_CASES)])
@pytest.mark.parametrize("gravity", [False, True], ids=["free", "gravity"])
def test_t11_lab_frame_update_matches_direct_integration(contact, speed, gravity, dim, rng):
    m = (1.0, 2.5)
    R = (0.5, 0.8)
    G = np.array([0.0, -9.81, 0.0]) if gravity else np.zeros(3)
    for b in [0.0, 0.3, 0.7, 0.95]:
        r0, v0 = random_contact(rng, dim, R, speed, b)
        tc_e, pos_e, vel_e, upd = emd_star_two_spheres(contact, m, R, r0, v0, G, 1.0)
        t_end = 3 * tc_e
        tc_e, pos_e, vel_e, upd = emd_star_two_spheres(contact, m, R, r0, v0, G, t_end)
        tc_d, pos_d, vel_d = direct_two_spheres(contact, m, R, r0, v0, G, t_end)
        assert tc_e == pytest.approx(tc_d, rel=1e-8)
        for k in range(2):
            assert np.max(np.abs(pos_e[k] - pos_d[k])) < 1e-8 * (R[0] + R[1])
            assert np.max(np.abs(vel_e[k] - vel_d[k])) < 1e-8 * speed
            if dim == 2:
                assert pos_e[k][2] == 0.0 and vel_e[k][2] == 0.0


def test_t12_conservation(rng):
    # momentum exact; energy after B = 1/2 M V^2 + 1/2 mu (eps^2 v_n^2 + v_t^2 / D^2); angular momentum
    contact = Hertz(young=1e5, poisson=0.3, A=1e-3)
    m, R = (1.0, 2.5), (0.5, 0.8)
    r0, v0 = random_contact(rng, 3, R, 1.0, 0.6)
    _tc, _pos, _vel, upd = emd_star_two_spheres(contact, m, R, r0, v0, np.zeros(3), 1.0)
    M, mu = m[0] + m[1], m[0] * m[1] / (m[0] + m[1])
    np.testing.assert_allclose(m[0] * upd.delta1 + m[1] * upd.delta2, 0.0, atol=1e-15)
    np.testing.assert_allclose(M * upd.V, m[0] * v0[0] + m[1] * v0[1], rtol=1e-14)
    res = collide(contact, m[0], m[1], R[0], R[1], upd.v_n, upd.v_t)
    e_after = 0.5 * m[0] * np.sum((upd.V + upd.delta1) ** 2) + 0.5 * m[1] * np.sum((upd.V + upd.delta2) ** 2)
    expected = 0.5 * M * upd.V @ upd.V + 0.5 * mu * (res.eps_hat**2 * upd.v_n**2 + upd.v_t**2 / res.D**2)
    assert e_after == pytest.approx(expected, rel=1e-13)
    # r' x rdot' = sigma v_t e_z = r x rdot at contact (central force)
    L0 = np.cross(r0[0] - r0[1], v0[0] - v0[1])
    L1 = np.cross(upd.r1 - upd.r2, upd.delta1 - upd.delta2)
    np.testing.assert_allclose(L1, L0, rtol=1e-12, atol=1e-14)


def test_lab_frame_update_checks_its_input():
    res = solve("dashpot", 0.0, 0.01)
    with pytest.raises(ContactError, match="must touch"):
        lab_frame_update([0, 0, 0], [2, 0, 0], [1, 0, 0], [0, 0, 0], 1, 1, 0.5, 0.5, res)
    with pytest.raises(ContactError, match="approach"):
        lab_frame_update([0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 0], 1, 1, 0.5, 0.5, res)
    with pytest.raises(ContactError, match="same dimension"):
        lab_frame_update([0, 0], [1, 0, 0], [1, 0, 0], [0, 0, 0], 1, 1, 0.5, 0.5, res)


def test_examples_in_docstrings():
    assert doctest.testmod(edmd.physics.twobody, raise_on_error=False).failed == 0
