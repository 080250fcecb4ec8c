"""Frictional contacts (docs/physics.md §2.6): tangential spring, damping and Coulomb slider in
the DEM, against the analytic hard-contact limits, conservation laws and the frictionless DEM."""

import doctest
import math

import numpy as np
import pytest

import edmd
import edmd.physics.friction
import tomllib

from edmd.app.config import ConfigError
from edmd.app.config import parse_config as parse_dict
from edmd.app.runner import build_simulation
from edmd.physics.contact import ContactError, Hertz, LinearDashpot
from edmd.physics.friction import Friction

K = 1e8  # stiff: the overlap is 1e-4 of the radius, the normal barely turns
DIMS = [2, 3]


def spinning_pair(dim, u0, v_n=1.0, gap=1e-3):
    """Two unit spheres/disks (R = 0.5) meeting head-on at ``v_n`` whose spins about z give the
    contact point the tangential velocity ``u0`` along y."""
    w = u0 / 2.0 / 0.5  # each sphere's spin: (R w1 + R w2) = u0
    pos = np.zeros((2, dim))
    pos[0, 0], pos[1, 0] = -0.5 - gap / 2, 0.5 + gap / 2
    vel = np.zeros((2, dim))
    vel[0, 0], vel[1, 0] = v_n / 2, -v_n / 2
    spin = np.array([w, w]) if dim == 2 else np.array([[0.0, 0.0, w], [0.0, 0.0, w]])
    return edmd.State(position=pos, velocity=vel, angular_velocity=spin, radius=[0.5, 0.5], mass=[1.0, 1.0], box=[20.0] * dim)


def contact_velocity(state):
    """Tangential (y) velocity of the contact point, arms R (the contact is over)."""
    wz = state.angular_velocity if state.dim == 2 else state.angular_velocity[:, 2]
    return (state.velocity[0, 1] - state.velocity[1, 1]) + 0.5 * (wz[0] + wz[1])


def tangential_mass(state):
    r""":math:`m_t` of the pair: :math:`1/m_t = 1/\mu + R_1^2/I_1 + R_2^2/I_2`."""
    return 1.0 / (2.0 + 0.25 / state.inertia[0] + 0.25 / state.inertia[1])


def collide(state, contact, friction, steps=400):
    t_c = contact.central(1.0, 1.0, 0.5, 0.5, 1.0).t_c
    sim = edmd.DEMSimulation(state, contact, friction=friction, dt=t_c / steps)
    sim.run(until_time=2e-3 + 2 * t_c)
    assert sim.collisions == 1
    return sim


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("ratio", [0.5, 0.75, 1.0])
def test_sticking_contact_is_a_tangential_oscillator(dim, ratio):
    r"""Never sliding (mu = inf), undamped, hard: the contact point oscillates at
    :math:`\omega_t = \sqrt{k_t/m_t}` during :math:`t_c = \pi/\omega_n`, so
    :math:`u' = u_0\cos(\pi\omega_t/\omega_n)`, and the energy lost is the spring's at the end,
    :math:`\tfrac12m_tu_0^2\sin^2(\pi\omega_t/\omega_n)`. (Ratio 1 with k_t = 2/7 k_n: perfectly
    rough spheres.) Tolerance: the spring force :math:`k_t\zeta` stops inside a step when the
    overlap ends (with mu = inf nothing lets it slide to zero first), an impulse error of at most
    :math:`hk_t\zeta_{\rm end}/m_t = (\pi r/n)\,|\sin\pi r|\,u_0` at n steps per contact; plus
    1e-4 u0 for the turn of the normal (overlap / R = 1e-4)."""
    u0, steps = 0.8, 400
    state = spinning_pair(dim, u0)
    m_t = tangential_mass(state)
    k_t = ratio**2 * K / 0.5 * m_t  # omega_t^2 = k_t / m_t = ratio^2 k / mu
    sim = collide(state, LinearDashpot(k=K), Friction(mu=math.inf, stiffness=k_t), steps=steps)
    end = sim.state
    tol = (math.pi * ratio / steps * abs(math.sin(math.pi * ratio)) + 1e-4) * u0
    assert contact_velocity(end) == pytest.approx(u0 * math.cos(math.pi * ratio), abs=tol)
    lost = state.kinetic_energy() + state.rotational_energy() - end.kinetic_energy() - end.rotational_energy()
    assert lost == pytest.approx(0.5 * m_t * u0**2 * math.sin(math.pi * ratio) ** 2, abs=2 * m_t * u0 * tol)
    assert end.velocity[0, 0] == pytest.approx(-0.5, abs=1e-3)  # the normal motion is elastic


SLIDING = {
    "linear-dashpot": (LinearDashpot.from_restitution(0.8, k=K, mass=1.0), Friction(mu=0.1, stiffness=0.3 * K, damping=0.5)),
    "mindlin-hertz": (Hertz(young=1e10, poisson=0.3, A=1e-6), Friction(mu=0.1, law="mindlin")),
}


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("case", list(SLIDING))
def test_sliding_contact_takes_mu_times_the_normal_impulse(dim, case):
    r"""Sliding all through (small mu, fast spin): the tangential impulse is :math:`\mu J_n` with
    :math:`J_n = \mu_{12}(1+e_n)v_n`, so :math:`u' = u_0 - \mu(1+e_n)v_n\mu_{12}/m_t`, whatever
    the spring (Walton's sliding branch, docs/physics.md §2.3). Mindlin's spring
    :math:`k_{t0}a\zeta` keeps pace with the Hertz force from the first instant (their ratio is
    :math:`1.24\,u_0/v_n > \mu`), so it slides from the start too."""
    u0 = 3.0
    contact, friction = SLIDING[case]
    e_n = contact.central(1.0, 1.0, 0.5, 0.5, 1.0).e_n
    state = spinning_pair(dim, u0)
    end = collide(state, contact, friction).state
    expected = u0 - friction.mu * (1.0 + e_n) * 1.0 * 0.5 / tangential_mass(state)
    assert contact_velocity(end) == pytest.approx(expected, rel=1e-3)
    assert end.velocity[1, 0] - end.velocity[0, 0] == pytest.approx(e_n, rel=1e-3)  # e_n unchanged


def cluster(dim, n=12, seed=4):
    """A compact, converging cloud of spinning particles in a large box (no one crosses a face during the test)."""
    rng = np.random.default_rng(seed)
    s = edmd.random_packing(n, 0.3, dim=dim, seed=seed)
    pos = s.position * 0.999
    vel = rng.normal(size=(n, dim)) - 2.0 * pos  # converging: many contacts
    spin = rng.normal(size=n) if dim == 2 else rng.normal(size=(n, 3))
    box = s.box * 4.0
    return edmd.State(position=pos, velocity=vel, angular_velocity=spin, radius=s.radius, mass=s.mass, box=box)


def angular_momentum(state):
    r, v, m = state.unwrapped_position, state.velocity, state.mass
    if state.dim == 2:
        return np.array([np.sum(m * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])) + np.sum(state.inertia * state.angular_velocity)])
    return np.sum(m[:, None] * np.cross(r, v), axis=0) + np.sum(state.inertia[:, None] * state.angular_velocity, axis=0)


@pytest.mark.parametrize("dim", DIMS)
def test_momentum_and_angular_momentum_are_exact(dim):
    """The forces act at one point of each contact (arms R - xi/2 add up to r): velocity Verlet
    keeps linear and angular momentum (orbital + spin) to round-off, through stick and slip."""
    state = cluster(dim)
    contact = Hertz(young=1e4, poisson=0.3, A=1e-3)
    sim = edmd.DEMSimulation(state, contact, friction=Friction(mu=0.4, law="mindlin", damping=1.0), steps_per_contact=30)
    sim.run(until_time=0.3)
    assert sim.collisions > 10
    end = sim.state
    p0, p1 = (s.mass @ s.velocity for s in (state, end))
    assert np.abs(p1 - p0).max() < 1e-12 * np.abs(state.velocity).sum()
    scale = np.abs(angular_momentum(state)).max() + 1.0
    assert np.abs(angular_momentum(end) - angular_momentum(state)).max() < 1e-12 * scale
    assert not np.allclose(end.angular_velocity, state.angular_velocity)


@pytest.mark.parametrize("dim", DIMS)
def test_energy_balance_closes_to_second_order(dim):
    """Kinetic + rotational + elastic (normal and springs) + dissipated energy stays constant up to
    the time step: its drift shrinks about 4x when the step halves (a smooth Hertz-Mindlin gas)."""
    state = cluster(dim, n=16, seed=7)
    contact = Hertz(young=1e4, poisson=0.3, A=2e-3)
    drifts = []
    for spc in (20, 40):
        sim = edmd.DEMSimulation(state, contact, friction=Friction(mu=0.5, law="mindlin", damping=0.5), steps_per_contact=spc)
        th = sim.add(edmd.Thermo(interval=0.1))
        sim.run(until_time=0.3)
        bal = np.array([r["energy_balance"] for r in th.rows])
        dissipated = th.rows[-1]["dissipated_energy"]
        assert dissipated > 0.02 * bal[0]
        drifts.append(np.abs(bal - bal[0]).max() / dissipated)
    assert drifts[0] < 0.02
    assert drifts[1] < 0.4 * drifts[0]


@pytest.mark.parametrize("dim", DIMS)
def test_springs_survive_list_rebuilds(dim):
    """A long grazing contact of a fast-drifting pair spans many list rebuilds; each keeps the
    pair's spring: the result equals a run whose list never changes (a huge skin) to round-off."""
    state = spinning_pair(dim, 0.6, v_n=0.2, gap=1e-4)
    drift = np.zeros(dim)
    drift[1] = 40.0
    state = edmd.State(position=state.position, velocity=state.velocity + drift, angular_velocity=state.angular_velocity, radius=state.radius, mass=state.mass, box=[20.0] * dim)
    contact = LinearDashpot(k=1e3, gamma=2.0)
    friction = Friction(mu=0.5, stiffness=300.0, damping=1.0)
    runs = []
    for skin in (0.02, 100.0):  # 100: capped below half the box, no rebuild in the run
        sim = edmd.DEMSimulation(state, contact, friction=friction, dt=2e-4, skin=skin)
        sim.run(until_time=0.1)  # the contact lasts 0.07
        runs.append((sim.state, int(sim._engine.cnt[edmd.run.dem.L.C_REBUILD])))
    (a, rebuilds), (b, once) = runs
    assert rebuilds > 20 and once == 0
    assert np.abs(a.velocity - b.velocity).max() < 1e-12 * 40
    assert np.abs(a.angular_velocity - b.angular_velocity).max() < 1e-10
    assert contact_velocity(a) != pytest.approx(0.6, abs=1e-3)  # the spring did act


@pytest.mark.parametrize("dim", DIMS)
def test_no_friction_is_the_frictionless_dem(dim):
    """mu = 0: the frictionless DEM to rounding (spins untouched). (The onset jumps of a
    frictional run are summed apart and added with the last kick, those of a smooth run at once.)"""
    state = cluster(dim, seed=2)
    contact = LinearDashpot(k=1e4, gamma=5.0)
    a = edmd.DEMSimulation(state, contact, steps_per_contact=20)
    b = edmd.DEMSimulation(state, contact, steps_per_contact=20, friction=Friction(mu=0.0, stiffness=1e3, damping=1.0))
    for sim in (a, b):
        sim.run(until_time=0.2)
    assert a.collisions == b.collisions > 5
    np.testing.assert_allclose(a.state.velocity, b.state.velocity, rtol=0, atol=1e-13)
    np.testing.assert_allclose(a.state.position, b.state.position, rtol=0, atol=1e-13)
    assert np.array_equal(b.state.angular_velocity, state.angular_velocity)


def test_bad_friction_input():
    with pytest.raises(ContactError, match="mu must be >= 0"):
        Friction(mu=-0.1, stiffness=1.0)
    with pytest.raises(ContactError, match="unknown tangential law 'mindlinn'"):
        Friction(mu=0.1, law="mindlinn")
    with pytest.raises(ContactError, match="needs its stiffness"):
        Friction(mu=0.1)
    with pytest.raises(ContactError, match="Hertz law"):
        edmd.DEMSimulation(spinning_pair(3, 1.0), LinearDashpot(k=1e4), friction=Friction(mu=0.1, law="mindlin"))
    with pytest.raises(TypeError, match="friction must be"):
        edmd.DEMSimulation(spinning_pair(3, 1.0), LinearDashpot(k=1e4), friction=0.3)


BASE = """
[system]
n = 64
dim = {dim}
packing_fraction = 0.2
[integrator]
kind = "{kind}"
[run]
until_time = 0.05
output_interval = 0.05
"""


def parse_config(text):
    return parse_dict(tomllib.loads(text))


@pytest.mark.parametrize("dim", DIMS)
def test_config_friction_section(dim, tmp_path):
    text = BASE.format(dim=dim, kind="dem") + '[contact]\nmodel = "hertz"\nyoung = 1e5\npoisson = 0.3\nA = 1e-4\n[friction]\nmu = 0.3\nlaw = "mindlin"\ndamping = 0.5\n'
    cfg = parse_config(text)
    sim = build_simulation(cfg)
    assert sim.friction == Friction(mu=0.3, law="mindlin", damping=0.5)
    sim.run(until_time=0.05)
    assert sim.params["friction"]["law"] == "mindlin"
    with pytest.raises(ConfigError, match=r"\[friction\] .* needs integrator.kind = 'dem' or collision.rule = 'emdstar'"):
        parse_config(BASE.format(dim=dim, kind="edmd") + "[friction]\nmu = 0.3\nstiffness = 1.0\n")
    with pytest.raises(ConfigError, match="needs friction.stiffness"):
        parse_config(BASE.format(dim=dim, kind="dem") + '[contact]\nmodel = "dashpot"\nk = 1e4\n[friction]\nmu = 0.3\n')
    with pytest.raises(ConfigError, match="mindlin' takes its stiffness from a Hertz"):
        parse_config(BASE.format(dim=dim, kind="dem") + '[contact]\nmodel = "dashpot"\nk = 1e4\n[friction]\nmu = 0.3\nlaw = "mindlin"\n')
    assert parse_config(BASE.format(dim=dim, kind="dem") + '[contact]\nmodel = "dashpot"\nk = 1e4\n[friction]\nmu = inf\nstiffness = 1e3\n').friction.mu == math.inf


EMD = '[collision]\nrule = "emdstar"\ncontact = "hertz"\nyoung = 1e5\npoisson = 0.3\nA = 1e-4\n'


@pytest.mark.parametrize("dim", DIMS)
def test_config_frictional_emdstar(dim):
    """``[friction]`` with rule 'emdstar': frictional eMD* contacts; ``collision.beta`` is the fallback's beta_0."""
    from edmd.physics.emdstar import EMDStar

    cfg = parse_config(BASE.format(dim=dim, kind="edmd") + EMD + '[friction]\nmu = 0.3\nlaw = "mindlin"\n')
    sim = build_simulation(cfg)
    rule = sim.engine.rule
    assert isinstance(rule, EMDStar) and rule.friction == Friction(mu=0.3, law="mindlin")
    assert rule.fallback_beta == EMDStar(rule.contact, friction=rule.friction).for_dim(dim).fallback_beta
    sim.run(until_time=0.05)
    cfg = parse_config(BASE.format(dim=dim, kind="edmd") + EMD + 'beta = 0.25\n[friction]\nmu = 0.3\nlaw = "mindlin"\n')
    assert build_simulation(cfg).engine.rule.fallback_beta == 0.25
    with pytest.raises(ConfigError, match=r"collision.beta of rule 'emdstar' .* needs a \[friction\] section"):
        parse_config(BASE.format(dim=dim, kind="edmd") + EMD + "beta = 0.25\n")
    with pytest.raises(ConfigError, match="needs friction.stiffness"):
        parse_config(BASE.format(dim=dim, kind="edmd") + EMD + "[friction]\nmu = 0.3\n")
    with pytest.raises(ConfigError, match="give collision.beta"):
        parse_config(BASE.format(dim=dim, kind="edmd") + EMD + "[friction]\nmu = 0.3\nstiffness = 1e3\n")


@pytest.mark.parametrize("dim", DIMS)
def test_config_friction_table(dim, tmp_path):
    """``collision.friction_table``: the hard-limit table of frictional eMD* (docs/physics.md §4.12),
    from a config file and the CLI; it needs ``[friction]`` and a pairing the table covers."""
    from typer.testing import CliRunner

    from edmd.app.cli import app

    text = BASE.format(dim=dim, kind="edmd") + EMD + 'friction_table = true\n[friction]\nmu = 0.3\nlaw = "mindlin"\n'
    rule = build_simulation(parse_config(text)).engine.rule
    assert rule.friction_table and rule.friction == Friction(mu=0.3, law="mindlin")
    with pytest.raises(ConfigError, match=r"friction_table .* needs a \[friction\] section"):
        parse_config(BASE.format(dim=dim, kind="edmd") + EMD + "friction_table = true\n")
    with pytest.raises(ConfigError, match="friction_table covers a dashpot with a linear spring or Hertz with Mindlin"):
        parse_config(BASE.format(dim=dim, kind="edmd") + EMD + "beta = 0.2\nfriction_table = true\n[friction]\nmu = 0.3\nstiffness = 1e3\n")
    cfg = tmp_path / "f.toml"
    cfg.write_text(text.replace("n = 64", "n = 200").replace("packing_fraction = 0.2", "packing_fraction = 0.05").replace("until_time = 0.05", "until_time = 2.0"))
    res = CliRunner().invoke(app, ["run", str(cfg), "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    thermo = edmd.read_thermo(tmp_path / "out" / "thermo.csv")
    assert thermo["temperature_rot"][-1] > 0.0 and thermo["emd_contacts"][-1] > 0  # spins were zero: the contacts spun them up


def test_cli_runs_frictional_dem(tmp_path):
    from typer.testing import CliRunner

    from edmd.app.cli import app

    cfg = tmp_path / "f.toml"
    cfg.write_text(BASE.format(dim=3, kind="dem").replace("until_time = 0.05", "until_time = 0.5") + '[contact]\nmodel = "dashpot"\nk = 1e4\ne_n = 0.8\n[friction]\nmu = 0.3\nstiffness = 2857.0\n')
    res = CliRunner().invoke(app, ["run", str(cfg), "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    thermo = edmd.read_thermo(tmp_path / "out" / "thermo.csv")
    assert thermo["temperature_rot"][-1] > 0.0  # spins were zero at the start: friction spun them up


def test_examples_in_docstrings():
    assert doctest.testmod(edmd.physics.friction).failed == 0


@pytest.mark.parametrize("dim", DIMS)
def test_reassigning_the_state_keeps_the_springs(dim):
    """``sim.state = sim.state`` in the middle of a contact changes nothing (the springs of pairs
    still in contact are kept; a State itself holds none)."""
    state = spinning_pair(dim, 0.6, v_n=0.2, gap=1e-4)
    contact, friction = LinearDashpot(k=1e3, gamma=2.0), Friction(mu=0.5, stiffness=300.0, damping=1.0)
    a = edmd.DEMSimulation(state, contact, friction=friction, dt=1e-4)
    b = edmd.DEMSimulation(state, contact, friction=friction, dt=1e-4)
    a.run(until_time=0.03)  # the contact lasts about 0.07
    b.run(until_time=0.03)
    b.state = b.state
    for sim in (a, b):
        sim.run(until_time=0.1)
    # (the reload recomputes the forces from the snapshot: round-off; losing the springs changed v by 0.09)
    assert np.abs(a.state.velocity - b.state.velocity).max() < 1e-9
    assert np.abs(np.asarray(a.state.angular_velocity) - b.state.angular_velocity).max() < 1e-9
