"""Einstein–Helfand shear viscosity of the hard-sphere fluid against Enskog (physics.md §5.6), long runs.

Molecular dynamics finds the hard-sphere viscosity above Enskog's by a factor that grows with
density (correlated collisions; Alder, Gass & Wainwright, J. Chem. Phys. 53, 3813 (1970)):
about 1.0-1.1 at n sigma^3 = 0.5 and 1.2-1.4 at n sigma^3 = 0.8. Runs of 2e4 time units (some
1e7-2e7 collisions per 500 spheres) pin our ratio to ~1.5 %. The viscosity depends little on N
(Sigurgeirsson & Heyes, Mol. Phys. 101, 469 (2003)); the lags (3-6 time units, ~20-50 mean free
times) are past the decay of the stress correlations.
"""

import math

import pytest

import edmd
from edmd.analysis import ShearViscosity

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("density, band", [(0.5, (1.0, 1.1)), (0.8, (1.2, 1.4))])
def test_einstein_helfand_viscosity_against_enskog(density, band):
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(500, math.pi * density / 6), 1.0, seed=11))
    sim.run(until_time=50.0)
    thermo = sim.add(edmd.Thermo(interval=0.25))
    sim.run(until_time=20050.0)
    v = ShearViscosity(lag_max=6.0, fit_from=3.0, blocks=10).compute(thermo, sim.state)
    ratio, error = v.viscosity / v.enskog, v.error / v.enskog
    print(f"n sigma^3 = {density}: eta = {v.viscosity:.4f} +- {v.error:.4f}, Enskog {v.enskog:.4f}, ratio {ratio:.3f} +- {error:.3f}")
    assert error < 0.03 * ratio
    assert band[0] - 3 * error < ratio < band[1] + 3 * error
