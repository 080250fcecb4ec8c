"""Jammed packings and crystallisation by Lubachevsky–Stillinger compression (docs/physics.md §1.7).

References:
* Skoge, Donev, Stillinger & Torquato, PRE 74, 041127 (2006): LS packings of monodisperse spheres,
  terminated at reduced pressure 1e12; amorphous packings at fast rates, phi_J of 3D random
  jammed packings 0.645 +- 0.005 (their Table I, the MRJ value of Kansal et al. 2002); faster
  compressions jam lower, down to ~0.635 (O'Hern et al., PRE 68, 011306 (2003): 0.639 by energy
  minimisation). Non-rattlers are isostatic (z = 2d), rattlers 2-3 % in 3D (Donev, Torquato &
  Stillinger, PRE 71, 011105 (2005)); slow compressions crystallise (their Fig. 5).
* O'Hern et al. (2003): 50:50 disks of size ratio 1.4 jam at phi_J ~ 0.84 (0.842 in the large-N limit).
* DynamO's issue #76: a 1008-particle AB6 binary mixture whose compression stops above phi = 0.7
  ("system size too small") because its cell list cannot shrink; here lists sized to the box carry
  it to jamming.
* Steinhardt, Nelson & Ronchetti, PRB 28, 784 (1983): Q6 = 0.575 (fcc), 0.485 (hcp); a fluid or
  glass of N particles has Q6 ~ N^(-1/2) (0.05-0.07 at N = 500).
"""

import pytest

import edmd
from edmd.run.compress import JAMMED

pytestmark = pytest.mark.slow


def jam(n, dim, radius, seed, rate=0.02):
    start = edmd.maxwell_boltzmann(edmd.random_packing(n, 0.1, dim=dim, seed=seed, radius=radius), kT=1.0, seed=seed + 1)
    jammed = edmd.compression(start, pressure=JAMMED, rate=rate)
    assert jammed.reached == "pressure" and jammed.pressure >= JAMMED
    assert jammed.state.overlapping_pair(1e-13) is None
    return jammed, jammed.contacts(gap=1e-9)


def test_monodisperse_spheres_jam_isostatic_in_the_random_jamming_range():
    """N = 4000: phi_J within [0.635, 0.650] (fast LS compressions jam below the MRJ 0.645 +- 0.005,
    not below O'Hern's 0.639 by much); z within 1 % of 6; rattlers 1-5 %."""
    jammed, net = jam(4000, 3, 0.5, seed=5)
    assert 0.635 <= jammed.packing_fraction <= 0.650, jammed.packing_fraction
    assert abs(net.mean_contact_number / 6.0 - 1.0) < 0.01, net.mean_contact_number
    assert 0.01 <= net.rattler_fraction <= 0.05, net.rattler_fraction


def test_bidisperse_disks_jam_at_the_literature_packing_fraction():
    """50:50, size ratio 1.4, N = 2000: phi_J within 0.835-0.850 (O'Hern et al. 0.842 at large N,
    finite-N and rate spread ~0.005); z within 1 % of 4."""
    radius = {"kind": "discrete", "values": [0.5, 0.7], "fractions": [0.5, 0.5]}
    jammed, net = jam(2000, 2, radius, seed=7)
    assert 0.835 <= jammed.packing_fraction <= 0.850, jammed.packing_fraction
    assert abs(net.mean_contact_number / 4.0 - 1.0) < 0.01, net.mean_contact_number


def test_a_small_ab6_mixture_compresses_all_the_way_to_jamming():
    """DynamO issue #76's system: 1008 spheres, 144 large and 864 small of half their size (AB6),
    in a box of about 5.8 large diameters at jamming. It jams above the monodisperse phi_J (size
    disparity packs denser: 0.66-0.70), isostatic within 1 %."""
    radius = {"kind": "discrete", "values": [0.5, 0.25], "fractions": [1, 6]}
    jammed, net = jam(1008, 3, radius, seed=9)
    assert 0.66 <= jammed.packing_fraction <= 0.70, jammed.packing_fraction
    assert abs(net.mean_contact_number / 6.0 - 1.0) < 0.01, net.mean_contact_number


def test_compression_through_the_freezing_range_crystallises():
    """500 spheres (an fcc 5 x 5 x 5 fits the box) compressed to 0.56, above the fluid-solid
    coexistence range (0.494-0.545) where the fluid is metastable and crystallises, held there, then
    compressed at g = 1e-3 to Z = 1e6: bond order Q6 rises from the fluid's ~0.1 to a crystal's (> 0.38:
    0.40 measured after 120 time units; random stacking of fcc and hcp lies between their 0.485 and
    0.575, defects lower it), and the packing fraction passes far beyond random jamming (0.64) towards
    close packing 0.7405: a crystal with grain boundaries stops below it. Of eleven realisations (seeds,
    resync periods), the eight that crystallised while held (Q6 > 0.38) ended at 0.688-0.705, two
    partly crystallised (Q6 0.35) at 0.685, one still fluid (Q6 0.18) at 0.660."""
    freud = pytest.importorskip("freud")

    def q6(state):
        ql = freud.order.Steinhardt(6)
        ql.compute((freud.box.Box.from_box(state.freud_box), state.points), neighbors={"num_neighbors": 12})
        return ql.order

    fluid = edmd.compress(edmd.maxwell_boltzmann(edmd.random_packing(500, 0.1, seed=1), kT=1.0, seed=2), 0.56, rate=0.02)
    assert q6(fluid) < 0.15
    sim = edmd.Simulation(fluid)
    sim.run(until_time=fluid.time + 300.0)
    assert q6(sim.state) > 0.38, q6(sim.state)
    crystal = edmd.compression(sim.state, pressure=1e6, rate=1e-3, slowdown=())
    assert q6(crystal.state) > 0.38, q6(crystal.state)
    assert 0.68 < crystal.packing_fraction < 0.7405, crystal.packing_fraction
