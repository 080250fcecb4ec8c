"""Updaters (core v2 event interface, hook d): exact firing times, energy bookkeeping, RNG state in checkpoints."""

import numpy as np
import pytest

import edmd
from edmd import Callback, Checkpoint, Simulation, Thermo, Updater, VelocityRescale, WhiteNoise
from edmd.files.checkpoint import load_checkpoint


class Jiggle(Updater):
    """A toy random updater (hook d): Gaussian velocity kicks drawn from the updater's own generator."""

    def __init__(self, size, interval, seed=0):
        super().__init__(interval, seed=seed)
        self.size = size

    def update(self, state, rng):
        kick = rng.normal(0.0, self.size, size=state.velocity.shape)
        state.velocity = state.velocity + kick - (state.mass @ kick) / state.mass.sum()
        return state


def gas(dim, n3=256, n2=225, eta=0.1, seed=1):
    return edmd.maxwell_boltzmann(edmd.lattice(n3 if dim == 3 else n2, eta, dim=dim), 1.0, seed=seed)


@pytest.mark.parametrize("dim", [2, 3])
def test_rescale_fires_at_exact_times_and_sets_the_temperature(dim):
    sim = Simulation(gas(dim), e_n=0.7)
    sim.add(VelocityRescale(kT=1.5, interval=0.25))
    seen = []
    sim.add(Callback(lambda s, tot: seen.append((s.time, s.temperature(), s.momentum())), interval=0.25))
    sim.run(until_time=2.0)
    times = [t for t, _, _ in seen]
    assert times == [0.25 * k for k in range(9)]  # start + k * interval, by multiplication
    for _, temperature, momentum in seen:  # observers due then see the rescaled system
        assert temperature == pytest.approx(1.5, rel=1e-12)
        assert np.abs(momentum).max() < 1e-10
    assert sim.collisions > 100


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("make", [lambda: VelocityRescale(kT=1.0, interval=0.2), lambda: Jiggle(0.2, interval=0.05, seed=7)])
def test_energy_balance_closes_with_the_input(dim, make):
    """Granular gas under gravity between walls, driven: kinetic + rot + potential + dissipated - input."""
    periodic = [True] * (dim - 1) + [False]
    state = edmd.maxwell_boltzmann(edmd.lattice(64 if dim == 3 else 49, 0.1, dim=dim, periodic=periodic), 1.0, seed=2)
    rule = edmd.physics.collide.TC(edmd.physics.collide.Inelastic(0.8), duration=1e-3)  # (no inelastic collapse on the floor)
    sim = Simulation(state, collision=rule, gravity=[0.0] * (dim - 1) + [-0.5], walls=edmd.physics.collide.Wall(e_n=0.9))
    sim.add(make())
    thermo = sim.add(Thermo(interval=0.1))
    sim.run(until_time=3.0)
    table = thermo.table()
    assert table["energy_input"][-1] != 0.0
    balance = table["energy_balance"]
    assert np.abs(balance - balance[0]).max() < 1e-10 * table["kinetic_energy"].max()
    assert table["dissipated_energy"][-1] > 0 and table["wall_collisions"][-1] > 0


def test_no_energy_input_column_without_updaters():
    sim = Simulation(gas(3), e_n=0.9)
    thermo = sim.add(Thermo(interval=0.5))
    sim.run(until_time=1.0)
    assert "energy_input" not in thermo.table()


@pytest.mark.parametrize("dim", [2, 3])
def test_split_runs_equal_one_run(dim):
    def run(cuts):
        sim = Simulation(gas(dim), e_n=0.8, forcing=WhiteNoise(xi0=0.8, interval=0.1, seed=3))
        sim.add(Jiggle(0.1, interval=0.3, seed=5))
        sim.add(VelocityRescale(kT=1.0, interval=0.7))
        for t in cuts:
            sim.run(until_time=t)
        return sim.state, sim.totals()

    (a, ta), (b, tb) = run([2.0]), run([0.33, 0.5, 1.234, 2.0])
    assert np.array_equal(a.position, b.position) and np.array_equal(a.velocity, b.velocity)
    assert ta == tb


@pytest.mark.parametrize("dim", [2, 3])
def test_restart_continues_the_random_stream_bit_for_bit(tmp_path, dim):
    def observers():
        return [Jiggle(0.1, interval=0.3, seed=5), VelocityRescale(kT=1.0, interval=0.7), Checkpoint(tmp_path / "c.gsd", interval=1.0)]

    sim = Simulation(gas(dim), e_n=0.8, forcing=WhiteNoise(xi0=0.8, interval=0.1, seed=3))
    for o in observers():
        sim.add(o)
    sim.run(until_time=1.0)
    sim.run(until_time=2.5)
    whole = sim.state
    again = load_checkpoint(tmp_path / "c.gsd", observers())  # the checkpoint of t = 2
    assert again.time == 2.0
    again.run(until_time=2.5)
    assert np.array_equal(again.state.position, whole.position) and np.array_equal(again.state.velocity, whole.velocity)
    assert again.totals() == sim.totals()


def test_bad_updater_arguments():
    with pytest.raises(ValueError, match="kT must be positive"):
        VelocityRescale(kT=0.0, interval=1.0)
    with pytest.raises(ValueError, match="seed must be a non-negative integer"):
        Jiggle(0.1, interval=1.0, seed=-2)
    sim = Simulation(edmd.lattice(64, 0.1), e_n=0.9)  # at rest: T = 0
    sim.add(VelocityRescale(kT=1.0, interval=0.5))
    with pytest.raises(ValueError, match="the temperature is 0"):
        sim.run(until_time=1.0)


def test_updaters_refuse_the_dem():
    from edmd import DEMSimulation, LinearDashpot

    sim = DEMSimulation(gas(3), contact=LinearDashpot.from_restitution(0.9, 1e4, mass=1.0))
    with pytest.raises(TypeError, match="VelocityRescale needs an event-driven Simulation"):
        sim.add(VelocityRescale(kT=1.0, interval=0.5))


CONFIG = """
[system]
dim = {dim}
n = 200
packing_fraction = 0.2
kT = 2.0
[collision]
rule = "inelastic"
e_n = 0.8
[thermostat]
kind = "rescale"
kT = 1.0
interval = 0.5
[run]
until_time = 3.0
output_interval = 0.5
progress = false
[output]
plots = false
"""


def test_rescale_from_the_config(tmp_path, dim):
    # [thermostat] kind = "rescale": thermo rows at the firing times see T = kT exactly
    from typer.testing import CliRunner

    from edmd.app.cli import app
    from edmd.files.thermo import read_thermo

    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG.format(dim=dim))
    r = CliRunner().invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run")])
    assert r.exit_code == 0, r.output
    table = read_thermo(tmp_path / "run" / "thermo.csv")
    assert np.allclose(table["temperature"][1:], 1.0, rtol=1e-12)
    balance = np.asarray(table["energy_balance"])
    assert np.ptp(balance) < 1e-9 * table["dissipated_energy"][-1]  # the input is booked


@pytest.mark.parametrize(
    "section, message",
    [
        ('kind = "rescale"\nkT = 1.0\n', "needs interval"),
        ('kind = "rescale"\nkT = 1.0\ninterval = 1.0\nrate = 2.0\n', "rate is not used"),
        ('kind = "andersen"\nkT = 1.0\n', "needs rate"),
    ],
)
def test_thermostat_config_errors(section, message):
    import tomllib

    with pytest.raises(edmd.ConfigError, match=message):
        edmd.parse_config(tomllib.loads("[thermostat]\n" + section))
