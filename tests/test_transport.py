"""Transport coefficients (``edmd.analysis.transport``): Enskog references and the Einstein–Helfand viscosity."""

import math

import numpy as np
import pytest

import edmd
from edmd.analysis import SelfDiffusion, ShearViscosity, ThermalConductivity, enskog_conductivity, enskog_diffusion, enskog_viscosity


def test_enskog_values_reduce_to_the_dilute_gas():
    """eta_E -> Chapman-Cowling's eta_0 (1.016 x 5/16 sqrt(m kT / pi) / sigma^2; Gass's 1.022 / (2 sigma) sqrt(m kT / pi)
    for disks), lambda_E -> lambda_0 and n D_E -> n D_0 as the density vanishes; the scaling with sqrt(m kT)."""
    eta = 1e-9
    assert enskog_viscosity(eta, 3) == pytest.approx(1.016 * 5 / 16 / math.sqrt(math.pi), rel=1e-7)
    assert enskog_viscosity(eta, 2) == pytest.approx(1.022 / 2 / math.sqrt(math.pi), rel=1e-7)
    assert enskog_conductivity(eta, 3) == pytest.approx(1.025 * 75 / 64 / math.sqrt(math.pi), rel=1e-7)
    assert enskog_conductivity(eta, 2) == pytest.approx(1.029 * 2 / math.sqrt(math.pi), rel=1e-7)
    # the dilute Prandtl-like ratio lambda_0 / eta_0 = (15/4) k/m (times the Sonine factors)
    assert enskog_conductivity(eta, 3) / enskog_viscosity(eta, 3) == pytest.approx(15 / 4 * 1.025 / 1.016, rel=1e-7)
    n3 = 6 * eta / math.pi
    assert n3 * enskog_diffusion(eta, 3) == pytest.approx(1.019 * 3 / 8 / math.sqrt(math.pi), rel=1e-7)
    assert enskog_viscosity(0.3, 3, sigma=2.0, mass=4.0, kT=9.0) == pytest.approx(enskog_viscosity(0.3, 3) * 6.0 / 4.0, rel=1e-12)
    assert enskog_diffusion(0.3, 2, sigma=2.0, mass=4.0, kT=9.0) == pytest.approx(enskog_diffusion(0.3, 2) * 2.0 * 1.5, rel=1e-12)
    with pytest.raises(ValueError, match="packing fraction"):
        enskog_viscosity(1.2, 3)


def _table(increments, dt, kT, volume):
    """A thermo-like table whose xy pressure has the given Helfand increments."""
    rows = increments.shape[0]
    return {
        "time": dt * np.arange(1, rows + 1),
        "temperature": np.full(rows, kT),
        "pressure": np.ones(rows),
        "pressure_xy": increments[:, 0] / (volume * dt),
        "pressure_xz": increments[:, 1] / (volume * dt),
        "pressure_yz": increments[:, 2] / (volume * dt),
    }


def test_einstein_helfand_slope_of_a_random_walk():
    """Independent increments of variance s^2 per interval: <dG^2> = m s^2 exactly in expectation, so
    eta = s^2 / (2 V kT dt); 3 x 40000 samples give it to ~1 %, the blocks' error estimate agrees."""
    rng = np.random.default_rng(1)
    state = edmd.lattice(27, 0.1)
    dt, kT, s = 0.1, 2.0, 3.0
    table = _table(rng.normal(0.0, s, size=(40000, 3)), dt, kT, state.volume)
    v = ShearViscosity(lag_max=1.0, blocks=10).compute(table, state)
    expect = s * s / (2.0 * state.volume * kT * dt)
    assert v.viscosity == pytest.approx(expect, rel=0.04)
    assert abs(v.viscosity - expect) < 4 * v.error and v.error < 0.03 * expect
    assert v.temperature == kT and v.lag_times[-1] == pytest.approx(1.0)


@pytest.mark.parametrize("dim", [2, 3])
def test_viscosity_and_conductivity_of_a_hard_sphere_fluid_are_near_enskog(dim):
    """Elastic fluids, spheres at n sigma^3 = 0.5 and disks at packing fraction 0.5: the
    Einstein-Helfand viscosity and conductivity are within statistics (~3-5 %, four errors allowed)
    of Enskog's times the ratios molecular dynamics finds there: 1.0-1.1 for the viscosity of
    spheres, 1.0-1.05 for their conductivity (Alder, Gass & Wainwright, J. Chem. Phys. 53, 3813
    (1970)), about 1 for disks (Gass, J. Chem. Phys. 54, 1898 (1971)); lags of 1.5-3 (about 5-10 and
    10-20 mean free times) past the decay of the correlations. tests/validation/test_transport_validation.py
    pins the viscosity in longer runs."""
    eta, bands = (0.5, {"viscosity": (0.95, 1.1), "conductivity": (0.95, 1.1)}) if dim == 2 else (math.pi * 0.5 / 6, {"viscosity": (1.0, 1.1), "conductivity": (1.0, 1.05)})
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(256, eta, dim=dim), 1.0, seed=4))
    sim.run(until_time=10.0)
    thermo = sim.add(edmd.Thermo(interval=0.2))
    sim.run(until_time=3010.0)
    for name, analysis in (("viscosity", ShearViscosity), ("conductivity", ThermalConductivity)):
        a = analysis(lag_max=3.0, fit_from=1.5, blocks=10).compute(thermo, sim.state)
        value = getattr(a, name)
        assert a.error < 0.08 * value, name
        spread = 4 * a.error / a.enskog
        lo, hi = bands[name]
        assert lo - spread < value / a.enskog < hi + spread, (name, value / a.enskog, spread)


def test_bad_inputs_are_named():
    state = edmd.lattice(27, 0.1)
    table = _table(np.zeros((100, 3)), 0.1, 1.0, state.volume)
    with pytest.raises(ValueError, match="too few"):
        ShearViscosity(lag_max=1.0).compute(table, state)
    gap = dict(table, time=np.r_[table["time"][:50], table["time"][50:] + 1.0])
    with pytest.raises(ValueError, match="equally spaced"):
        ShearViscosity(lag_max=0.2).compute(gap, state)
    del table["pressure_xz"]
    with pytest.raises(ValueError, match="no pressure tensor"):
        ShearViscosity(lag_max=0.2).compute(table, state)
    with pytest.raises(ValueError, match="fit_from"):
        ShearViscosity(lag_max=1.0, fit_from=2.0)
    moving = edmd.maxwell_boltzmann(edmd.lattice(27, 0.1), 1.0, seed=1)
    moving.velocity = moving.velocity + 0.5
    with pytest.raises(ValueError, match="zero total momentum"):
        ThermalConductivity(lag_max=0.2).compute(table, moving)
    mixed = edmd.State(position=state.position, velocity=state.velocity, radius=state.radius, mass=np.r_[2.0, np.ones(26)], box=state.box)
    with pytest.raises(ValueError, match="equal masses"):
        ThermalConductivity(lag_max=0.2).compute(table, mixed)


@pytest.mark.parametrize("dim", [2, 3])
def test_self_diffusion_of_a_random_walk(dim):
    """Frames of independent Gaussian steps of variance s^2 per component: D = s^2 / (2 dt) exactly in
    expectation; 500 walkers x 2000 frames give it to ~1 %, within the blocks' error estimate."""
    rng = np.random.default_rng(2)
    base = edmd.lattice(500, 0.001, dim=dim)
    dt, s = 0.5, 0.2
    walk = np.cumsum(rng.normal(0.0, s, size=(2000, base.n, dim)), axis=0)
    frames = []
    for k in range(2000):
        f = base.copy()
        f.position = base.position + walk[k]
        f.time = dt * (k + 1)
        frames.append(f)
    d = SelfDiffusion(lag_max=5.0, blocks=10).compute(frames)
    expect = s * s / (2.0 * dt)
    assert d.diffusion == pytest.approx(expect, rel=0.03)
    assert abs(d.diffusion - expect) < 4 * d.error


def test_self_diffusion_of_hard_spheres_against_enskog():
    """n sigma^3 = 0.5, N = 256: molecular dynamics finds D/D_E = 1.2-1.3 in large systems (Alder,
    Gass & Wainwright 1970; Speedy, Mol. Phys. 62, 509 (1987)); the periodic box of 8 sigma slows it
    by the hydrodynamic 2.837 kT / (6 pi eta L) ~ 0.03 (Yeh & Hummer 2004), so 1.05-1.3 here, the
    statistical error (~1 %) being far smaller."""
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(256, math.pi * 0.5 / 6), 1.0, seed=4))
    sim.run(until_time=10.0)
    frames = []
    for k in range(1, 1001):
        sim.run(until_time=10.0 + 0.25 * k)
        frames.append(sim.state)
    d = SelfDiffusion(lag_max=5.0, blocks=5).compute(frames)
    assert d.error < 0.03 * d.diffusion
    assert 1.05 < d.diffusion / d.enskog < 1.3


def test_walled_axes_are_left_out():
    """A box closed along z: walls take impulses that the pressure tensor does not hold, so the
    viscosity uses the xy moments only and the conductivity the x and y fluxes."""
    rng = np.random.default_rng(3)
    state = edmd.lattice(27, 0.1, periodic=[True, True, False])
    table = _table(rng.normal(0.0, 1.0, size=(4000, 3)), 0.1, 1.0, state.volume)
    table["energy_flux_x"], table["energy_flux_y"] = table["pressure_xy"], table["pressure_xz"]
    table["energy_flux_z"] = np.full(4000, 1e6)  # (would dominate if used)
    v = ShearViscosity(lag_max=0.5).compute(table, state)
    full = ShearViscosity(lag_max=0.5).compute(table, edmd.lattice(27, 0.1))
    assert v.viscosity != full.viscosity
    c = ThermalConductivity(lag_max=0.5).compute(table, state)
    assert c.conductivity < 1.0
    with pytest.raises(ValueError, match="two periodic axes"):
        ShearViscosity(lag_max=0.5).compute(table, edmd.lattice(27, 0.1, periodic=[True, False, False]))
