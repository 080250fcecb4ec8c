"""The sums over particles of ``_core/snapshot.py`` (what a thermo row reads), against exactly
rounded sums (``math.fsum``) of a copy of the state."""

import math

import numpy as np
import pytest

import edmd
from edmd._core.snapshot import S_MASS, S_MASS_HEIGHT, S_PX, S_TWICE_KINETIC, S_TWICE_SPIN
from edmd.physics.collide import Rough
from edmd.physics.emdstar import EMDStar
from edmd.state import StateView


def _close(got, exact, terms):
    """``got`` within 4 units of round-off of ``exact``, relative to the sum of the terms' sizes
    (Neumaier's bound is 2 units of ``|exact|`` plus O(N eps^2) of that)."""
    return abs(got - exact) <= 4e-16 * math.fsum(np.abs(terms)) + 1e-300


def _check(sums, mass, c, u, spin2=None, inertia=None, height=None):
    assert _close(sums[S_MASS], math.fsum(mass), mass)
    for k in range(c.shape[1]):
        assert _close(sums[S_PX + k], math.fsum(mass * c[:, k]), mass * c[:, k]), k
    kinetic = mass * ((c - u) ** 2).sum(axis=1)
    assert _close(sums[S_TWICE_KINETIC], math.fsum(kinetic), kinetic)
    if spin2 is not None:
        assert _close(sums[S_TWICE_SPIN], math.fsum(inertia * spin2), inertia * spin2)
    if height is not None:
        assert _close(sums[S_MASS_HEIGHT], math.fsum(mass * height), mass * height)


def test_rough_spheres_under_gravity_sum_to_the_exactly_rounded_values(dim):
    periodic = [True] * (dim - 1) + [False]
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.2, dim=dim, seed=3, periodic=periodic, radius={"kind": "discrete", "values": [0.5, 0.8], "fractions": [0.5, 0.5]}), 1.0, seed=4, spin=True)
    g = np.zeros(dim)
    g[-1] = -1.0
    sim = edmd.Simulation(s, collision=Rough(e_n=0.9, beta=0.3), gravity=g)
    sim.run(until_time=1.7)  # (particles at their own local times: the sums stream them)
    state = sim.state
    u = np.array([0.3, -0.2, 0.1][:dim])
    sums = sim._engine.sums(sim.time, u, 0.0, g)
    w2 = state.angular_velocity**2 if dim == 2 else (state.angular_velocity**2).sum(axis=1)
    assert w2.any() and state.image[:, 0].any()  # (spins and images to count)
    _check(sums, state.mass, state.velocity, u, w2, state.inertia, state.unwrapped_position @ g)
    assert sim.state_view().potential_energy(g) == -sums[S_MASS_HEIGHT]


def test_pending_soft_contacts_are_summed_with_their_committed_velocities(dim):
    s = edmd.maxwell_boltzmann(edmd.lattice(200, 0.3, dim=dim), 1.0, seed=4)
    sim = edmd.Simulation(s, collision=EMDStar(edmd.LinearDashpot(k=500.0, gamma=8.0)))
    sim.run(max_events=3000)
    state = sim.state
    assert state.has_pending  # (a soft gas with contacts under way)
    sums = sim._engine.sums(sim.time)
    _check(sums, state.mass, state.committed_velocity, np.zeros(dim))
    assert not _close(sums[S_TWICE_KINETIC], math.fsum(state.mass * (state.velocity**2).sum(axis=1)), state.mass)


def test_a_sheared_view_sums_the_peculiar_velocities(dim):
    shear = edmd.Shear(rate=0.5)
    s = edmd.maxwell_boltzmann(edmd.lattice(256, 0.3, dim=dim), 1.0, seed=5)
    sim = edmd.Simulation(shear.with_profile(s), shear=shear)
    sim.run(until_time=2.3)
    view = shear.peculiar_state(sim.state_view())
    state = shear.peculiar_state(sim.state)
    assert isinstance(view, StateView) and np.array_equal(view.velocity, state.velocity)
    _check(sim._engine.sums(sim.time, flow=0.5), state.mass, state.velocity, np.zeros(dim))
    scale = float(np.sum(state.mass[:, None] * np.abs(state.velocity)))
    assert np.allclose(view.momentum(), state.momentum(), rtol=0.0, atol=1e-14 * scale)
    assert view.temperature() == pytest.approx(state.temperature(), rel=1e-13)
    assert view.kinetic_energy() == pytest.approx(state.kinetic_energy(), rel=1e-13)
