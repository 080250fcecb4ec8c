"""The hard-limit table of frictional contacts (docs/physics.md §4.12): the table against the
hard-limit solves it interpolates, its analytic limits, the lab-frame map against the frictional
two-body solver (first order in the softness), conservation, and frictional eMD* runs with it."""

import math
import warnings

import numpy as np
import pytest

import edmd
from edmd._core import friction_lookup as fl
from edmd._core import twobody_friction as tf
from edmd._core.contact import contact_scales
from edmd._core.twobody import dashpot_central
from edmd.physics.contact import Hertz, LinearDashpot
from edmd.physics.emdstar import EMDStar, EMDStarError, FrictionTableWarning, friction_table
from edmd.physics.friction import Friction
from edmd.physics.tables import default_table, pair_table

PAIRINGS = {
    "dashpot-linear": (LinearDashpot(k=1e4, gamma=10.0), Friction(mu=0.3, law="linear", stiffness=2e3)),
    "hertz-mindlin": (Hertz(young=1e5, poisson=0.3, A=1e-3), Friction(mu=0.3, law="mindlin")),
}


def _scratch():
    return np.zeros((tf.SCRATCH_ROWS, tf.N_STATE))


@pytest.mark.parametrize("pairing", sorted(PAIRINGS))
@pytest.mark.parametrize("dim", [2, 3])
def test_table_interpolates_the_hard_limit_solves(pairing, dim):
    """At random damping and contact-point speed (1e-3 to 1e2 impact speeds) the table's impulse
    agrees with a hard-limit solve: (1 + K)|dj| per impact speed, the error of the contact point's
    velocity after the contact, is at most 1e-3 (next to the kinks where the stick-slip sequence
    changes: bicubic interpolation across a kink errs at first order in the node spacing; measured
    5e-4 over 600 points), below 1e-4 for 95 % of the points (measured 99 % below 3e-5) and 1e-6
    in the median (measured 1e-8)."""
    contact, friction = PAIRINGS[pairing]
    q = 0.4 if dim == 3 else 0.5
    values, grid = friction_table(contact, friction, q)
    K = 1.0 / q
    code, _kt, xt, mu = friction.constants(contact)
    rng = np.random.default_rng(dim)
    errors, rate_errors = [], []
    F = _scratch()
    for _ in range(150):
        x = rng.uniform(0.0, 1.0)
        c = x * x if isinstance(contact, Hertz) else x
        u0 = math.exp(rng.uniform(math.log(1e-3), math.log(1e2)))
        j, i_j, tau = fl.hard_limit(contact.code, c, code, grid[fl.G_KT], xt, mu, K, u0, 1e-10, F)
        jt, rate = fl.lookup(values, grid, c, u0)
        errors.append((1.0 + K) * abs(jt - j) / math.hypot(1.0, u0))
        rate_errors.append(abs(rate - i_j / tau) / math.hypot(1.0, u0))
    for e in (errors, rate_errors):
        assert max(e) < 1e-3 and np.quantile(e, 0.95) < 1e-4 and np.median(e) < 1e-6


@pytest.mark.parametrize("dim", [2, 3])
def test_sticking_limit_is_the_tangential_oscillator(dim):
    r"""A dashpot contact that never slides (mu = inf), undamped: the contact point oscillates on
    the spring with frequency :math:`\sqrt{\tilde k(1+K)}` during the half period :math:`\pi` of the
    normal motion, so :math:`\beta = -\cos(\pi\sqrt{\tilde k(1+K)})` exactly (docs/physics.md §4.11)."""
    contact, friction = LinearDashpot(k=7.0, gamma=0.0), Friction(mu=math.inf, stiffness=0.5)
    q = 0.4 if dim == 3 else 0.5
    values, grid = friction_table(contact, friction, q)
    K = 1.0 / q
    expected = -math.cos(math.pi * math.sqrt(0.5 / 7.0 * (1.0 + K)))
    for u0 in (1e-3, 0.7, 40.0):
        j, _rate = fl.lookup(values, grid, 0.0, u0)
        assert (1.0 + K) * j / u0 - 1.0 == pytest.approx(expected, abs=1e-8)  # (the solves at rtol 1e-10)


@pytest.mark.parametrize("zeta", [0.0, 0.1, 0.3])
def test_gross_sliding_limit_is_coulomb(zeta):
    """A contact that slides almost throughout takes the Coulomb impulse mu (1 + e_n) mu_red v_n,
    e_n the dashpot's central restitution (docs/physics.md §2.2.1): to 1e-3 at u0 = 1e3 (the
    spring sticks for a time ~ 1/u0 after the touch)."""
    contact, friction = LinearDashpot(k=1.0, gamma=2.0 * zeta * math.sqrt(0.5)), Friction(mu=0.3, stiffness=0.4)
    values, grid = friction_table(contact, friction)
    j, _rate = fl.lookup(values, grid, 2.0 * zeta, 1e3)
    _tau, e_n, _x = dashpot_central(zeta)
    assert j == pytest.approx(0.3 * (1.0 + e_n), rel=1e-3)


def _random_contact(rng, dim, scale):
    n = rng.normal(size=3)
    if dim == 2:
        n[2] = 0.0
    n /= np.linalg.norm(n)
    v1, v2 = rng.normal(size=3) * scale, rng.normal(size=3) * scale
    w1, w2 = rng.normal(size=3) * 2.0 * scale, rng.normal(size=3) * 2.0 * scale
    if dim == 2:
        v1[2] = v2[2] = 0.0
        w1[:2] = w2[:2] = 0.0
    if (v1 - v2) @ n > 0.0:
        v1, v2 = v2, v1
    return np.zeros(3), -n, v1, v2, w1, w2


def _both_maps(contact, friction, dim, contact_data, inertia=None):
    """``(out_solver, t_c, out_table, t_c)`` of one contact of two equal particles (m = 1, R = 0.5)."""
    q = 0.4 if dim == 3 else 0.5
    I = inertia if inertia is not None else q * 0.25
    values, grid = friction_table(contact, friction, q)
    tab = default_table(contact.name)
    v, tg, ctab, cgeo = tab.core()
    a, b = contact.constants()
    smooth = (True, v, np.array(tg), ctab, np.array(cgeo), *pair_table(tab, tab.code, a, b, 1.0, 0.5, 1.0, 0.5))  # (the smooth map of the species)
    code, kt, xt, mu = friction.constants(contact)
    exact, tabled = np.zeros((7, 3)), np.zeros((7, 3))
    args = (contact.code, a, b, code, kt, xt, mu, 1.0, 1.0, 0.5, 0.5, I, I, *contact_data)
    tc_exact = tf.frictional_update(*args, 1e-10, _scratch(), exact)
    tc_table = fl.tabled_update(*args, smooth, values, grid, 1e-10, np.zeros((3, 10)), np.zeros((13, 3)), tabled)
    return exact, tc_exact, tabled, tc_table


@pytest.mark.parametrize("pairing", sorted(PAIRINGS))
@pytest.mark.parametrize("dim", [2, 3])
def test_tabled_map_converges_to_the_solver_with_the_softness(pairing, dim):
    """Random oblique contacts with spins, at 0.1 and 0.01 of the unit speed: the table's
    relocation, velocities, spins and duration depart from the frictional two-body solver's at
    first order in the softness Lambda (the error per impact speed over Lambda: median 0.6-1.1,
    measured; up to ~100 for grazing contacts, whose small v_n understates their softness). Ten
    times slower impacts are 10x (dashpot, Lambda ~ v_n) or 10^0.8 = 6.3x (Hertz) closer."""
    contact, friction = PAIRINGS[pairing]
    a, b = contact.constants()
    rng = np.random.default_rng(7 + dim)
    contacts = [_random_contact(rng, dim, 1.0) for _ in range(30)]
    worst, per_softness = {}, []
    for scale in (0.1, 0.01):
        errors = []
        for r1, r2, v1, v2, w1, w2 in contacts:
            data = (r1, r2, v1 * scale, v2 * scale, w1 * scale, w2 * scale)
            exact, tc_exact, tabled, tc_table = _both_maps(contact, friction, dim, data)
            g = np.linalg.norm(data[2] - data[3])
            errors.append(max(np.abs(exact[3:5] - tabled[3:5]).max() / g, 0.5 * np.abs(exact[5:7] - tabled[5:7]).max() / g,
                              abs(tc_exact - tc_table) / tc_exact, np.abs(exact[0:2] - tabled[0:2]).max() / (g * tc_exact)))  # fmt: skip
            softness = contact_scales(contact.code, a, b, 0.5, 0.25, 1.0, -(data[2] - data[3]) @ (r1 - r2))[1]
            per_softness.append(errors[-1] / softness)
        worst[scale] = max(errors)
    assert worst[0.01] < worst[0.1] / 5.0
    assert worst[0.01] < 2e-3
    assert np.median(per_softness) < 2.0


@pytest.mark.parametrize("dim", [2, 3])
def test_tabled_map_conserves_momentum_and_angular_momentum(dim):
    """The tangential impulse acts at the contact point and the spins take what the translation's
    angular momentum loses: total momentum and angular momentum (about the origin) after the
    contact equal those before to round-off."""
    contact, friction = PAIRINGS["hertz-mindlin"]
    rng = np.random.default_rng(11)
    I = (0.4 if dim == 3 else 0.5) * 0.25
    for _ in range(20):
        r1, r2, v1, v2, w1, w2 = _random_contact(rng, dim, 1.0)
        _exact, _tc, out, _tct = _both_maps(contact, friction, dim, (r1, r2, v1, v2, w1, w2))
        c1, c2 = out[2] + out[3], out[2] + out[4]
        np.testing.assert_allclose(c1 + c2, v1 + v2, atol=1e-13)
        before = np.cross(r1, v1) + np.cross(r2, v2) + I * (w1 + w2)
        after = np.cross(out[0], c1) + np.cross(out[1], c2) + I * (out[5] + out[6])
        np.testing.assert_allclose(after, before, atol=1e-12)


def test_pairs_off_the_table_are_not_tabled():
    """Another inertia sum (hollow spheres) or damping beyond the table's range: NaN, and eMD*
    then solves the contact directly."""
    contact, friction = PAIRINGS["dashpot-linear"]
    data = _random_contact(np.random.default_rng(1), 3, 1.0)
    assert math.isnan(_both_maps(contact, friction, 3, data, inertia=2.0 / 3.0 * 0.25)[3])
    values, grid = friction_table(contact, friction)
    assert math.isnan(fl.lookup(values, grid, 1.5, 0.3)[0])


def test_friction_table_needs_friction_and_a_constant_spring():
    with pytest.raises(EMDStarError, match="needs friction"):
        EMDStar(Hertz(young=1e5, poisson=0.3, A=1e-3), friction_table=True)
    with pytest.raises(EMDStarError, match="covers a dashpot with a linear spring or Hertz with Mindlin"):
        EMDStar(Hertz(young=1e5, poisson=0.3, A=1e-3), friction=Friction(mu=0.3, stiffness=1e3), fallback_beta=0.5, friction_table=True)
    with pytest.raises(EMDStarError, match="true or false"):
        contact, friction = PAIRINGS["hertz-mindlin"]
        EMDStar(contact, friction=friction, friction_table="yes")


@pytest.mark.parametrize("dim", [2, 3])
def test_gas_with_the_table_follows_the_solved_gas(dim):
    """A frictional gas (Hertz-Mindlin, mu = 0.3, Lambda ~ 3e-3 at the thermal speed, N = 4000)
    with the table and with every contact solved, from one state: after about one collision per
    particle as many contacts (within 2 %), and T_tr, T_rot within 0.6 % (the table errs at first
    order in Lambda per contact: measured -0.07 to -0.28 % here, two seeds, 2D and 3D; against
    the DEM over five collisions per particle: docs/physics.md §4.12)."""
    contact, friction = Hertz(young=2.5e6, poisson=0.3, A=2e-4), Friction(mu=0.3, law="mindlin")
    state = edmd.maxwell_boltzmann(edmd.random_packing(4000, 0.05, dim=dim, seed=3), 1.0, seed=4, spin=True)
    runs = [edmd.Simulation(state, collision=EMDStar(contact, friction=friction, friction_table=table)) for table in (False, True)]
    for sim in runs:
        sim.run(until_time=1.5 if dim == 3 else 4.5)
    solved, tabled = (sim.state for sim in runs)
    contacts = [sim.engine.emd_counters()["emd_contacts"] for sim in runs]
    assert contacts[0] > 1500 and contacts[1] == pytest.approx(contacts[0], rel=0.02)
    assert tabled.temperature() == pytest.approx(solved.temperature(), rel=0.006)
    assert tabled.rotational_temperature() == pytest.approx(solved.rotational_temperature(), rel=0.006)


@pytest.mark.parametrize("dim", [2, 3])
def test_contacts_off_the_table_are_named(dim):
    """A run with the table warns about what the table does not cover (those contacts are solved
    directly): moments of inertia other than q m R^2, a dashpot damped beyond c = 1."""
    state = edmd.maxwell_boltzmann(edmd.random_packing(50, 0.05, dim=dim, seed=3), 1.0, seed=4, spin=True)
    contact, friction = PAIRINGS["dashpot-linear"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        edmd.Simulation(state, collision=EMDStar(contact, friction=friction, friction_table=True))
    hollow = state.copy()
    hollow.inertia = 2.0 / 3.0 * hollow.mass * hollow.radius**2
    with pytest.warns(FrictionTableWarning, match=r"50 of 50 particles have moments of inertia other than"):
        edmd.Simulation(hollow, collision=EMDStar(contact, friction=friction, friction_table=True))
    soggy = LinearDashpot(k=1e4, gamma=150.0)  # c = 150 / sqrt(1e4 / 2) = 2.1
    with pytest.warns(FrictionTableWarning, match=r"damping c = gamma / sqrt\(k mu\) = 2.12 exceeds the table's 1"):
        edmd.Simulation(state, collision=EMDStar(soggy, friction=friction, friction_table=True))
