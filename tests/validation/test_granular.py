"""Granular gases against kinetic theory (physics.md §3, §5.4 and a derived rough-sphere result)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import edmd
from edmd import collide


def chi(dim, eta):
    return (1 - eta / 2) / (1 - eta) ** 3 if dim == 3 else (1 - 7 * eta / 16) / (1 - eta) ** 2


def sonine_a2(dim, e):
    """physics.md §5.4 (van Noije & Ernst): a2 of the homogeneous cooling state."""
    return 16 * (1 - e) * (1 - 2 * e * e) / (9 + 24 * dim + (8 * dim - 41) * e + 30 * e * e * (1 - e))


def test_sonine_numbers_w6():
    assert sonine_a2(3, 0.9) == pytest.approx(-0.014560, abs=1e-6)
    assert sonine_a2(2, 0.5) == pytest.approx(0.082902, abs=1e-6)


def cooling_run(dim, n, eta, e, seed, checkpoints):
    """HCS from a Maxwellian: returns (t/tau0, T/T0, collisions per particle) at the checkpoints (T/T0 of Haff)."""
    s = edmd.maxwell_boltzmann(edmd.random_packing(n, eta, dim=dim, seed=seed), 1.0, seed=seed + 100)
    sim = edmd.Simulation(s, e_n=e)
    density = n / s.volume
    tau0 = 1 / ((2 / 3 if dim == 3 else 0.5) * (1 - e * e) * density * chi(dim, eta) * math.sqrt(math.pi))
    out = []
    for frac in checkpoints:
        t = tau0 * (1 / math.sqrt(frac) - 1)
        sim.run(until_time=t)
        out.append((t / tau0, sim.state.temperature(), 2 * sim.collisions / n))
    return np.array(out)


CHECKPOINTS = (0.8, 0.5, 0.3, 0.15, 0.08, 0.05)


@pytest.mark.parametrize("dim, e", [(3, 0.9), (2, 0.95)], ids=["3d-e0.9", "2d-e0.95"])
def test_haff_law(dim, e):
    """T(t) = T0 / (1 + t/tau0)^2 within 3 % down to T/T0 = 0.05 (eta = 0.05, N = 1000, 4 runs averaged).

    Run-to-run scatter of one N = 1000 run at T/T0 = 0.05 is ~1.5 %, so the mean of four is good to
    ~0.8 %; the Sonine correction moves the 3D curve by +0.5 %. In 2D at e = 0.9 the homogeneous
    state grows a shear mode (flow energy 0.7 % -> 2 % of the kinetic energy, measured) that shifts
    T by +2-3 %; at e = 0.95 it grows more slowly, hence the choice.
    """
    runs = np.array([cooling_run(dim, 1000, 0.05, e, seed, CHECKPOINTS) for seed in range(4)])
    x, T, C = runs.mean(axis=0).T
    print(f"Haff d={dim}: T/T_Haff = {np.round(T * (1 + x) ** 2, 4)}")
    assert np.abs(T * (1 + x) ** 2 - 1).max() < 0.03
    # per collision (density independent), with the Sonine factor of the exponent (physics.md §5.4)
    a2 = sonine_a2(dim, e)
    per_collision = np.exp(-(1 - e * e) * C / dim * (1 + 3 * a2 / 16) / (1 - a2 / 16))
    assert np.abs(T / per_collision - 1).max() < 0.03


def viscoelastic_cooling(dim, eta, material, mass, radius, times):
    r"""Quadrature of the general cooling law of physics.md §5.4 for e_n(u) of viscoelastic spheres.

    .. math:: \dot T = -\frac1d n\chi\sigma^{d-1}\frac m4|S^{d-1}|\int_0^\infty du\,
              \frac{e^{-u^2/2s^2}}{\sqrt{2\pi s^2}}u^3[1-e_n^2(u)],\qquad s^2 = 2T/m
    """
    sigma = 2 * radius
    density = eta / (math.pi / 6 * sigma**3 if dim == 3 else math.pi / 4 * sigma**2)
    sphere = 4 * math.pi if dim == 3 else 2 * math.pi
    x, w = np.polynomial.laguerre.laggauss(80)  # int_0^inf e^{-x} f(x) dx with x = u^2 / (2 s^2)

    def rate(t, y):
        T = y[0]
        s2 = 2 * T / mass
        u = np.sqrt(2 * s2 * x)
        e = np.array([material.restitution(ui, mass / 2, radius / 2) for ui in u])
        # u^3 e^{-u^2/2s^2} du = 2 s^4 x e^{-x} dx
        integral = 2 * s2 * s2 * np.sum(w * x * (1 - e * e)) / math.sqrt(2 * math.pi * s2)
        return [-density * chi(dim, eta) * sigma ** (dim - 1) * mass / 4 * sphere * integral / dim]

    sol = solve_ivp(rate, (0, max(times)), [1.0], t_eval=times, rtol=1e-10, atol=1e-14)
    return sol.y[0]


def unit_material(beta_v):
    """A viscoelastic material with the given beta_v for sigma = m = 1 (R_eff = 1/4, mu = 1/2, nu = 0)."""
    young = 1.5e4  # K sqrt(R_eff) / mu = 2 Y / 3 = 1e4
    return collide.Viscoelastic(young=young, poisson=0.0, A=beta_v / (1.5 * (2 * young / 3) ** 0.4))


def test_viscoelastic_quadrature_reproduces_physics_md():
    # physics.md §5.4 example: 3D, eta = 0.05, sigma = m = T0 = 1, beta_v = 0.05
    material = unit_material(0.05)
    assert material.beta_v(0.5, 0.25) == pytest.approx(0.05, rel=1e-12)
    T = viscoelastic_cooling(3, 0.05, material, 1.0, 0.5, [10, 100, 1000, 2000])
    assert T == pytest.approx([0.740348, 0.161148, 0.006151, 0.001999], abs=6e-7)  # quoted to 6 decimals


def test_viscoelastic_gas_cools_by_the_general_law():
    """3D, eta = 0.05, beta_v = 0.05: T(t) within 3 % of the quadrature up to t = 2000, slope -> -5/3."""
    material = unit_material(0.05)
    times = np.array([10, 100, 300, 1000, 2000])
    expected = viscoelastic_cooling(3, 0.05, material, 1.0, 0.5, times)
    runs = []
    for seed in range(2):
        s = edmd.maxwell_boltzmann(edmd.random_packing(1000, 0.05, dim=3, seed=seed), 1.0, seed=seed + 50)
        sim = edmd.Simulation(s, collision=material)
        T = []
        for t in times:
            sim.run(until_time=t)
            T.append(sim.state.temperature())
        runs.append(T)
    T = np.mean(runs, axis=0)
    print(f"viscoelastic: T/T_quadrature = {np.round(T / expected, 4)}")
    assert np.abs(T / expected - 1).max() < 0.03
    slope = math.log(T[-1] / T[-2]) / math.log(times[-1] / times[-2])
    quad_slope = math.log(expected[-1] / expected[-2]) / math.log(2.0)
    assert slope == pytest.approx(quad_slope, abs=0.05)
    assert slope == pytest.approx(-5 / 3, abs=0.08)  # late times: T ~ t^(-5/3) (first order in delta)


@pytest.mark.slow
def test_dense_2d_gas_with_tc_does_not_stall():
    """e_n = 0.5 at eta = 0.5 collapses without TC; with TC it runs 1e6 collisions (physics.md §3)."""
    s = edmd.maxwell_boltzmann(edmd.random_packing(2000, 0.5, dim=2, seed=1), 1.0, seed=2)
    with pytest.raises(edmd.run.engine.CollapseError):
        edmd.Simulation(s, e_n=0.5).run(max_events=5_000_000)
    sim = edmd.Simulation(s, collision=collide.TC(collide.Inelastic(0.5), duration=1e-4))
    sim.run(max_events=3_000_000)
    assert sim.collisions >= 1_000_000
    assert sim.engine.cnt[10] > 0  # TC made some collisions elastic
    assert sim.state.overlapping_pair(1e-9) is None


def rough_hcs_ratio(dim, e, beta, q):
    r"""T_rot/T_tr of the homogeneous cooling state of rough spheres (derived, molecular chaos).

    With Maxwellian translational and rotational velocities, the mean energy changes per collision
    (kappa = q/(1+q), a = (1+beta) kappa, d_t = d - 1 tangential directions, r = T_rot/T_tr) are

    .. math::
        \frac{\langle\Delta E_{tr}\rangle}{T_{tr}} = -(1-e^2) - a d_t + \frac{a^2}{2}d_t(1 + r/q),\qquad
        \frac{\langle\Delta E_{rot}\rangle}{T_{tr}} = -a d_t\frac rq + \frac{a^2}{2q}d_t(1+r/q)

    and both temperatures decay at the same rate when
    :math:`\langle\Delta E_{tr}\rangle/(dT_{tr}) = \langle\Delta E_{rot}\rangle/(d_rT_{rot})`
    (d_r = 3 in 3D, 1 in 2D): a quadratic in r. For beta = e = 1 it gives r = 1 (equipartition).
    """
    a = (1 + beta) * q / (1 + q)
    dt, dr = dim - 1, (3 if dim == 3 else 1)
    # (-(1-e^2) - a dt + a^2/2 dt (1 + r/q)) r / d = (-a dt r/q + a^2/(2q) dt (1 + r/q)) / dr
    c2 = a * a / 2 * dt / q / dim
    c1 = (-(1 - e * e) - a * dt + a * a / 2 * dt) / dim - (-a * dt / q + a * a / (2 * q * q) * dt) / dr
    c0 = -(a * a / (2 * q)) * dt / dr
    roots = np.roots([c2, c1, c0])
    return float(roots[roots > 0][0].real)


def test_rough_ratio_limits():
    assert rough_hcs_ratio(3, 1.0, 1.0, 0.4) == pytest.approx(1.0)
    assert rough_hcs_ratio(2, 1.0, 1.0, 0.5) == pytest.approx(1.0)
    assert rough_hcs_ratio(3, 0.9, 0.0, 0.4) == pytest.approx(0.574, abs=1e-3)


@pytest.mark.parametrize("dim, e, beta", [(3, 0.9, 0.0), (3, 0.8, 0.5), (2, 0.9, 0.0)])
def test_rough_gas_settles_to_the_kinetic_theory_ratio(dim, e, beta):
    """Dilute rough gas (eta = 0.02): T_rot/T_tr after 20 collisions per particle within 7 %.

    The prediction assumes molecular chaos and independent Maxwellian translational and rotational
    velocities. Rough granular gases develop correlations between v and omega (Brilliantov, Poschel,
    Kranz, Zippelius, PRL 98, 128001 (2007)) that this theory neglects. Measured over 8 realizations
    of N = 1000 (mean, and the standard deviation of one realization): 3D e = 0.9 -5.0 +- 2.0 %,
    3D e = 0.8 beta = 0.5 -1.9 +- 2.2 %, 2D -4.2 +- 3.3 %. One realization alone fell outside 7 %
    for 4 of these 24, so the test averages all 8 (standard error <= 1.2 %). Larger disk systems
    depart further (-10 % at N = 2000, -22 % at 8000): there the homogeneous cooling of this dilute
    2D gas is unstable.
    """
    q = 0.4 if dim == 3 else 0.5
    measured = []
    for k in range(8):
        s = edmd.maxwell_boltzmann(edmd.random_packing(1000, 0.02, dim=dim, seed=3 + 10 * k), 1.0, seed=4 + 10 * k, spin=True)
        sim = edmd.Simulation(s, collision=collide.Rough(e, beta=beta))
        ratios = []
        for _ in range(8):  # 5 collisions per particle each
            target = sim.collisions + 2500
            while sim.collisions < target:
                sim.run(max_events=20_000)
            st = sim.state
            ratios.append(st.rotational_temperature() / st.temperature())
        measured.append(np.mean(ratios[4:]))  # after 20 collisions per particle
    measured = np.mean(measured)
    print(f"rough d={dim} e={e} beta={beta}: T_rot/T_tr = {measured:.4f}, theory {rough_hcs_ratio(dim, e, beta, q):.4f}")
    assert measured == pytest.approx(rough_hcs_ratio(dim, e, beta, q), rel=0.07)


def sonine_a2_white_noise(dim, e):
    """a2 of the steady state under white-noise forcing (van Noije & Ernst, Granular Matter 1, 57 (1998))."""
    return 16 * (1 - e) * (1 - 2 * e * e) / (73 + 56 * dim - 3 * e * (35 + 8 * dim) + 30 * (1 - e) * e * e)


def white_noise_temperature(dim, n, volume, eta, e, xi0, mass=1.0, sigma=1.0):
    r"""Steady temperature of the white-noise driven gas: input = loss (docs/user-guide.md, "Thermostats and driving").

    Input per particle and unit time :math:`\tfrac d2 m\xi_0^2 (1 - 1/N)` (the mean kick removed);
    loss :math:`\tfrac d2 \zeta(T) T` with :math:`\zeta = \zeta_0 (1 + \tfrac3{16} a_2)` (physics.md §5.4) and
    :math:`\zeta_0 = c_d (1 - e^2) n \sigma^{d-1} \chi \sqrt{\pi T/m}`, :math:`c_3 = 4/3`, :math:`c_2 = 1`.
    """
    zeta1 = (4 / 3 if dim == 3 else 1.0) * (1 - e * e) * n / volume * sigma ** (dim - 1) * chi(dim, eta) * math.sqrt(math.pi / mass)
    zeta1 *= 1 + 3 * sonine_a2_white_noise(dim, e) / 16
    return (mass * xi0**2 * (1 - 1 / n) / zeta1) ** (2 / 3)


def test_white_noise_sonine_numbers():
    # 3D: a2(0.9) = -0.99200/84.130, a2(0.5) = 4/156.25 (hand-checked)
    assert sonine_a2_white_noise(3, 0.9) == pytest.approx(-0.0117913, abs=1e-6)
    assert sonine_a2_white_noise(3, 0.5) == pytest.approx(0.0256, abs=1e-7)


@pytest.mark.parametrize("dim, e", [(3, 0.5), (2, 0.7)])
def test_white_noise_driven_gas_reaches_the_enskog_temperature(dim, e):
    """Dilute (eta = 0.02), kicks every 0.05 mean free times; N = 3000 averaged over 100 relaxation
    times (statistics ~0.3 %). Measured: +0.75 % (3D, e = 0.5) and +1.2 % (2D, e = 0.7) above the
    balance, the same with kicks 20x finer or coarser, while the collision rate at the measured T is
    Enskog's to 0.4 %: the dissipation per collision is ~1.5 % below the first-Sonine value, as
    pre-collision velocity correlations of randomly driven gases make it (Pagonabarraga, Trizac,
    van Noije & Ernst, PRE 65, 011303 (2001)). Tolerance 2 %: this tests the energy balance and
    Enskog's cooling rate; the a2 correction itself (0.3 % of T in 3D at e = 0.5, 0.02 % in 2D at
    e = 0.7) is below what it resolves."""
    n, eta, xi0 = 3000, 0.02, 1.0
    state = edmd.maxwell_boltzmann(edmd.random_packing(n, eta, dim=dim, seed=3), 1.0, seed=4)
    target = white_noise_temperature(dim, n, state.volume, eta, e, xi0)
    omega = (4 if dim == 3 else 2) * n / state.volume * chi(dim, eta) * math.sqrt(math.pi * target)  # Enskog, sigma = m = 1
    sim = edmd.Simulation(state, e_n=e, forcing=edmd.WhiteNoise(xi0=xi0, interval=0.05 / omega, seed=5))
    relax = 1 / (0.5 * (4 / 3 if dim == 3 else 1.0) * (1 - e * e) * n / state.volume * chi(dim, eta) * math.sqrt(math.pi * target))
    sim.run(until_time=10 * relax)
    before = sim.totals()
    sim.run(until_time=sim.time + 100 * relax)
    after = sim.totals()
    t_mean = 2 * (after.kinetic_integral - before.kinetic_integral) / ((after.time - before.time) * dim * n)
    print(f"d={dim} e={e}: T = {t_mean:.5f}, balance {target:.5f} ({t_mean / target - 1:+.2%}); without a2 {target * (1 + 3 * sonine_a2_white_noise(dim, e) / 16) ** (2 / 3):.5f}")
    assert t_mean == pytest.approx(target, rel=0.02)
