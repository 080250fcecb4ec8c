"""Contact models: parameters, validation, pair mixing, physics.md worked examples W8 and W9."""

import doctest
import math
import warnings

import numpy as np
import pytest

import edmd.physics.contact
from edmd.physics.contact import ContactError, ContactWarning, Hertz, LinearDashpot, pair_constants


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: LinearDashpot(k=-1.0), "spring constant k"),
        (lambda: LinearDashpot(k=0.0), "spring constant k"),
        (lambda: LinearDashpot(k=float("nan")), "spring constant k"),
        (lambda: LinearDashpot(k=1.0, gamma=-0.1), "damping constant gamma"),
        (lambda: LinearDashpot(k="stiff"), "must be a number"),
        (lambda: Hertz(young=-1e9, poisson=0.3), "Young's modulus"),
        (lambda: Hertz(young=1e9, poisson=0.6), "Poisson ratio"),
        (lambda: Hertz(young=1e9, poisson=-1.0), "Poisson ratio"),
        (lambda: Hertz(young=1e9, poisson=0.3, A=-1e-7), "dissipative constant A"),
        (lambda: LinearDashpot.from_restitution(1.2, k=1.0, mass=1.0), "e_n must be in (0, 1]"),
        (lambda: LinearDashpot(k=1.0).scales(1.0, 1.0, 0.5, 0.5, v_n=-1.0), "normal impact speed"),
        (lambda: LinearDashpot(k=1.0).scales(1.0, 0.0, 0.5, 0.5, v_n=1.0), "mass m2"),
        (lambda: LinearDashpot(k=1.0).table_coordinates(1.0, 1.0, 0.5, 0.5, v=1.0, b=1.0), "eccentricity b"),
    ],
)
def test_bad_parameters_name_the_problem(make, words):
    with pytest.raises(ContactError, match=words.replace("(", r"\(").replace(")", r"\)").replace("'", ".")):
        make()


def test_viscoelastic_delta_above_one_warns():
    h = Hertz(young=1e7, poisson=0.3, A=1e-2)
    with pytest.warns(ContactWarning, match="delta = .* > 1"):
        s = h.scales(1.0, 1.0, 0.5, 0.5, v_n=1.0)
    assert s.damping > 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Hertz(young=1e7, poisson=0.3, A=1e-7).scales(1.0, 1.0, 0.5, 0.5, v_n=1.0)


def test_w8_dashpot_si_example():
    # physics.md §2.2.1 W8: m = 1e-3 kg each, k = 1e4 N/m, zeta_d = 0.1 (gamma = 0.4472136 kg/s)
    m = 1e-3
    d = LinearDashpot(k=1e4, gamma=0.4472136)
    assert d.damping_ratio(m, m) == pytest.approx(0.1, rel=1e-7)
    s = d.scales(m, m, 1e-3, 1e-3, v_n=0.3)
    assert 1.0 / s.t_s == pytest.approx(4472.136, rel=1e-7)
    c = d.central(m, m, 1e-3, 1e-3, v_n=0.3)
    assert c.t_c == pytest.approx(6.609985e-4, rel=2e-7)
    assert c.e_n == pytest.approx(0.7440794, rel=2e-7)
    # residual overlap xi_c = 2 zeta e_n v_n / omega_0 (physics.md §2.2.1)
    assert c.xi_c == pytest.approx(2 * 0.1 * c.e_n * 0.3 / 4472.136, rel=1e-6)
    # e_n of a dashpot does not depend on the impact speed
    assert d.central(m, m, 1e-3, 1e-3, v_n=7.0).e_n == pytest.approx(c.e_n, rel=1e-14)


def test_w9_glass_example():
    # physics.md §2.2.2 W9: R = 1 mm, rho_m = 2500 kg/m^3, Y = 63 GPa, nu = 0.2, A = 1e-7 s
    R = 1e-3
    m = 2500 * 4 / 3 * math.pi * R**3
    h = Hertz(young=63e9, poisson=0.2, A=1e-7)
    assert h.prefactor(R, R) == pytest.approx(9.78280e8, rel=1e-5)
    kappa = h.prefactor(R, R) / (m / 2)
    assert kappa == pytest.approx(1.86838e14, rel=1e-5)
    expected = [(0.1, 0.04838, 0.946132, 9.884e-6), (1.0, 0.07668, 0.916405, 6.203e-6), (10.0, 0.12153, 0.871862, 3.881e-6)]
    for v, delta, e_n, t_c in expected:
        assert h.scales(m, m, R, R, v_n=v).damping == pytest.approx(delta, abs=1e-5)
        c = h.central(m, m, R, R, v_n=v)
        assert c.e_n == pytest.approx(e_n, abs=1e-6)
        assert c.t_c == pytest.approx(t_c, abs=1e-9)
    # maximal compression (5 mu v^2 / (4 rho))^(2/5) = 2.1 micrometre at 1 m/s
    assert (5 * m / 2 / (4 * h.prefactor(R, R))) ** 0.4 == pytest.approx(2.1e-6, abs=0.05e-6)


def test_delta_is_three_halves_a_over_t_s():
    # physics.md §2.2.2: delta = (3/2) A / t_s exactly
    h = Hertz(young=2e9, poisson=0.35, A=3e-7)
    s = h.scales(2e-3, 5e-3, 1e-3, 2e-3, v_n=0.7)
    assert s.damping == pytest.approx(1.5 * 3e-7 / s.t_s, rel=1e-14)
    assert s.l_s / s.t_s == pytest.approx(0.7, rel=1e-14)


def test_pair_mixing_polydisperse():
    assert pair_constants(1.0, 3.0, 0.5, 1.5) == (0.75, 0.375, 2.0)
    h = Hertz(young=1e8, poisson=0.3, A=1e-6)
    # a (R1, R2, m1, m2) pair behaves like a monodisperse pair with the same mu and R_eff; only
    # the softness Lambda = l_s / sigma sees the contact distance
    poly = h.scales(1.0, 3.0, 0.5, 1.5, v_n=2.0, v_t=1.0)
    mono = h.scales(1.5, 1.5, 0.75, 0.75, v_n=2.0, v_t=1.0)
    assert poly.damping == pytest.approx(mono.damping, rel=1e-14)
    assert poly.l_s == pytest.approx(mono.l_s, rel=1e-14)
    assert poly.softness * 2.0 == pytest.approx(mono.softness * 1.5, rel=1e-14)
    # symmetric in the two particles
    swapped = h.scales(3.0, 1.0, 1.5, 0.5, v_n=2.0, v_t=1.0)
    assert swapped == poly
    d = LinearDashpot(k=50.0, gamma=0.3)
    assert d.damping_ratio(1.0, 3.0) == pytest.approx(0.3 / (2 * math.sqrt(50 * 0.75)), rel=1e-14)


@pytest.mark.parametrize("e_n", [0.99, 0.9, 0.5, 0.1, 0.01])
def test_dashpot_from_restitution(e_n):
    d = LinearDashpot.from_restitution(e_n, k=1e3, mass=2.0, mass2=0.5)
    assert d.central(2.0, 0.5, 0.3, 0.4, v_n=1.3).e_n == pytest.approx(e_n, rel=1e-12)
    assert LinearDashpot.from_restitution(1.0, k=1e3, mass=1.0).gamma == 0.0


def test_forces():
    d = LinearDashpot(k=100.0, gamma=2.0)
    xi = np.array([-0.01, 0.02, 0.02, 0.02])
    xi_dot = np.array([1.0, 1.0, -0.5, -2.0])
    # 100*0.02 + 2*(1, -0.5, -2) = 4, 1, -2 -> clipped to 0; no force without overlap
    assert d.force(xi, xi_dot, 0.5, 0.5).tolist() == [0.0, 4.0, 1.0, 0.0]
    h = Hertz(young=3e6, poisson=0.5, A=0.01)
    rho = 2 * 3e6 * math.sqrt(0.25) / (3 * 0.75)
    f = h.force(0.01, -0.2, 0.5, 0.5)
    assert float(f) == pytest.approx(rho * 0.01**1.5 + 1.5 * 0.01 * rho * 0.1 * -0.2, rel=1e-14)


def test_examples_in_docstrings():
    assert doctest.testmod(edmd.physics.contact, raise_on_error=False).failed == 0
