"""The Andersen heat bath (``edmd.physics.thermostats``, ``edmd._core.bath``)."""

import math

import numpy as np
import pytest

import edmd
from edmd._core import layout as L


def _gas(dim, n=256, eta=0.2, kT=0.2, seed=1):
    return edmd.maxwell_boltzmann(edmd.lattice(n, eta, dim=dim), kT, seed=seed)


@pytest.mark.parametrize("dim", [2, 3])
def test_velocities_relax_to_maxwell_boltzmann_at_the_bath_temperature(dim):
    # start far from it: every particle at the same speed (v_x kurtosis 9/5 in 3D, 3/2 in 2D)
    state = _gas(dim, kT=1.0)
    v = state.velocity / np.linalg.norm(state.velocity, axis=1)[:, None] * 0.5
    state = edmd.State(position=state.position, velocity=v, radius=state.radius, mass=state.mass, box=state.box)
    sim = edmd.Simulation(state, thermostat=edmd.Andersen(kT=2.0, rate=1.0, seed=4))
    sim.run(until_time=10.0)  # 10 bath times
    samples = []
    for _ in range(40):  # one bath time apart: nearly independent
        sim.run(until_time=sim.time + 1.0)
        samples.append(sim.state.velocity)
    v = np.concatenate(samples).ravel()
    n_dof = v.size
    # mean v^2 = kT/m: relative standard error sqrt(2/n_dof) (correlations at most double it)
    assert np.mean(v**2) == pytest.approx(2.0, rel=5 * math.sqrt(4 / n_dof))
    assert np.mean(v**4) / np.mean(v**2) ** 2 == pytest.approx(3.0, abs=0.15)


@pytest.mark.parametrize("dim", [2, 3])
def test_bath_events_are_poisson_at_the_given_rate(dim):
    n, rate, t = 256, 0.5, 20.0
    sim = edmd.Simulation(_gas(dim, n), thermostat=edmd.Andersen(kT=1.0, rate=rate, seed=2))
    sim.run(until_time=t)
    expected = n * rate * t  # Poisson count: standard deviation sqrt(expected)
    assert abs(int(sim.engine.cnt[L.C_BATH]) - expected) < 5 * math.sqrt(expected)


@pytest.mark.parametrize("dim", [2, 3])
def test_energy_balance_closes_with_a_rough_inelastic_gas_in_the_bath(dim):
    # the bath resamples spins too; input - dissipated - (change of energy) = 0 to round-off
    state = _gas(dim, eta=0.1)
    sim = edmd.Simulation(state, collision=edmd.physics.collide.Rough(e_n=0.8, beta=0.4), thermostat=edmd.Andersen(kT=1.0, rate=0.5, seed=9))
    e0 = state.kinetic_energy() + state.rotational_energy()
    sim.run(until_time=30.0)
    s, tot = sim.state, sim.totals()
    assert tot.energy_input > 0 and tot.dissipated > 0
    e1 = s.kinetic_energy() + s.rotational_energy()
    assert abs(tot.energy_input - tot.dissipated - (e1 - e0)) < 1e-9 * (tot.energy_input + tot.dissipated)
    assert s.rotational_energy() > 0  # spins were drawn
    # steady state between bath and dissipation: colder than the bath, hotter than the start
    assert 0.2 < s.temperature() < 1.0


def test_disks_stay_in_the_plane_and_spin_about_z():
    sim = edmd.Simulation(_gas(2), collision=edmd.physics.collide.Rough(e_n=0.9, beta=0.5), thermostat=edmd.Andersen(kT=1.0, rate=2.0))
    sim.run(until_time=5.0)
    e = sim.engine
    assert int(e.cnt[L.C_BATH]) > 1000
    assert np.all(e.part.rows[:, L.Z] == 0.0) and np.all(e.part.rows[:, L.VZ] == 0.0)
    assert np.all(e.part.omega[:, :2] == 0.0) and np.any(e.part.omega[:, 2] != 0.0)


def test_momentum_is_tracked_through_bath_events():
    sim = edmd.Simulation(_gas(3), thermostat=edmd.Andersen(kT=1.0, rate=1.0, seed=5))
    sim.run(until_time=5.0)
    s = sim.state
    engine_p = sim.engine.acc[L.A_PX : L.A_PZ + 1]
    assert np.allclose(engine_p, s.mass @ s.velocity, atol=1e-9)
    assert np.linalg.norm(engine_p) > 1.0  # the bath does not conserve momentum


@pytest.mark.parametrize("dim", [2, 3])
def test_a_restart_continues_bit_for_bit(tmp_path, dim):
    path = tmp_path / "bath.gsd"

    def simulation():
        return edmd.Simulation(_gas(dim), collision=edmd.physics.collide.Rough(e_n=0.9, beta=0.3), thermostat=edmd.Andersen(kT=1.0, rate=0.7, seed=3))

    full = simulation()
    full.add(edmd.Checkpoint(path, interval=2.0))
    full.run(until_time=2.0)
    full.run(until_time=5.0)
    restarted = edmd.Simulation.from_checkpoint(path, observers=[edmd.Checkpoint(tmp_path / "again.gsd", interval=2.0)])
    assert restarted.time == 4.0  # the last checkpoint point
    restarted.run(until_time=5.0)
    a, b = full.state, restarted.state
    assert np.array_equal(a.position, b.position) and np.array_equal(a.velocity, b.velocity)
    assert np.array_equal(a.angular_velocity, b.angular_velocity)
    assert full.totals() == restarted.totals()


def test_the_seed_decides_the_bath():
    runs = []
    for seed in (1, 1, 2):
        sim = edmd.Simulation(_gas(3), thermostat=edmd.Andersen(kT=1.0, rate=1.0, seed=seed))
        sim.run(until_time=2.0)
        runs.append(sim.state.velocity)
    assert np.array_equal(runs[0], runs[1]) and not np.array_equal(runs[0], runs[2])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"kT": -1.0, "rate": 1.0}, "Andersen kT must be a positive number, got -1.0"),
        ({"kT": 1.0, "rate": 0.0}, "Andersen rate must be a positive number, got 0.0"),
        ({"kT": 1.0, "rate": math.inf}, "Andersen rate must be a positive number, got inf"),
        ({"kT": 1.0, "rate": 1.0, "seed": -3}, r"Andersen seed must be an integer in \[0, 2\*\*63\), got -3"),
        ({"kT": 1.0, "rate": 1.0, "seed": 1.5}, r"Andersen seed must be an integer"),
    ],
)
def test_bad_parameters_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        edmd.Andersen(**kwargs)


def test_a_thermostat_of_another_type_is_refused():
    with pytest.raises(TypeError, match="thermostat must be an edmd.Andersen"):
        edmd.Simulation(_gas(3), thermostat=1.0)


def test_thermo_has_the_energy_input_column(tmp_path):
    sim = edmd.Simulation(_gas(3), e_n=0.9, thermostat=edmd.Andersen(kT=1.0, rate=0.5))
    sim.add(edmd.Thermo(1.0, tmp_path / "thermo.csv"))
    sim.run(until_time=5.0)
    sim.close()
    table = edmd.read_thermo(tmp_path / "thermo.csv")
    balance = table["energy_balance"]
    assert table["energy_input"][-1] > 0
    assert np.ptp(balance) < 1e-9 * table["energy_input"][-1]


def test_config_section_and_cli_reach_the_bath(tmp_path):
    from edmd.app.config import parse_config
    from edmd.app.runner import build_simulation

    cfg = parse_config({"system": {"n": 108, "packing_fraction": 0.1}, "thermostat": {"kind": "andersen", "kT": 1.5, "rate": 0.25, "seed": 4}})
    sim = build_simulation(cfg)
    assert sim.params["thermostat"] == {"kind": "andersen", "kT": 1.5, "rate": 0.25, "seed": 4}
    assert sim.engine.loop.name == "bath"
    with pytest.raises(edmd.ConfigError, match="thermostat.kind"):
        parse_config({"thermostat": {"kind": "nose-hoover", "kT": 1.0, "rate": 1.0}})


# ---------------------------------------------------------------- white-noise forcing


def test_one_kick_has_the_right_statistics():
    """Mean energy input of one kick on a gas at rest: m d (N - 1) xi0^2 dt / 2; momentum kept."""
    n, dim, xi0, dt = 4000, 3, 0.7, 0.02
    state = edmd.lattice(n, 0.01, dim=dim, mass=2.0)  # at rest, dilute
    sim = edmd.Simulation(state, forcing=edmd.WhiteNoise(xi0=xi0, interval=dt, seed=11, start=0.0))
    sim.run(until_time=0.5 * dt)  # the kick at t = 0 only
    assert int(sim.engine.cnt[L.C_KICKS]) == 1
    out = sim.state
    expected = 0.5 * 2.0 * dim * (n - 1) * xi0**2 * dt
    # relative standard deviation of a chi-square with d(N-1) degrees of freedom: sqrt(2 / (d(N-1))) = 1.3 %
    assert out.kinetic_energy() == pytest.approx(expected, rel=0.05)
    assert sim.totals().energy_input == pytest.approx(out.kinetic_energy(), rel=1e-12)
    assert np.abs(out.momentum()).max() < 1e-9
    components = out.velocity.ravel() / (xi0 * np.sqrt(dt))
    assert np.std(components) == pytest.approx(1.0, rel=0.03)
    assert abs(np.mean(components**4) / np.mean(components**2) ** 2 - 3.0) < 0.2


@pytest.mark.parametrize("dim", [2, 3])
def test_kicks_fire_at_exact_times_in_the_calendar(dim):
    forcing = edmd.WhiteNoise(xi0=0.5, interval=0.3, seed=1, start=0.1)
    sim = edmd.Simulation(_gas(dim), e_n=0.9, forcing=forcing)
    energy = []
    sim.add(edmd.Callback(lambda s, tot: energy.append(tot.energy_input), interval=0.05))
    sim.run(until_time=2.0)
    # kicks at 0.1, 0.4, ..., 1.9: seven of them; the input jumps exactly between the observations around them
    assert int(sim.engine.cnt[L.C_KICKS]) == 7
    jumps = [k for k in range(1, len(energy)) if energy[k] != energy[k - 1]]
    times = [0.05 * k for k in jumps]
    assert all(any(abs(t - (0.1 + 0.3 * j)) < 0.05 + 1e-12 for j in range(7)) for t in times) and len(jumps) == 7
    assert forcing.first_tick(0.4) == 1 and forcing.first_tick(0.4000001) == 2 and forcing.first_tick(-5.0) == 0


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("neighbours", ["list", "cells"])
def test_energy_balance_and_momentum_with_kicks(dim, neighbours):
    sim = edmd.Simulation(
        _gas(dim, eta=0.15), collision=edmd.physics.collide.Rough(e_n=0.8, beta=0.2), forcing=edmd.WhiteNoise(xi0=1.0, interval=0.02, seed=4), engine={"neighbours": neighbours}
    )
    s0 = sim.state
    p0 = s0.momentum()
    sim.run(until_time=10.0)
    s, tot = sim.state, sim.totals()
    change = s.kinetic_energy() + s.rotational_energy() - s0.kinetic_energy() - s0.rotational_energy()
    assert abs(tot.energy_input - tot.dissipated - change) < 1e-9 * tot.energy_input
    assert np.abs(s.momentum() - p0).max() < 1e-9
    assert int(sim.engine.cnt[L.C_KICKS]) == 500 and tot.energy_input > 0  # (its mean: test_one_kick_...)


def test_white_noise_with_the_bath_and_a_restart_bit_for_bit(tmp_path):
    def simulation():
        return edmd.Simulation(
            _gas(3), e_n=0.9, thermostat=edmd.Andersen(kT=1.0, rate=0.3, seed=2), forcing=edmd.WhiteNoise(xi0=0.5, interval=0.07, seed=8)
        )

    full = simulation()
    full.add(edmd.Checkpoint(tmp_path / "c.gsd", interval=1.0))
    full.run(until_time=3.5)
    again = edmd.Simulation.from_checkpoint(tmp_path / "c.gsd", observers=[edmd.Checkpoint(tmp_path / "d.gsd", interval=1.0)])
    assert again.time == 3.0
    again.run(until_time=3.5)
    assert np.array_equal(full.state.velocity, again.state.velocity) and full.totals() == again.totals()
    assert full.engine.loop.name == "bath+noise"


def test_white_noise_refuses_emdstar_and_bad_parameters():
    from edmd.physics.emdstar import EMDStar

    soft = EMDStar(edmd.Hertz(young=1e5, poisson=0.3, A=1e-3))
    with pytest.raises(edmd.StateError, match="white-noise forcing and eMD\\* cannot be combined"):
        edmd.Simulation(_gas(3, eta=0.05), collision=soft, forcing=edmd.WhiteNoise(xi0=1.0, interval=0.1))
    with pytest.raises(ValueError, match="WhiteNoise xi0 must be a positive number, got -1.0"):
        edmd.WhiteNoise(xi0=-1.0, interval=1.0)
    with pytest.raises(ValueError, match="WhiteNoise interval must be a positive number"):
        edmd.WhiteNoise(xi0=1.0, interval=0.0)
    with pytest.raises(ValueError, match=r"WhiteNoise seed must be an integer in \[0, 2\*\*63\)"):
        edmd.WhiteNoise(xi0=1.0, interval=1.0, seed=-2)
    with pytest.raises(TypeError, match="forcing must be an edmd.WhiteNoise"):
        edmd.Simulation(_gas(3), forcing=edmd.Andersen(kT=1.0, rate=1.0))


def test_forcing_config_section():
    from edmd.app.config import parse_config
    from edmd.app.runner import build_simulation

    cfg = parse_config({"system": {"n": 108, "packing_fraction": 0.1}, "collision": {"rule": "inelastic", "e_n": 0.9}, "forcing": {"kind": "white_noise", "xi0": 0.5, "interval": 0.05}})
    sim = build_simulation(cfg)
    assert sim.params["forcing"] == {"kind": "white_noise", "xi0": 0.5, "interval": 0.05, "seed": 0, "start": 0.0}
    with pytest.raises(edmd.ConfigError, match="forcing.xi0"):
        parse_config({"forcing": {"kind": "white_noise", "xi0": -1.0, "interval": 0.1}})


def test_a_kick_fires_at_exactly_its_time():
    """Timers are calendar events at start + k * interval: a run that stops at the tick does not kick,
    one that stops just after it does (a toy of hook c). The engine keeps times relative to its last
    rebuild, so "just after" is beyond the rounding of that subtraction (1e-12 here), not the next float."""
    forcing = edmd.WhiteNoise(xi0=0.5, interval=0.3, seed=1, start=0.1)
    sim = edmd.Simulation(_gas(3), e_n=0.9, forcing=forcing)
    for tick in range(4):
        t = forcing.tick_time(tick)
        sim.run(until_time=t)
        assert int(sim.engine.cnt[L.C_KICKS]) == tick  # the run stops before events at its end time
        sim.run(until_time=t + 1e-12)
        assert int(sim.engine.cnt[L.C_KICKS]) == tick + 1


def test_the_bath_ends_a_pending_emdstar_contact_first():
    from edmd.physics.emdstar import EMDStar

    state = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.2, seed=2), 1.0, seed=3)
    rule = EMDStar(edmd.Hertz(young=1e3, poisson=0.3, A=1e-3))  # soft: long contacts, bath events land in them
    sim = edmd.Simulation(state, collision=rule, thermostat=edmd.Andersen(kT=1.0, rate=5.0, seed=4))
    e0 = state.kinetic_energy()
    sim.run(until_time=3.0)
    s, tot = sim.state, sim.totals()
    counters = sim.emd_counters()
    assert counters["emd_contacts"] > 100 and counters["emd_exceptions_b"] > 0 and int(sim.engine.cnt[L.C_BATH]) > 1000
    # committed velocities (pending increments included) balance the books
    assert abs(tot.energy_input - tot.dissipated - (s.kinetic_energy() - e0)) < 1e-8 * tot.energy_input


def test_a_rebuild_right_after_a_kick_does_not_repeat_it():
    """The engine's maintenance resyncs (and checkpoints after max_events runs) rebuild at the time of
    the last event; when that was a kick, the rebuilt timer must point at the next one."""
    forcing = edmd.WhiteNoise(xi0=0.5, interval=0.3, seed=1, start=0.1)
    sim = edmd.Simulation(_gas(3), e_n=0.9, forcing=forcing)
    sim.run(until_time=0.4 + 1e-12)  # the kick at 0.4 is the last event (none else within 1e-12)
    assert int(sim.engine.cnt[L.C_KICKS]) == 2 and sim.engine.now == pytest.approx(0.4, abs=1e-12)
    energy = sim.totals().energy_input
    sim.engine.resync()  # at the last event: the kick's time
    sim.run(until_time=0.4 + 2e-12)
    assert int(sim.engine.cnt[L.C_KICKS]) == 2 and sim.totals().energy_input == energy
    sim.run(until_time=0.7 + 1e-9)
    assert int(sim.engine.cnt[L.C_KICKS]) == 3


def test_the_bath_thermalises_spins_when_only_the_walls_are_rough():
    state = edmd.maxwell_boltzmann(edmd.lattice(256, 0.1, periodic=[True, True, False]), 1.0, seed=1)
    sim = edmd.Simulation(state, walls=edmd.collide.Wall(e_n=1.0, beta=0.5), thermostat=edmd.Andersen(kT=1.0, rate=2.0, seed=2))
    sim.run(until_time=10.0)
    spins = sim.state.angular_velocity
    inertia = sim.state.inertia
    # every particle met the bath ~20 times: the rotational temperature is the bath's
    assert np.mean(inertia[:, None] * spins**2) == pytest.approx(1.0, rel=0.15)
