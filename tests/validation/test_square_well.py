"""The square-well gas against its virial expansion (docs/physics.md §2.5).

At low density :math:`Z = 1 + B_2\\rho + B_3\\rho^2 + O(\\rho^3)`, with the exact
:math:`B_2 = b_0[1 - (\\lambda^d - 1)(e^{\\varepsilon/kT} - 1)]` (:math:`b_0 = 2\\pi\\sigma^3/3`, :math:`\\pi\\sigma^2/2`)
and :math:`B_3 = -\\tfrac13\\iint f_{12}f_{13}f_{23}\\,d\\mathbf r_2d\\mathbf r_3` computed here by Monte Carlo
(:math:`f = -1` inside the core, :math:`e^{\\varepsilon/kT} - 1` inside the well). The simulated pressure is
the collision virial with the wells' capture, release and bounce impulses: a bookkeeping error
of any of them moves Z by far more than the tolerance.
"""

import math

import numpy as np
import pytest

import edmd
from edmd.files.thermo import Thermo

WIDTH, DEPTH, RHO = 1.5, 0.5, 0.05


def mayer(r, x):
    return np.where(r < 1.0, -1.0, np.where(r < WIDTH, x, 0.0))


def third_virial(dim, x, samples=2_000_000):
    """:math:`B_3` (and its Monte Carlo error) for unit core diameter: both partners uniform in the ball of radius lambda."""
    rng = np.random.default_rng(0)

    def ball():
        v = rng.normal(size=(samples, dim))
        return v / np.linalg.norm(v, axis=1)[:, None] * WIDTH * rng.random(samples)[:, None] ** (1.0 / dim)

    r2, r3 = ball(), ball()
    f = mayer(np.linalg.norm(r2, axis=1), x) * mayer(np.linalg.norm(r3, axis=1), x) * mayer(np.linalg.norm(r2 - r3, axis=1), x)
    volume = (4.0 / 3.0 * math.pi if dim == 3 else math.pi) * WIDTH**dim
    return -volume**2 * f.mean() / 3.0, volume**2 * f.std() / (3.0 * math.sqrt(samples))


@pytest.mark.parametrize("dim", [2, 3])
def test_low_density_pressure_follows_the_virial_expansion(dim):
    eta = RHO * (math.pi / 6.0 if dim == 3 else math.pi / 4.0)
    state = edmd.maxwell_boltzmann(edmd.random_packing(2000, eta, dim=dim, seed=1), kT=1.0, seed=2)
    sim = edmd.Simulation(state, well=edmd.SquareWell(WIDTH, DEPTH))
    sim.run(until_time=20.0)
    thermo = Thermo(interval=15.0)
    sim.add(thermo)
    sim.run(until_time=320.0)
    table = thermo.table()
    kT = table["temperature"]
    z = table["pressure"][1:] / (RHO * 0.5 * (kT[1:] + kT[:-1]))  # each row: the interval that ends there
    z_error = z.std(ddof=1) / math.sqrt(len(z))
    x = math.exp(DEPTH / float(kT.mean())) - 1.0
    b0 = 2.0 * math.pi / 3.0 if dim == 3 else math.pi / 2.0
    b2 = b0 * (1.0 - (WIDTH**dim - 1.0) * x)
    b3, b3_error = third_virial(dim, x)
    expected = 1.0 + b2 * RHO + b3 * RHO**2
    # 4 standard errors of the run, the Monte Carlo error of B3, and 1e-3 for the B4 rho^3 term left out
    tolerance = 4.0 * z_error + b3_error * RHO**2 + 1e-3
    assert abs(z.mean() - expected) < tolerance, (z.mean(), z_error, expected)
    hard_spheres = 1.0 + b0 * RHO + (5.0 / 8.0 if dim == 3 else 0.782004) * b0**2 * RHO**2
    assert hard_spheres - z.mean() > 10.0 * tolerance  # the attraction is resolved
