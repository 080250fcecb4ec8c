"""The counter-based generator of the core (``edmd._core.rng``)."""

import math

import numpy as np
import pytest
from numba import njit

from edmd._core.rng import mix, normal_pair, stream, uniform


@njit
def _draws(seed, n, k):
    u = np.empty(n)
    g = np.empty(2 * n)
    for i in range(n):
        z = stream(seed, 7, i, 3)
        u[i] = uniform(z, k)
        g[2 * i], g[2 * i + 1] = normal_pair(z, k)
    return u, g


def test_mix_matches_splitmix64_reference():
    # SplitMix64 with state 0: its first output is mix(0x9E3779B97F4A7C15) = 0xE220A8397B1DCDAF
    assert int(njit(lambda z: mix(z))(np.uint64(0x9E3779B97F4A7C15))) == 0xE220A8397B1DCDAF


def test_uniforms_and_normals_have_the_right_moments():
    n = 200_000
    u, g = _draws(11, n, 0)
    assert u.min() >= 0.0 and u.max() < 1.0
    # standard errors: 1/sqrt(12 n) for the mean of u, sqrt(2/n) for the variance of g (5 sigma)
    assert abs(u.mean() - 0.5) < 5 / math.sqrt(12 * n)
    assert abs(g.mean()) < 5 / math.sqrt(2 * n)
    assert abs(g.var() - 1.0) < 5 * math.sqrt(2 / (2 * n))
    assert abs(np.mean(g**4) / np.mean(g**2) ** 2 - 3.0) < 0.1
    # neighbouring keys and indices are uncorrelated
    u2, _ = _draws(11, n, 1)
    assert abs(np.corrcoef(u, u2)[0, 1]) < 5 / math.sqrt(n)
    assert abs(np.corrcoef(u[:-1], u[1:])[0, 1]) < 5 / math.sqrt(n)


def test_draws_are_a_function_of_the_key_only():
    a, _ = _draws(5, 100, 2)
    b, _ = _draws(5, 100, 2)
    c, _ = _draws(6, 100, 2)
    assert np.array_equal(a, b)
    assert not np.any(a == c)


@pytest.mark.parametrize("part", range(4))
def test_each_part_of_the_key_changes_the_stream(part):
    key = [1, 2, 3, 4]
    other = list(key)
    other[part] += 1
    f = njit(lambda a, b, c, d: uniform(stream(a, b, c, d), 0))
    assert f(*key) != f(*other)
