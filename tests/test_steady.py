"""Steady-state averages and profiles (``edmd.analysis.steady``)."""

import math

import numpy as np
import pytest

import edmd
from edmd.analysis import Profile, SteadyState, blocking_errors


def ar1(n, phi, seed):
    """x_t = phi x_{t-1} + e_t, unit-variance innovations, started in its stationary state."""
    rng = np.random.default_rng(seed)
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0] / math.sqrt(1 - phi * phi)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    return x


@pytest.mark.parametrize("phi", [0.0, 0.9])
def test_blocking_finds_the_standard_error_of_correlated_data(phi):
    n = 2**16
    x = ar1(n, phi, seed=3)
    # exact standard error of the mean of an AR(1) series (large n): sigma_x sqrt((1 + phi)/((1 - phi) n))
    exact = math.sqrt(1 / (1 - phi * phi)) * math.sqrt((1 + phi) / ((1 - phi) * n))
    s = SteadyState().compute_series(np.arange(n) * 0.1, x)
    assert s.samples == n and s.converged
    # the estimate is uncertain by ~1/sqrt(2 * 15) = 18 % at 16 blocks, and the max over levels leans high
    assert s.error == pytest.approx(exact, rel=0.3)
    naive = x.std(ddof=1) / math.sqrt(n)
    if phi > 0:
        assert s.error > 3 * naive  # correlations make the naive error 4.4x too small here


def test_settle_and_short_series():
    time = np.arange(100.0)
    values = np.where(time < 20, 100.0, 1.0) + 0.01 * np.sin(time)
    s = SteadyState(settle=20.0, min_blocks=8).compute_series(time, values)
    assert s.mean == pytest.approx(1.0, abs=0.01) and s.samples == 80
    with pytest.raises(ValueError, match="30 samples after settle = 70.0: the error estimate needs at least 32"):
        SteadyState(settle=70.0).compute_series(time, values)
    assert blocking_errors(np.ones(5))[0].tolist() == [5, 2]


def test_steady_state_of_a_thermo_table_and_a_missing_column():
    table = {"time": np.arange(64.0), "temperature": np.ones(64), "pressure": np.ones(64)}
    s = SteadyState().compute(table, "temperature")
    assert s.mean == 1.0 and s.error == 0.0
    with pytest.raises(ValueError, match="no column 'kinetic'"):
        SteadyState().compute(table, "kinetic")


@pytest.mark.parametrize("dim", [2, 3])
def test_profile_recovers_density_temperature_and_drift(dim):
    rng = np.random.default_rng(5)
    n, box = 40000, 20.0
    frames = []
    for _ in range(2):
        pos = rng.uniform(-box / 2, box / 2, size=(n, dim))
        height = pos[:, -1] / box + 0.5  # 0 at the bottom, 1 at the top
        kT = 1.0 + height  # a temperature gradient along the last axis
        vel = rng.normal(size=(n, dim)) * np.sqrt(kT)[:, None]
        vel[:, 0] += 0.3  # a uniform drift along x
        frames.append(edmd.State(position=pos, velocity=vel, radius=0.001, mass=1.0, box=[box] * dim, check_overlaps=False))
    axis = "xyz"[dim - 1]
    p = Profile(axis, bins=5).compute(frames)
    assert p.frames == 2 and p.counts.sum() == 2 * n
    assert np.allclose(p.density, n / box**dim, rtol=0.05)  # ~8000 per bin per frame: 1 %
    assert np.allclose(p.temperature, 1.0 + (p.centres / box + 0.5), rtol=0.03)  # +-0.1 spread within a bin
    assert np.allclose(p.velocity[:, 0], 0.3, atol=0.03) and np.allclose(p.velocity[:, 1:], 0.0, atol=0.03)


def test_profile_refuses_a_missing_axis_and_bad_bins():
    with pytest.raises(ValueError, match="a 2D system has no z axis"):
        Profile("z").compute(edmd.lattice(36, 0.2, dim=2))
    with pytest.raises(ValueError, match="axis must be 'x', 'y' or 'z'"):
        Profile("w")
    with pytest.raises(ValueError, match="bins must be a positive integer"):
        Profile("x", bins=0)


def test_profile_of_a_granular_column_thins_out_with_height():
    state = edmd.maxwell_boltzmann(edmd.lattice(512, 0.1, periodic=[True, True, False]), 1.0, seed=2)
    sim = edmd.Simulation(state, collision=edmd.collide.TC(edmd.collide.Inelastic(0.9), 1e-3), gravity=[0, 0, -1.0], thermostat=edmd.Andersen(kT=1.0, rate=0.5, seed=1))
    frames = []
    sim.run(until_time=10.0)
    for _ in range(20):
        sim.run(until_time=sim.time + 1.0)
        frames.append(sim.state)
    p = Profile("z", bins=6).compute(frames)
    assert p.density[0] > 2 * p.density[-1]  # the bath keeps the column hot; gravity makes it thin out
