"""A fluid compressed by growing its particles is the equilibrium fluid (docs/physics.md §1.7).

Compressing slowly to eta = 0.45 (3D) / 0.6 (2D) and then running at fixed size gives the pressure
of a run started from a lattice at the same packing fraction, and both the Carnahan–Starling /
Henderson equation of state (within ~0.5 % of the exact fluid there). With >= 4e5 collisions per
run the statistical error is ~0.3 %, so 1.5 % between runs and against the EOS is safe.
"""

import math

import pytest

import edmd
from edmd.files.thermo import pressure


def z_at_fixed_size(state, collisions):
    sim = edmd.Simulation(state)
    sim.run(max_events=60 * state.n)
    before = sim.totals()
    sim.run(max_events=collisions * 2)
    while sim.collisions - before.collisions < collisions:
        sim.run(max_events=collisions)
    after = sim.totals()
    s = sim.state
    p = pressure(s, after.kinetic_integral - before.kinetic_integral, after.virial - before.virial, after.time - before.time)
    return p / (s.n / s.volume * s.temperature())


@pytest.mark.parametrize("dim, eta", [(3, 0.45), (2, 0.6)], ids=["3d", "2d"])
def test_a_compressed_fluid_has_the_pressure_of_the_equilibrium_fluid(dim, eta):
    n = 2000
    start = edmd.maxwell_boltzmann(edmd.random_packing(n, 0.05, dim=dim, seed=11), kT=1.0, seed=12)
    compressed = edmd.compress(start, eta, rate=0.02)
    from_lattice = edmd.maxwell_boltzmann(edmd.lattice(n, eta, dim=dim), kT=1.0, seed=13)
    z_compressed = z_at_fixed_size(compressed, 400_000)
    z_lattice = z_at_fixed_size(from_lattice, 400_000)
    chi = (1 - eta / 2) / (1 - eta) ** 3 if dim == 3 else (1 - 7 * eta / 16) / (1 - eta) ** 2
    z_eos = 1 + (4 if dim == 3 else 2) * eta * chi
    assert z_compressed == pytest.approx(z_lattice, rel=0.015)
    assert z_compressed == pytest.approx(z_eos, rel=0.015) and z_lattice == pytest.approx(z_eos, rel=0.015)
    assert math.isfinite(z_compressed)
