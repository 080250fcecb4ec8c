"""Collision rules against physics.md §2 worked examples (W2-W4, T4-T7) and conservation laws."""

import math

import numpy as np
import pytest

from edmd import collide
from edmd._core import layout as L
from edmd._core.collide import collide_pair, collide_wall

BOX = np.array([100.0, 100.0, 100.0])
GEO = L.make_geo(BOX, 0.5 * BOX)


class Pair:
    """Two particles and the core's parameter arrays for one rule."""

    def __init__(self, r, v, m=(1.0, 1.0), R=(0.5, 0.5), w=None, q=0.4, rule=None, wall=None):
        self.P = np.zeros((2, L.ROW))
        self.P[:, :3] = r
        self.P[:, 3:6] = v
        self.P[:, L.R] = R
        self.mass = np.array(m, float)
        self.inertia = q * self.mass * np.array(R) ** 2
        self.omega = np.zeros((2, 3)) if w is None else np.array(w, float)
        self.tlast = np.full(2, -np.inf)
        self.fp = np.zeros(L.N_FP)
        self.ip = np.zeros(L.N_IP, np.int64)
        collide.pack(rule or collide.Inelastic(1.0), wall or collide.Wall(), self.fp, self.ip)
        self.etab = collide.viscoelastic_table()[0]
        self.acc = np.zeros(L.N_ACC)
        self.cnt = np.zeros(L.N_COUNTERS, np.int64)

    def collide(self, t=0.0):
        return collide_pair(t, self.P, self.mass, self.omega, self.inertia, self.tlast, 0, 1, GEO, self.fp, self.ip, self.etab, self.acc, self.cnt, self.ip[L.IP_TANGENT], self.ip[L.IP_NORMAL])

    def wall(self, axis, face, t=0.0):
        collide_wall(t, self.P, self.mass, self.omega, self.inertia, self.tlast, 0, axis, face, GEO, self.fp, self.ip, self.etab, self.acc, 0.0)

    def energy(self):
        trans = 0.5 * self.mass @ (self.P[:, 3:6] ** 2).sum(axis=1)
        return trans + 0.5 * self.inertia @ (self.omega**2).sum(axis=1)

    def momentum(self):
        return self.mass @ self.P[:, 3:6]

    def angular_momentum(self):
        orbital = sum(self.mass[k] * np.cross(self.P[k, :3], self.P[k, 3:6]) for k in range(2))
        return orbital + self.inertia @ self.omega


@pytest.mark.parametrize("e_n, v1, v2, dE", [(0.8, -2.05, 0.35, -1.215), (1.0, -2.5, 0.5, 0.0)])
def test_w2_t4_unequal_masses(e_n, v1, v2, dE):
    # physics.md W2 / T4: m = (1, 3), v = (2, -1), r2 - r1 = (1, 0, 0); e_n = 1 is the elastic case
    p = Pair([[0, 0, 0], [1, 0, 0]], [[2, 0, 0], [-1, 0, 0]], m=(1.0, 3.0), rule=collide.Inelastic(e_n))
    vn, vt = p.collide()
    assert p.P[0, 3:6] == pytest.approx([v1, 0, 0], abs=1e-14)
    assert p.P[1, 3:6] == pytest.approx([v2, 0, 0], abs=1e-14)
    assert p.acc[L.A_KE] == pytest.approx(dE, abs=1e-14)
    assert p.acc[L.A_DISSIPATED] == pytest.approx(-dE, abs=1e-14)
    assert (vn, vt) == (3.0, 0.0)
    assert p.acc[L.A_VIRIAL] == pytest.approx(1.0 * (1 + e_n) * 0.75 * 3.0, rel=1e-14)  # sigma (1+e) mu |g.n|


def test_t5_oblique_elastic_equal_masses():
    p = Pair([[0, 0, 0], [np.sqrt(3) / 2, 0.5, 0]], [[1, 0, 0], [0, 0, 0]])
    p.collide()
    assert p.P[0, 3:6] == pytest.approx([0.25, -0.4330127, 0], abs=1e-7)
    assert p.P[1, 3:6] == pytest.approx([0.75, 0.4330127, 0], abs=1e-7)


def test_w4_t6_rough_worked_example():
    p = Pair([[0, 0, 0], [1, 0, 0]], [[1, 0.5, 0], [0, 0, 0]], w=[[0, 0, 2], [0, 0, 0]], rule=collide.Rough(0.9, beta=0.5))
    p.collide()
    assert p.P[0, 3:6] == pytest.approx([0.05, 0.1785714, 0], abs=1e-7)
    assert p.P[1, 3:6] == pytest.approx([0.95, 0.3214286, 0], abs=1e-7)
    assert p.omega[0] == pytest.approx([0, 0, 0.3928571], abs=1e-7)
    assert p.omega[1] == pytest.approx([0, 0, -1.6071429], abs=1e-7)


def test_e_t_is_minus_beta():
    a = Pair([[0, 0, 0], [1, 0, 0]], [[1, 0.5, 0], [0, 0, 0]], w=[[0, 0, 2], [0, 0, 0]], rule=collide.Rough(0.9, e_t=-0.5))
    a.collide()
    assert a.P[0, 3:6] == pytest.approx([0.05, 0.1785714, 0], abs=1e-7)


def _random_pair(rng, dim, rule):
    n = rng.normal(size=3)
    n[dim:] = 0
    n /= np.linalg.norm(n)
    R = rng.uniform(0.2, 1.0, 2)
    m = rng.uniform(0.1, 5.0, 2)
    v = rng.normal(size=(2, 3))
    v[:, dim:] = 0
    if (v[0] - v[1]) @ n >= 0:
        v = v[::-1].copy()
    w = rng.normal(size=(2, 3))
    if dim == 2:
        w[:, :2] = 0
    rj = rng.normal(size=3) * [1, 1, dim == 3]
    p = Pair([rj + n * R.sum(), rj], v, m=m, R=R, w=w, q=rng.uniform(0.2, 0.7), rule=rule)
    return p, n


@pytest.mark.parametrize(
    "rule",
    [
        collide.Rough(1.0, beta=-1.0),
        collide.Rough(1.0, beta=1.0),
        collide.Rough(0.8, beta=-1.0),
        collide.Rough(0.8, beta=0.3),
        collide.Rough(0.5, beta=0.0),
        collide.Rough(0.9, beta=-0.5),
        collide.Inelastic(0.7),
    ],
    ids=lambda r: f"{type(r).__name__}-{r.e_n}-{getattr(r, 'beta', 's')}",
)
def test_t7_random_collisions(rng, dim, rule):
    """Restitution relations, momentum, total angular momentum, energy-loss formula to 1e-13."""
    e_n = rule.e_n
    beta = getattr(rule, "beta", -1.0)
    for _ in range(200):
        p, n = _random_pair(rng, dim, rule)
        before_P, before_w = p.P.copy(), p.omega.copy()
        E0, P0, L0 = p.energy(), p.momentum(), p.angular_momentum()
        p.collide()

        def contact(P, w):
            R = P[:, L.R]
            g = P[0, 3:6] - P[1, 3:6] - np.cross(R[0] * w[0] + R[1] * w[1], n)
            gn = (g @ n) * n
            return gn, g - gn

        gn0, gt0 = contact(before_P, before_w)
        gn1, gt1 = contact(p.P, p.omega)
        scale = 1 + np.abs(gt0).max() + np.abs(gn0).max()
        assert np.allclose(gn1, -e_n * gn0, atol=1e-13 * scale)
        if isinstance(rule, collide.Rough):
            assert np.allclose(gt1, -beta * gt0, atol=1e-13 * scale)
        assert np.allclose(p.momentum(), P0, atol=1e-13 * (1 + np.abs(P0).max() + p.mass.sum()))
        assert np.allclose(p.angular_momentum(), L0, atol=1e-12 * (1 + np.abs(L0).max()))
        mu = p.mass.prod() / p.mass.sum()
        inv_mt = 1 / mu + (p.P[:, L.R] ** 2 / p.inertia).sum()
        dE = -0.5 * mu * (1 - e_n**2) * (gn0 @ gn0)
        if isinstance(rule, collide.Rough):
            dE -= 0.5 / inv_mt * (1 - beta**2) * (gt0 @ gt0)
        assert p.energy() - E0 == pytest.approx(dE, abs=1e-13 * E0)
        assert p.acc[L.A_DISSIPATED] == pytest.approx(-dE, abs=1e-13 * E0)
        if dim == 2:
            assert np.all(p.P[:, 5] == 0.0) and np.all(p.omega[:, :2] == 0.0)  # stays in the plane


def test_coulomb_limits_the_tangential_impulse(rng, dim):
    rule = collide.Rough(0.8, beta=0.6, mu=0.2)
    sliding = 0
    for _ in range(300):
        p, n = _random_pair(rng, dim, rule)
        before = p.P[:, 3:6].copy()
        E0, P0 = p.energy(), p.momentum()
        p.collide()
        J = p.mass[0] * (p.P[0, 3:6] - before[0])
        Jn = (J @ n) * n
        Jt = J - Jn
        assert np.linalg.norm(Jt) <= 0.2 * np.linalg.norm(Jn) * (1 + 1e-12) or np.linalg.norm(Jt) < 1e-14
        sliding += np.isclose(np.linalg.norm(Jt), 0.2 * np.linalg.norm(Jn), rtol=1e-9)
        assert np.allclose(p.momentum(), P0, atol=1e-12 * (1 + p.mass.sum()))
        assert p.energy() <= E0 * (1 + 1e-14)
    assert sliding > 100  # most random collisions slide (physics.md §2.3: 84 %)


def test_tc_model_makes_recent_colliders_elastic():
    rule = collide.TC(collide.Rough(0.5, beta=0.0), duration=1e-3)
    p = Pair([[0, 0, 0], [1, 0, 0]], [[1, 0.5, 0], [0, 0, 0]], w=[[0, 0, 2], [0, 0, 0]], rule=rule)
    p.tlast[1] = -5e-4  # partner collided 0.5 ms ago
    E0 = p.energy()
    p.collide(t=0.0)
    assert p.energy() == pytest.approx(E0, rel=1e-14)  # elastic and smooth
    assert p.cnt[L.C_TC_ELASTIC] == 1
    assert p.tlast.tolist() == [0.0, 0.0]
    q = Pair([[0, 0, 0], [1, 0, 0]], [[1, 0.5, 0], [0, 0, 0]], w=[[0, 0, 2], [0, 0, 0]], rule=rule)
    q.tlast[:] = -2e-3  # long ago: the rough inelastic rule applies (W4 with e_n = 0.5, beta = 0)
    q.collide(t=0.0)
    assert q.energy() < E0


@pytest.mark.parametrize("vn", [0.1, 1.0, 10.0])
def test_viscoelastic_restitution_w9(vn):
    # physics.md W9: glass-like 1 mm spheres, A = 1e-7 s: e_n = 0.946132, 0.916405, 0.871862
    glass = collide.Viscoelastic(young=63e9, poisson=0.2, A=1e-7)
    m = 2500 * 4 / 3 * np.pi * 1e-9
    p = Pair([[0, 0, 0], [2e-3, 0, 0]], [[vn, 0, 0], [0, 0, 0]], m=(m, m), R=(1e-3, 1e-3), rule=glass)
    p.collide()
    e = -(p.P[0, 3] - p.P[1, 3]) / vn
    expected = {0.1: 0.946132, 1.0: 0.916405, 10.0: 0.871862}[vn]
    assert e == pytest.approx(expected, abs=2e-6)
    assert glass.restitution(vn, m / 2, 0.5e-3) == pytest.approx(e, rel=1e-12)


@pytest.mark.parametrize("delta, eps", [(0.001, 0.99884736), (0.05, 0.94439678), (0.5, 0.59525150), (2.0, 0.21164605), (10.0, 0.02509570)])
def test_viscoelastic_table_matches_physics_md(delta, eps):
    from edmd._core.collide import eps_viscoelastic

    coeffs, inv = collide.viscoelastic_table()
    assert eps_viscoelastic(delta, coeffs, inv) == pytest.approx(eps, abs=2e-8)


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("face", [0, 1])
def test_walls_reflect_smooth_and_rough(axis, face):
    sign = 1.0 if face == 0 else -1.0  # inward normal
    v = np.zeros((2, 3))
    v[0] = [0.3, -0.2, 0.4]
    v[0, axis] = -sign * 2.0  # moving into the wall
    p = Pair([[0, 0, 0], [10, 10, 10]], v, rule=collide.Inelastic(1.0), wall=collide.Wall(e_n=0.7))
    p.wall(axis, face)
    expected = v[0].copy()
    expected[axis] = sign * 1.4
    assert p.P[0, 3:6] == pytest.approx(expected, abs=1e-15)
    assert p.acc[L.A_WALL + 2 * axis + face] == pytest.approx(1.0 * 3.4, rel=1e-14)
    # a rough sticking wall (beta = 0) stops the contact point: v_t = R w x n at the end
    r = Pair([[0, 0, 0], [10, 10, 10]], v, w=[[1.0, -2.0, 0.5], [0, 0, 0]], wall=collide.Wall(e_n=0.7, beta=0.0))
    r.wall(axis, face)
    n = np.zeros(3)
    n[axis] = sign
    gc = r.P[0, 3:6] - np.cross(0.5 * r.omega[0], n)
    assert gc - (gc @ n) * n == pytest.approx(np.zeros(3), abs=1e-14)


@pytest.mark.parametrize(
    "bad, match",
    [
        (lambda: collide.Inelastic(1.2), "e_n must be a number in"),
        (lambda: collide.Rough(0.9, beta=1.5), "beta must be a number in"),
        (lambda: collide.Rough(0.9, beta=0.1, e_t=0.1), "either beta or e_t"),
        (lambda: collide.Rough(0.9, mu=-1.0), "Coulomb friction"),
        (lambda: collide.Viscoelastic(young=-1.0, poisson=0.3, A=0.0), "Young's modulus"),
        (lambda: collide.Viscoelastic(young=1e9, poisson=0.7, A=0.0), "Poisson ratio"),
        (lambda: collide.TC(collide.Inelastic(0.5), duration=0.0), "TC duration"),
        (lambda: collide.Wall(e_n=math.nan), "e_n must be a number in"),
    ],
)
def test_bad_parameters_are_named(bad, match):
    with pytest.raises(collide.RuleError, match=match):
        bad()
