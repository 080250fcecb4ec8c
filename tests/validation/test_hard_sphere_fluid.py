"""Equilibrium hard spheres/disks: equation of state and collision rate (physics.md §5.2, §5.3).

Reference values: Carnahan-Starling (3D) and Henderson (2D) for Z = P/(nkT) and the contact
value chi; Enskog's collision frequency omega_E = 4 n sigma^2 chi sqrt(pi T/m) (3D),
2 n sigma chi sqrt(pi T/m) (2D). Both approximations are within ~0.5 % of the exact fluid values
at these densities, and with >= 3e5 collisions the statistical error of our averages is ~0.2 %,
so a 1 % tolerance is tight but safe.
"""

import math

import pytest

import edmd


def chi_cs(eta):
    return (1 - eta / 2) / (1 - eta) ** 3


def chi_henderson(eta):
    return (1 - 7 * eta / 16) / (1 - eta) ** 2


def test_reference_numbers_w5():
    # physics.md W5
    assert chi_cs(0.3) == pytest.approx(2.478134, abs=1e-6)
    assert 1 + 4 * 0.3 * chi_cs(0.3) == pytest.approx(3.973761, abs=1e-6)
    assert chi_henderson(0.5) == pytest.approx(3.125)
    assert 1 + 2 * 0.5 * chi_henderson(0.5) == pytest.approx(4.125)


def enskog_rate(dim, n, eta, volume):
    """Enskog collision frequency per particle for sigma = m = T = 1."""
    chi = chi_cs(eta) if dim == 3 else chi_henderson(eta)
    return (4 if dim == 3 else 2) * n / volume * chi * math.sqrt(math.pi)


def measure(dim, n, eta, seed, collisions):
    """Z and the collision frequency over ``collisions`` collisions after melting the lattice."""
    state = edmd.maxwell_boltzmann(edmd.lattice(n, eta, dim=dim), 1.0, seed=seed)
    sim = edmd.Simulation(state)
    sim.run(max_events=(120 if eta > 0.2 else 40) * n)
    before = sim.totals()
    sim.run(until_time=sim.time + collisions / (0.5 * n * enskog_rate(dim, n, eta, state.volume)))
    after = sim.totals()
    s = sim.state
    dt = after.time - before.time
    p = edmd.files.thermo.pressure(s, after.kinetic_integral - before.kinetic_integral, after.virial - before.virial, dt)
    z = p / (n / s.volume * s.temperature())
    omega = 2.0 * (after.collisions - before.collisions) / (n * dt)
    return z, omega, after.collisions - before.collisions


@pytest.mark.parametrize(
    "dim, eta",
    [(3, 0.1), (3, 0.3), (2, 0.3), (2, 0.5)],
    ids=["3d-0.1", "3d-0.3", "2d-0.3", "2d-0.5"],
)
def test_equation_of_state_and_enskog_rate(dim, eta):
    n = 2048 if dim == 3 else 2000
    z, omega, ncoll = measure(dim, n, eta, seed=7, collisions=300_000)
    assert ncoll >= 250_000
    chi = chi_cs(eta) if dim == 3 else chi_henderson(eta)
    z_ref = 1 + 2 ** (dim - 1) * eta * chi
    omega_ref = enskog_rate(dim, n, eta, edmd.lattice(n, eta, dim=dim).volume)
    print(f"d={dim} eta={eta}: Z={z:.5f} (ref {z_ref:.5f}, {z / z_ref - 1:+.2%}), "
          f"omega={omega:.5f} (Enskog {omega_ref:.5f}, {omega / omega_ref - 1:+.2%})")
    assert z == pytest.approx(z_ref, rel=0.01)
    assert omega == pytest.approx(omega_ref, rel=0.01)


@pytest.mark.parametrize("dim, eta", [(3, 0.3), (2, 0.5)], ids=["3d-0.3", "2d-0.5"])
def test_andersen_bath_samples_the_equilibrium_equation_of_state(dim, eta):
    # the bath fixes kT = 1.5 from a start at kT = 0.5; Z = P/(n kT_bath) must be the fluid's
    n = 2048 if dim == 3 else 2000
    state = edmd.maxwell_boltzmann(edmd.lattice(n, eta, dim=dim), 0.5, seed=5)
    sim = edmd.Simulation(state, thermostat=edmd.Andersen(kT=1.5, rate=0.5, seed=1))
    sim.run(until_time=20.0)  # 10 bath times: melted and at the bath temperature
    before = sim.totals()
    sim.run(until_time=sim.time + 300_000 / (0.5 * n * enskog_rate(dim, n, eta, state.volume) * math.sqrt(1.5)))
    after = sim.totals()
    s = sim.state
    dt = after.time - before.time
    kT = 2.0 * (after.kinetic_integral - before.kinetic_integral) / (dt * dim * n)  # time-averaged
    p = edmd.files.thermo.pressure(s, after.kinetic_integral - before.kinetic_integral, after.virial - before.virial, dt)
    z = p / (n / s.volume * 1.5)
    chi = chi_cs(eta) if dim == 3 else chi_henderson(eta)
    z_ref = 1 + 2 ** (dim - 1) * eta * chi
    print(f"d={dim} eta={eta}: kT={kT:.5f} (bath 1.5), Z={z:.5f} (ref {z_ref:.5f}, {z / z_ref - 1:+.2%})")
    assert kT == pytest.approx(1.5, rel=0.01)  # N d dof averaged over ~ 15 bath times: ~0.3 %
    assert z == pytest.approx(z_ref, rel=0.015)
