"""Collision rules against physics.md §2.1 worked examples (W2/T4, W3/T5) and invariants."""

import numpy as np
import pytest

from edmd._core.collide import collide_smooth
from edmd._core.layout import A_DISSIPATED, A_KE, A_VIRIAL, N_ACC, ROW, make_geo

BOX = np.array([100.0, 100.0, 100.0])
GEO = make_geo(BOX, 0.5 * BOX)


def pair(r1, r2, v1, v2, R=(0.5, 0.5)):
    P = np.zeros((2, ROW))
    P[0, :3], P[1, :3] = r1, r2
    P[0, 3:6], P[1, 3:6] = v1, v2
    P[:, 7] = R
    return P


@pytest.mark.parametrize("e_n, v1, v2, dE", [(0.8, -2.05, 0.35, -1.215), (1.0, -2.5, 0.5, 0.0)])
def test_w2_unequal_masses(e_n, v1, v2, dE):
    # physics.md W2: m = (1, 3), v = (2, -1), r2 - r1 = (1, 0, 0); e_n = 1 is the elastic case
    P = pair([0, 0, 0], [1, 0, 0], [2, 0, 0], [-1, 0, 0])
    acc = np.zeros(N_ACC)
    vn, vt = collide_smooth(P, np.array([1.0, 3.0]), 0, 1, e_n, GEO, acc)
    assert P[0, 3:6] == pytest.approx([v1, 0, 0], abs=1e-14)
    assert P[1, 3:6] == pytest.approx([v2, 0, 0], abs=1e-14)
    assert acc[A_KE] == pytest.approx(dE, abs=1e-14)
    assert acc[A_DISSIPATED] == pytest.approx(-dE, abs=1e-14)
    assert (vn, vt) == (3.0, 0.0)
    # virial r_ij . J = sigma (1 + e) mu |g.n|
    assert acc[A_VIRIAL] == pytest.approx(1.0 * (1 + e_n) * 0.75 * 3.0, rel=1e-14)


def test_t5_oblique_elastic_equal_masses():
    # physics.md W3 / T5
    P = pair([0, 0, 0], [np.sqrt(3) / 2, 0.5, 0], [1, 0, 0], [0, 0, 0])
    collide_smooth(P, np.ones(2), 0, 1, 1.0, GEO, np.zeros(N_ACC))
    assert P[0, 3:6] == pytest.approx([0.25, -0.4330127, 0], abs=1e-7)
    assert P[1, 3:6] == pytest.approx([0.75, 0.4330127, 0], abs=1e-7)


def test_collision_through_the_periodic_boundary():
    # i near +L/2, j near -L/2: the minimum image gives the normal (+x)
    P = pair([49.6, 0, 0], [-49.4, 0, 0], [1, 0, 0], [-1, 0, 0])
    collide_smooth(P, np.ones(2), 0, 1, 1.0, GEO, np.zeros(N_ACC))
    assert P[0, 3:6] == pytest.approx([-1, 0, 0])
    assert P[1, 3:6] == pytest.approx([1, 0, 0])


def test_random_collisions_conserve_momentum_and_angular_momentum(rng, dim):
    for _ in range(500):
        n = rng.normal(size=3)
        n[dim:] = 0
        n /= np.linalg.norm(n)
        R = rng.uniform(0.2, 1.0, 2)
        m = rng.uniform(0.1, 5.0, 2)
        v = rng.normal(size=(2, 3))
        v[:, dim:] = 0
        if (v[0] - v[1]) @ n >= 0:
            v = v[::-1].copy()
        r2 = rng.normal(size=3) * [1, 1, dim == 3]
        P = pair(r2 + n * R.sum(), r2, v[0], v[1], R)
        e = rng.uniform(0.3, 1.0)
        acc = np.zeros(N_ACC)
        before = P.copy()
        collide_smooth(P, m, 0, 1, e, GEO, acc)
        p0 = m @ before[:, 3:6]
        assert np.allclose(m @ P[:, 3:6], p0, atol=1e-13 * np.abs(m[:, None] * v).sum())
        L0 = sum(m[k] * np.cross(before[k, :3], before[k, 3:6]) for k in range(2))
        L1 = sum(m[k] * np.cross(P[k, :3], P[k, 3:6]) for k in range(2))
        assert np.allclose(L1, L0, atol=1e-12 * (1 + np.abs(L0).max()))
        ke = lambda Q: 0.5 * m @ (Q[:, 3:6] ** 2).sum(axis=1)  # noqa: E731
        assert ke(P) - ke(before) == pytest.approx(acc[A_KE], abs=1e-13 * ke(before))
        g0 = (before[0, 3:6] - before[1, 3:6]) @ n
        g1 = (P[0, 3:6] - P[1, 3:6]) @ n
        assert g1 == pytest.approx(-e * g0, abs=1e-13)
        if dim == 2:
            assert np.all(P[:, 5] == 0.0)  # disks stay exactly in the plane
