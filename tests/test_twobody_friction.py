"""The frictional two-body solver (docs/physics.md §4.11) against an independent integration of
the same laws in lab Cartesian coordinates (scipy), its limits (smooth map, perfect sticking),
conservation laws, and the DEM."""

import math
import zlib

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import edmd
from edmd.physics.contact import ContactError, Hertz, LinearDashpot
from edmd.physics.friction import Friction
from edmd.physics.twobody import collide, collide_frictional, lab_frame_update

# ---------------------------------------------------------------------------------------------
# the reference: both particles in lab coordinates, unscaled, derivatives by complex steps


class Reference:
    """The contact of docs/physics.md §2.6 for two particles (state: x1, x2, v1, v2, w1, w2, z or S).

    Everything a mode needs besides the forces (the rate of the trial force, the rate of the
    normal force) is differentiated along the trajectory by a complex step, which is exact to
    round-off: no derivative is written by hand here.
    """

    def __init__(self, contact, friction, m, R, I):
        self.model = contact.code
        self.a, self.b = contact.constants()
        self.law, self.kt, self.xt, self.mu = friction.constants(contact)
        self.m, self.R, self.I = m, R, I
        self.sigma = R[0] + R[1]
        self.reff = R[0] * R[1] / self.sigma

    def parts(self, y):
        """Normal, spring stiffness, tangential damping and sliding velocity at state ``y`` (complex-safe)."""
        x1, x2, v1, v2, w1, w2 = (y[3 * k : 3 * k + 3] for k in range(6))
        r = x1 - x2
        d = np.sqrt(r @ r)
        n = r / d
        xi = self.sigma - d
        g = v1 - v2
        xi_dot = -(g @ n)
        root = np.sqrt(xi) if np.real(xi) > 0 else 0 * xi  # (the solver too continues the law by 0 at xi <= 0)
        if self.model == 1:  # Hertz
            rho = self.a * math.sqrt(self.reff)
            fn = rho * root * (xi + self.b * xi_dot)
            eta_n = rho * root * self.b
        else:
            fn = self.a * xi + self.b * xi_dot
            eta_n = self.b + 0 * xi
        k = self.kt * (math.sqrt(self.reff) * root if self.law == 2 else 1.0)
        arm1, arm2 = self.R[0] - xi / 2, self.R[1] - xi / 2
        vc = g - np.cross(arm1 * w1 + arm2 * w2, n)
        vt = vc - (vc @ n) * n
        ndot = (g - (g @ n) * n) / d
        return fn, n, k, self.xt * eta_n, vt, ndot, (arm1, arm2), xi + (self.b * xi_dot if self.model == 1 else self.b / self.a * xi_dot)

    def forces(self, y, mode):
        fn, n, k, eta, vt, ndot, arms, _end = self.parts(y)
        z = y[18:21]
        if mode == "stick":
            ft = -k * z - eta * vt
        else:
            ft = self.mu * fn * z / np.sqrt(z @ z)
        return fn, n, ft, arms

    def mechanics(self, y, ft, fn, n, arms):
        """Derivatives of x, v, w (18 numbers) under the normal and tangential forces."""
        force = fn * n + ft
        torque = np.cross(n, ft)
        return np.concatenate([y[6:9], y[9:12], force / self.m[0], -force / self.m[1], -arms[0] / self.I[0] * torque, -arms[1] / self.I[1] * torque])

    def along(self, fun, y, dy, h=1e-30):
        """d/dt fun(y(t)) for y' = dy, by a complex step."""
        return np.imag(fun(y + 1j * h * dy)) / h

    def rhs(self, t, y, mode):
        fn, n, ft, arms = self.forces(y, mode)
        dy = np.zeros(21)
        dy[:18] = self.mechanics(y, ft, fn, n, arms)
        _fn, _n, k, eta, vt, ndot, _a, _e = self.parts(y)
        z = y[18:21]
        if mode == "stick":
            dy[18:21] = vt - (ndot @ z) * n
            return dy
        if mode == "frozen":
            return dy
        s = z / np.sqrt(z @ z)
        q = self.trial_rate(y, dy, ft)
        q = q - (q @ n) * n
        dfn = self.along(lambda u: self.parts(u)[0], y, dy)
        dy[18:21] = self.mu * dfn * s + (q - (q @ s) * s) - (ndot @ z) * n
        return dy

    def trial_rate(self, y, dy, ft):
        """Rate of the trial force -k z - eta v_t with the spring at the limit and growing at v_t."""
        _fn, n, k, eta, vt, ndot, _a, _e = self.parts(y)
        z = -(ft + eta * vt) / k
        dk = self.along(lambda u: self.parts(u)[2], y, dy)
        deta = self.along(lambda u: self.parts(u)[3], y, dy)
        dvt = self.along(lambda u: self.parts(u)[4], y, dy)
        return -dk * z - k * (vt - (ndot @ z) * n) - deta * vt - eta * dvt

    def switch_function(self, y, mode):
        """Positive while the mode holds, scaled into [-1, 1] (as the solver's)."""
        fn, n, ft, arms = self.forces(y, mode)
        if mode == "stick":
            lim, f = self.mu * max(fn, 0.0), np.sqrt(ft @ ft)  # (past the end, where steps may reach, no limit)
            return (lim - f) / (lim + f) if lim + f > 0 else 1.0
        dy = self.rhs(0.0, y, mode)
        s = y[18:21] / np.sqrt(y[18:21] @ y[18:21])
        qs = self.trial_rate(y, dy, ft) @ s
        dl = self.mu * self.along(lambda u: self.parts(u)[0], y, dy)
        return (qs - dl) / (abs(qs) + abs(dl))

    def to_other_mode(self, y, mode):
        fn, n, k, eta, vt, _nd, _a, _e = self.parts(y)
        y = y.copy()
        if mode == "stick":  # S: the force at the Coulomb limit along the trial force
            trial = -k * y[18:21] - eta * vt
            y[18:21] = self.mu * fn * trial / np.sqrt(trial @ trial)
            return y, "slide"
        ft = self.mu * fn * y[18:21] / np.sqrt(y[18:21] @ y[18:21])
        y[18:21] = -(ft + eta * vt) / k
        return y, "stick"

    def events(self, mode):
        """The end of the contact and the end of the mode, as scipy terminal events (falling through zero)."""

        def end(t, u):  # sliding stops just short of the end: there the force's direction turns ever faster
            return self.parts(u)[7] - (self.short if mode == "slide" else 0.0)

        def flip(t, u):
            return self.switch_function(u, mode)

        for e in (end, flip):
            e.terminal, e.direction = True, -1
        return [end] if mode == "frozen" else [end, flip]

    def integrate(self, y0, t_max):
        """From first touch to the end of the contact; returns the final state and the duration."""
        eps = 1e-12 * t_max
        self.short = 5e-8 * np.abs(y0[6:12]).max() * t_max  # 1e-6 of the overlap scale: a force of that size, frozen, gives impulses ~1e-12
        probe = y0 + eps * self.rhs(0.0, y0, "stick")  # a moment after the touch
        mode, y, t = "stick", y0.copy(), 0.0
        if self.switch_function(probe, "stick") < 0.0:  # sliding from the start (from eps on)
            y, mode = self.to_other_mode(probe, "stick")
            t = eps
        for _ in range(50):
            if mode != "frozen" and self.switch_function(y, mode) < -1e-9:
                y, mode = self.to_other_mode(y, mode)
            with np.errstate(invalid="ignore", divide="ignore"):  # (the event search samples past the end of the
                # contact, where a Mindlin spring has k = 0 and the switch function is 0/0; the end event comes first there)
                sol = solve_ivp(lambda t, u: self.rhs(t, u, mode), (t, t_max), y, method="DOP853", rtol=1e-13, atol=1e-15 * np.abs(y0).max(), events=self.events(mode))
            t, y = sol.t[-1], sol.y[:, -1]
            assert sol.status == 1, sol.message
            if sol.t_events[0].size and mode != "slide":
                return y, t
            if sol.t_events[0].size:  # the last 1e-6 of the overlap with the force's direction kept: an error ~1e-12
                mode = "frozen"
                continue
            y, mode = self.to_other_mode(y, mode)
        raise AssertionError("too many switches")


def reference(contact, friction, x1, x2, v1, v2, w1, w2, m, R, dim):
    q = 0.4 if dim == 3 else 0.5
    I = [q * m[0] * R[0] ** 2, q * m[1] * R[1] ** 2]
    ref = Reference(contact, friction, m, R, I)
    pad = lambda a: np.r_[a, np.zeros(3 - len(a))]  # noqa: E731
    spin = lambda w: np.array([0.0, 0.0, w]) if dim == 2 else np.asarray(w, float)  # noqa: E731
    y0 = np.concatenate([pad(x1), pad(x2), pad(v1), pad(v2), spin(w1), spin(w2), np.zeros(3)])
    t_c = contact.central(m[0], m[1], R[0], R[1], float(np.linalg.norm(np.subtract(v1, v2)))).t_c
    y, t = ref.integrate(y0, 20 * t_c)
    return y, t


def random_collision(rng, dim):
    """Two particles touching, approaching, spinning (random masses and radii)."""
    m = rng.uniform(0.5, 2.0, 2)
    R = rng.uniform(0.3, 0.7, 2)
    e = rng.normal(size=dim)
    e /= np.linalg.norm(e)
    x1 = rng.normal(size=dim)
    x2 = x1 - (R[0] + R[1]) * e
    v2 = rng.normal(size=dim)
    g = rng.normal(size=dim)
    g -= (g @ e + rng.uniform(0.5, 1.5)) * e  # approaching at normal speed 0.5-1.5
    v1 = v2 + g
    w = rng.normal(size=(2, 3)) * 2.0
    w1, w2 = (float(w[0, 2]), float(w[1, 2])) if dim == 2 else (w[0], w[1])
    return x1, x2, v1, v2, w1, w2, m, R


#: the scipy reference integrates these in seconds; with Hertz's normal law the sliding direction
#: relaxes at a rate ~1/t from the touch, which the explicit lab-frame integration cannot follow
#: in reasonable time: Hertz contacts are checked against the DEM below
LAWS = {
    "dashpot-linear": (LinearDashpot(k=1e5, gamma=20.0), Friction(mu=0.3, stiffness=3e4, damping=0.5)),
    "dashpot-linear-elastic": (LinearDashpot(k=1e5), Friction(mu=0.2, stiffness=2e4)),
    "dashpot-mindlin": (LinearDashpot(k=1e5, gamma=10.0), Friction(mu=0.4, law="mindlin", stiffness=3e6)),
}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law", list(LAWS))
def test_agrees_with_a_lab_frame_integration(law, dim):
    """Three random collisions per law: end velocities, spins, positions and duration agree with
    scipy's DOP853 (rtol 1e-13) on the lab-frame equations to 1e-8 (relative to the speeds)."""
    contact, friction = LAWS[law]
    rng = np.random.default_rng(zlib.crc32(f"{law} {dim}".encode()))
    switches = 0
    for _ in range(3):
        x1, x2, v1, v2, w1, w2, m, R = random_collision(rng, dim)
        end = collide_frictional(contact, friction, x1, x2, v1, v2, w1, w2, m[0], m[1], R[0], R[1], rtol=1e-12)
        y, t = reference(contact, friction, x1, x2, v1, v2, w1, w2, m, R, dim)
        speed = np.abs(np.r_[v1, v2]).max() + max(np.abs(w1).max() * R[0], np.abs(w2).max() * R[1])
        assert end.t_c == pytest.approx(t, rel=1e-8)
        got = np.concatenate([end.v1, end.v2, np.atleast_1d(end.omega1) * R[0], np.atleast_1d(end.omega2) * R[1]])
        spins = (y[14:15], y[17:18]) if dim == 2 else (y[12:15], y[15:18])
        want = np.concatenate([y[6 : 6 + dim], y[9 : 9 + dim], spins[0] * R[0], spins[1] * R[1]])
        assert np.abs(got - want).max() < 1e-8 * speed
        assert np.abs(end.r1 - y[:dim]).max() < 1e-8 * speed * t
        assert np.abs(end.r2 - y[3 : 3 + dim]).max() < 1e-8 * speed * t
        switches += end.switches
    assert switches > 0  # the cases do switch between sticking and sliding


def head_on_spinning(dim, u0, v_n=1.0):
    """Unit particles (R = 0.5) touching along x, approaching at v_n, spins about z giving the contact point the speed u0 along y."""
    w = u0  # R (w1 + w2) = u0 with w1 = w2 = u0
    spin = w if dim == 2 else [0.0, 0.0, w]
    x1, x2 = np.zeros(dim), np.zeros(dim)
    x2[0] = 1.0
    v1 = np.zeros(dim)
    v1[0] = v_n
    return x1, x2, v1, np.zeros(dim), spin, spin


@pytest.mark.parametrize("dim", [2, 3])
def test_no_friction_is_the_smooth_map(dim):
    """mu = 0: the smooth matrix of restitution and eMD* map (physics.md §4.5, §4.6) to 1e-10; spins untouched."""
    rng = np.random.default_rng(5 + dim)
    for contact in (LinearDashpot(k=1e5, gamma=30.0), Hertz(young=1e6, poisson=0.3, A=5e-4)):
        x1, x2, v1, v2, w1, w2, m, R = random_collision(rng, dim)
        end = collide_frictional(contact, Friction(mu=0.0, stiffness=1e4, damping=1.0), x1, x2, v1, v2, w1, w2, m[0], m[1], R[0], R[1], rtol=1e-12)
        n = (x1 - x2) / (R[0] + R[1])
        g = v1 - v2
        vn = -(g @ n)
        vt = float(np.linalg.norm(g + vn * n))
        res = collide(contact, m[0], m[1], R[0], R[1], vn, vt)
        u = lab_frame_update(x1, x2, v1, v2, m[0], m[1], R[0], R[1], res)
        assert end.t_c == pytest.approx(res.t_c, rel=1e-10)
        speed = np.abs(g).max()
        assert np.abs(end.v1 - (u.V + u.delta1)).max() < 1e-10 * speed
        assert np.abs(end.v2 - (u.V + u.delta2)).max() < 1e-10 * speed
        assert np.abs(end.r1 - (u.r1 + u.V * res.t_c)).max() < 1e-10 * (R[0] + R[1])
        assert np.array_equal(np.atleast_1d(end.omega1), np.atleast_1d(w1)) or np.abs(np.atleast_1d(end.omega1) - np.atleast_1d(w1)).max() < 1e-14


@pytest.mark.parametrize("dim", [2, 3])
def test_conservation(dim):
    """Momentum and angular momentum (orbital + spins, about any point) exactly; energy too when
    nothing dissipates (elastic normal law, no damping, never sliding): the kinetic energy after
    the contact plus the spring's left-over energy equals the kinetic energy before (1e-10)."""
    rng = np.random.default_rng(11 + dim)
    q = 0.4 if dim == 3 else 0.5
    cases = [(LinearDashpot(k=1e5, gamma=30.0), Friction(mu=0.3, stiffness=3e4, damping=0.5)), (LinearDashpot(k=1e5), Friction(mu=math.inf, stiffness=3e4))]
    for contact, friction in cases:
        x1, x2, v1, v2, w1, w2, m, R = random_collision(rng, dim)
        I = q * m * R**2
        end = collide_frictional(contact, friction, x1, x2, v1, v2, w1, w2, m[0], m[1], R[0], R[1], rtol=1e-12)

        def totals(r1, r2, u1, u2, o1, o2):
            p = m[0] * u1 + m[1] * u2
            if dim == 2:
                L = m[0] * (r1[0] * u1[1] - r1[1] * u1[0]) + m[1] * (r2[0] * u2[1] - r2[1] * u2[0]) + I[0] * o1 + I[1] * o2
            else:
                L = m[0] * np.cross(r1, u1) + m[1] * np.cross(r2, u2) + I[0] * np.asarray(o1) + I[1] * np.asarray(o2)
            E = 0.5 * (m[0] * u1 @ u1 + m[1] * u2 @ u2 + I[0] * np.sum(np.square(o1)) + I[1] * np.sum(np.square(o2)))
            return p, np.atleast_1d(L), E

        p0, L0, E0 = totals(x1, x2, v1, v2, w1, w2)
        p1, L1, E1 = totals(end.r1, end.r2, end.v1, end.v2, end.omega1, end.omega2)
        assert np.abs(p1 - p0).max() < 1e-12 * E0
        assert np.abs(L1 - L0).max() < 1e-10 * (np.abs(L0).max() + E0)
        if friction.mu == math.inf:
            assert not end.sliding and end.spring_energy > 1e-4 * E0
            assert E1 + end.spring_energy == pytest.approx(E0, rel=1e-10)
        else:
            assert E1 < E0


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("ratio", [0.5, 1.0, 1.5])
def test_large_friction_approaches_the_sticking_limit(dim, ratio):
    r"""mu -> inf, hard contacts (softness 5e-6), undamped: the contact point oscillates,
    :math:`u' = u_0\cos(\pi\omega_t/\omega_n)` (as in tests/test_friction.py, here without a time
    step); the departure is of order the softness."""
    x1, x2, v1, v2, w1, w2 = head_on_spinning(dim, 0.5)
    k = 2e10
    m_t = 1.0 / (2.0 + 2 * 0.25 / ((0.4 if dim == 3 else 0.5) * 0.25))
    kt = ratio**2 * k / 0.5 * m_t
    for mu, tol in ((1e3, 1e-3), (1e5, 3e-5), (math.inf, 3e-5)):  # finite mu: the spring slides off as F_n -> 0
        end = collide_frictional(LinearDashpot(k=k), Friction(mu=mu, stiffness=kt), x1, x2, v1, v2, w1, w2, 1.0, 1.0, 0.5, 0.5)
        wz = (np.atleast_1d(end.omega1)[-1], np.atleast_1d(end.omega2)[-1])
        u = (end.v1[1] - end.v2[1]) + 0.5 * (wz[0] + wz[1])
        assert u == pytest.approx(0.5 * math.cos(math.pi * ratio), abs=tol * 0.5)


DEM_CASES = {
    "hertz-mindlin": (Hertz(young=1e7, poisson=0.3, A=1e-5), Friction(mu=0.3, law="mindlin", damping=0.5)),
    "hertz-linear": (Hertz(young=1e7, poisson=0.3, A=1e-5), Friction(mu=0.3, stiffness=1e5, damping=0.5)),
}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("case", list(DEM_CASES))
def test_matches_the_dem(case, dim):
    """Hertz contacts: the DEM at 1600 steps per contact agrees with the solver to 2e-6 of the
    speeds, and 4x fewer steps are further off (order ~1.5: the sqrt onset of Hertz damping)."""
    contact, friction = DEM_CASES[case]
    x1, x2 = np.zeros(dim), np.zeros(dim)
    x2[0] = 1.0
    v1, v2 = np.array([0.5, 0.3, -0.1][:dim]), np.array([-0.5, -0.2, 0.1][:dim])
    w1, w2 = (-1.0, 0.4) if dim == 2 else ([0.4, 0.2, -1.0], [-0.2, 0.6, 0.4])
    end = collide_frictional(contact, friction, x1, x2, v1, v2, w1, w2, 1.0, 1.0, 0.5, 0.5)
    back = 1e-3  # the DEM starts before the touch and ends at the contact's end
    errors = []
    for steps in (400, 1600):
        state = edmd.State(position=[x1 - v1 * back, x2 - v2 * back], velocity=[v1, v2], angular_velocity=[w1, w2], radius=[0.5, 0.5], mass=[1.0, 1.0], box=[20.0] * dim)
        span = back + end.t_c
        sim = edmd.DEMSimulation(state, contact, friction=friction, dt=span / math.ceil(span / (end.t_c / steps)))
        sim.run(until_time=span)
        s = sim.state
        errors.append(max(np.abs(s.velocity - [end.v1, end.v2]).max(), 0.5 * np.abs(np.asarray(s.angular_velocity) - [end.omega1, end.omega2]).max()))
    assert errors[1] < 2e-6
    assert errors[1] < errors[0] / 2


@pytest.mark.parametrize("law", ["dashpot-linear", "hertz-mindlin", "hertz-linear"])
def test_accuracy_follows_the_tolerance(law):
    """At rtol 1e-6 / 1e-9 the end state agrees with rtol 1e-13 to 1e-6 / 1e-9 of the speeds, over
    random collisions with switches: also where the solver holds a small sliding force's direction
    (Hertz from the touch, every sliding contact near its end)."""
    contact, friction = {**LAWS, **DEM_CASES, "hertz-mindlin": (DEM_CASES["hertz-mindlin"][0], Friction(mu=0.3, law="mindlin"))}[law]
    rng = np.random.default_rng(zlib.crc32(law.encode()))
    for _ in range(8):
        x1, x2, v1, v2, w1, w2, m, R = random_collision(rng, 3)
        ref = collide_frictional(contact, friction, x1, x2, v1, v2, w1, w2, m[0], m[1], R[0], R[1], rtol=1e-13)
        speed = np.abs(np.r_[v1, v2]).max() + max(np.abs(w1).max() * R[0], np.abs(w2).max() * R[1])
        for rtol in (1e-6, 1e-9):
            end = collide_frictional(contact, friction, x1, x2, v1, v2, w1, w2, m[0], m[1], R[0], R[1], rtol=rtol)
            got = np.r_[end.v1, end.v2, end.omega1 * R[0], end.omega2 * R[1]] - np.r_[ref.v1, ref.v2, ref.omega1 * R[0], ref.omega2 * R[1]]
            assert np.abs(got).max() < rtol * speed


def test_a_contact_at_the_margin_of_sliding_finishes():
    """Near its end this contact's trial force tracks the shrinking Coulomb limit (sticking says
    "slide", sliding says "stick", by 1e-7): it must slide on at the limit, not flip forever at one
    instant, and agree with a solve at another tolerance."""
    contact, friction = Hertz(young=1e7, poisson=0.3, A=1e-5), Friction(mu=0.3, stiffness=1e5, damping=0.5)
    v1 = [1.1136513534513286, -0.9165392346644177, -2.019045793541647]
    w1, w2 = [-0.7883616943116903, 0.3298516141597998, -0.8859825857853795], [0.5347530670366708, 0.3885269746015548, 1.266829518034956]
    ends = [collide_frictional(contact, friction, [0, 0, 0], [1, 0, 0], v1, [0, 0, 0], w1, w2, 1.0, 1.0, 0.5, 0.5, rtol=rtol) for rtol in (1e-10, 1e-12)]
    assert ends[0].sliding
    for name in ("v1", "v2", "omega1", "omega2"):
        np.testing.assert_allclose(getattr(ends[0], name), getattr(ends[1], name), rtol=0, atol=1e-7)


def test_bad_input():
    c, f = LinearDashpot(k=1e5), Friction(mu=0.3, stiffness=1e4)
    with pytest.raises(ContactError, match="must touch"):
        collide_frictional(c, f, [0, 0, 0], [1.1, 0, 0], [1, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], 1, 1, 0.5, 0.5)
    with pytest.raises(ContactError, match="approach"):
        collide_frictional(c, f, [0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], 1, 1, 0.5, 0.5)
    with pytest.raises(ContactError, match="spin about z"):
        collide_frictional(c, f, [0, 0], [1, 0], [1, 0], [0, 0], [0, 0, 1], 0.0, 1, 1, 0.5, 0.5)
    with pytest.raises(ContactError, match="friction must be"):
        collide_frictional(c, 0.3, [0, 0], [1, 0], [1, 0], [0, 0], 0.0, 0.0, 1, 1, 0.5, 0.5)


def test_examples_in_docstrings():
    import doctest

    import edmd.physics.twobody

    assert doctest.testmod(edmd.physics.twobody).failed == 0
