"""Square wells (docs/physics.md §2.5): capture, release and bounce events with a per-pair capture map."""

import math

import numpy as np
import pytest

import edmd
from edmd import SquareWell, Simulation, State
from edmd._core import layout as L
from edmd._core.wells import edge_exit_time
from edmd.files.checkpoint import Checkpoint, load_checkpoint
from edmd.files.trajectory import read_state, write_state
from edmd.physics.emdstar import EMDStar
from edmd.state import StateError

WELL = SquareWell(width=1.5, depth=1.0)


def pair_state(dim, r0, v, box=10.0):
    """Two unit disks/spheres (R = 0.5, m = 1) on the x axis at distance ``r0``, velocities ``+-v`` along x."""
    pos = np.zeros((2, dim))
    vel = np.zeros((2, dim))
    pos[0, 0], pos[1, 0] = -0.5 * r0, 0.5 * r0
    vel[0, 0], vel[1, 0] = v, -v
    return State(position=pos, velocity=vel, radius=0.5, mass=1.0, box=[box] * dim)


def counts(sim):
    c = sim.engine.cnt
    return int(c[L.C_WELL_IN]), int(c[L.C_WELL_OUT]), int(c[L.C_WELL_BOUNCE]), sim.collisions


def test_a_head_on_pair_is_captured_reflected_and_released(dim):
    """W-SW: approach speed 1, mu = 1/2, epsilon = 1: captured at 1.5 with speed sqrt(5), reflected by the
    elastic core at 1, released at 1.5 with speed 1 again."""
    sim = Simulation(pair_state(dim, 2.0, 0.5), well=WELL, engine={"debug": True})
    t_capture = 0.5
    t_core = t_capture + 0.5 / math.sqrt(5.0)
    t_release = t_core + 0.5 / math.sqrt(5.0)
    sim.run(until_time=0.5 * (t_capture + t_core))
    assert counts(sim) == (1, 0, 0, 0)
    assert sim.state.velocity[0, 0] == pytest.approx(0.5 * math.sqrt(5.0), rel=1e-14)
    assert sim.well_energy == -1.0 and sim.state.captured_pairs.tolist() == [[0, 1]]
    sim.run(until_time=t_release + 1.0)
    assert counts(sim) == (1, 1, 0, 1)
    assert sim.state.velocity[0, 0] == pytest.approx(-0.5, rel=1e-14)
    gap = sim.state.position[1, 0] - sim.state.position[0, 0]
    assert gap == pytest.approx(1.5 + 1.0, rel=1e-13)  # one time unit at relative speed 1 after the release
    assert sim.well_energy == 0.0 and sim.state.captured_pairs.shape == (0, 2)


def test_a_pair_too_slow_to_escape_bounces_inside_its_well(dim):
    """Inside the well moving apart at g = 1 (mu g^2 / 2 = 1/4 < epsilon = 1): bounced at 1.5, reflected
    by the core at 1: a sawtooth of period 1 between the core and the edge."""
    sim = Simulation(pair_state(dim, 1.25, -0.5), well=WELL, engine={"debug": True})
    assert sim.state.captured_pairs.tolist() == [[0, 1]]  # captured by distance: the state had no record
    sim.run(until_time=10.1)
    assert counts(sim) == (0, 0, 10, 10)
    gap = sim.state.position[1, 0] - sim.state.position[0, 0]
    assert gap == pytest.approx(1.25 + 0.1, rel=1e-12)  # t = 10.1: ten periods, then 0.1 moving apart
    assert sim.state.kinetic_energy() == pytest.approx(0.25, rel=1e-13)


def brute_force_captured(state, edge):
    """Pairs closer than ``edge`` times their contact distance, by the minimum image over all pairs."""
    d = state.position[:, None, :] - state.position[None, :, :]
    box = state.box
    d -= np.where(state.periodic, box * np.round(d / box), 0.0)
    r = np.linalg.norm(d, axis=2) / (state.radius[:, None] + state.radius[None, :])
    i, j = np.nonzero(np.triu(r < edge, 1))
    return {(int(a), int(b)) for a, b in zip(i, j)}, r


@pytest.mark.parametrize("walls", [False, True])
def test_a_gas_conserves_energy_and_its_capture_map_is_its_geometry(dim, walls):
    """Kinetic - epsilon N_captured stays constant; at every frame the captured pairs are exactly the
    pairs inside the edge (up to pairs within round-off of it); polydisperse, debug checks on."""
    periodic = [True] * dim
    if walls:
        periodic[0] = False
    state = edmd.random_packing(300, 0.2, dim=dim, periodic=periodic, seed=4, radius={"kind": "uniform", "min": 0.4, "max": 0.6})
    state = edmd.maxwell_boltzmann(state, kT=1.0, seed=5)
    sim = Simulation(state, well=SquareWell(width=1.4, depth=0.7), engine={"debug": True})
    energy = sim.state.kinetic_energy() + sim.well_energy
    for k in range(1, 9):
        sim.run(until_time=0.5 * k)
        s = sim.state
        assert s.kinetic_energy() + sim.well_energy == pytest.approx(energy, rel=1e-11)
        inside, r = brute_force_captured(s, 1.4)
        recorded = {tuple(p) for p in s.captured_pairs.tolist()}
        for i, j in inside ^ recorded:
            assert abs(r[i, j] - 1.4) < 1e-9, (i, j, r[i, j])
        assert len(recorded) == pytest.approx(-sim.well_energy / 0.7, rel=1e-12)
    c = counts(sim)
    assert c[0] > 500 and c[1] > 500 and c[2] > 50 and c[3] > 500


@pytest.mark.parametrize("dim", [2, 3])
def test_the_pair_distribution_jumps_by_the_boltzmann_factor_at_the_edge(dim):
    """g(lambda sigma-) / g(lambda sigma+) = exp(epsilon / kT) (physics.md §2.5): pairs counted in thin
    shells just inside and just outside the edge over many frames."""
    n, width, depth, shell = 500, 1.5, 0.5, 0.03
    state = edmd.maxwell_boltzmann(edmd.random_packing(n, 0.1, dim=dim, seed=6), kT=1.0, seed=7)
    sim = Simulation(state, well=SquareWell(width=width, depth=depth))
    sim.run(until_time=20.0)
    inner = outer = 0
    temps = []
    for k in range(400):
        sim.run(until_time=20.0 + 0.25 * (k + 1))
        s = sim.state
        _inside, r = brute_force_captured(s, width)
        r = r[np.triu_indices(n, 1)]
        inner += int(np.count_nonzero((r >= width - shell) & (r < width)))
        outer += int(np.count_nonzero((r >= width) & (r < width + shell)))
        temps.append(s.temperature())
    kT = float(np.mean(temps))
    volume = (lambda a, b: b**dim - a**dim)
    expected = math.exp(depth / kT) * volume(width - shell, width) / volume(width, width + shell)
    ratio = inner / outer
    error = ratio * math.sqrt(1.0 / inner + 1.0 / outer)  # counting statistics (frames are ~1 collision time apart)
    assert abs(ratio - expected) < 4.0 * error + 0.02 * expected, (ratio, expected, error, kT)
    assert abs(ratio / (volume(width - shell, width) / volume(width, width + shell)) - 1.0) > 0.3  # the jump is there


def test_restarts_are_bit_for_bit_and_files_keep_the_capture_map(tmp_path, dim):
    state = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.25, dim=dim, seed=8), kT=1.0, seed=9)
    sim = Simulation(state, well=WELL)
    sim.add(Checkpoint(tmp_path / "ck.gsd", interval=1.0))
    sim.run(until_time=1.0)
    frozen = (tmp_path / "ck.gsd").read_bytes()
    sim.run(until_time=3.0)
    (tmp_path / "ck.gsd").write_bytes(frozen)
    again = load_checkpoint(tmp_path / "ck.gsd", [Checkpoint(tmp_path / "ck2.gsd", interval=1.0)])
    again.run(until_time=3.0)
    a, b = sim.state, again.state
    assert np.array_equal(a.position, b.position) and np.array_equal(a.velocity, b.velocity)
    assert np.array_equal(a.captured_pairs, b.captured_pairs) and len(a.captured_pairs) > 10
    assert counts(sim) == counts(again)
    write_state(tmp_path / "final.gsd", a)
    last = read_state(tmp_path / "final.gsd")
    assert np.array_equal(last.captured_pairs, a.captured_pairs)
    assert Simulation(last, well=WELL).well_energy == sim.well_energy


def test_bad_input_is_named(dim):
    with pytest.raises(ValueError, match="width"):
        SquareWell(width=1.0, depth=1.0)
    with pytest.raises(ValueError, match="depth"):
        SquareWell(width=1.5, depth=0.0)
    state = pair_state(dim, 2.0, 0.5)
    with pytest.raises(StateError, match="neighbours='list'"):
        Simulation(state, well=WELL, engine={"neighbours": "cells"})
    with pytest.raises(StateError, match="eMD"):
        Simulation(state, well=WELL, collision=EMDStar(edmd.Hertz(1e5, 0.3)))
    with pytest.raises(StateError, match="two distinct particles"):
        State(state.position, state.velocity, 0.5, 1.0, state.box, captured_pairs=[[0, 2]])
    with pytest.raises(StateError, match="twice"):
        State(state.position, state.velocity, 0.5, 1.0, state.box, captured_pairs=[[0, 1], [1, 0]])
    with pytest.raises(TypeError, match="SquareWell"):
        Simulation(state, well=1.5)


def test_square_wells_from_the_command_line(tmp_path):
    """``[well]`` in a run file: the run's thermo.csv keeps its energy balance and its frames the captured pairs."""
    from typer.testing import CliRunner

    from edmd.app.cli import app

    (tmp_path / "sw.toml").write_text(
        "[system]\ndim = 2\nn = 200\npacking_fraction = 0.3\nseed = 3\n[well]\nwidth = 1.5\ndepth = 1.0\n"
        "[run]\nuntil_time = 4.0\noutput_interval = 1.0\nprogress = false\n[output]\nplots = false\n"
    )
    result = CliRunner().invoke(app, ["run", str(tmp_path / "sw.toml"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    table = np.genfromtxt(tmp_path / "out" / "thermo.csv", delimiter=",", names=True)
    assert np.all(table["potential_energy"][1:] < 0.0)
    assert np.allclose(table["energy_balance"], table["energy_balance"][0], rtol=1e-11)
    last = read_state(tmp_path / "out" / "trajectory.gsd")
    assert len(last.captured_pairs) == -table["potential_energy"][-1]
    with pytest.raises(edmd.ConfigError, match="width"):
        edmd.parse_config({"well": {"width": 0.9, "depth": 1.0}})


def test_a_pair_grazing_the_edge_from_inside_keeps_the_clock_moving(dim):
    """Captured, one ulp inside the edge and moving along it: its exits are grazing bounces, each a
    little later (a predictor that answered 0 for them stalled the run, physics.md §2.5). The pair
    creeps along the edge in bounces of a tiny angle (a whispering-gallery orbit): many events per
    unit time, so the run is short."""
    r = 1.5
    for _ in range(3):
        r = float(np.nextafter(r, 0.0))
        pos = np.zeros((2, dim))
        vel = np.zeros((2, dim))
        pos[1, 1] = r
        vel[1, 0] = 1.0
        sim = Simulation(State(pos, vel, 0.5, 1.0, [20.0] * dim), well=WELL)
        sim.run(until_time=0.01)
        assert sim.time == 0.01 and sim.well_energy == -1.0 and sim.engine.cnt[L.C_WELL_BOUNCE] > 100


def test_edge_exit_time_of_slow_and_ordinary_pairs():
    assert edge_exit_time(0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.5) == 0.5  # inside, moving out
    assert edge_exit_time(0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 1.5) == 2.5  # inside, moving in: through the core's plane
    assert edge_exit_time(0.0, 1.6, 0.0, 0.0, 1.0, 0.0, 1.5) == 0.0  # beyond by round-off, moving out: now
    assert edge_exit_time(0.0, 1.0, 0.0, 0.0, 1e-140, 0.0, 1.5) == pytest.approx(5e139, rel=1e-12)
    # found by a search over tiny speeds: b^2 - ac underflowed to 0 and the pair, deep inside its
    # well (|d| = 1.33 < 1.5), was told to leave now; the exact exit is ~1e162 time units away
    d, g = (0.822068, -0.88522987, 0.55108277), (-5.99586393e-163, -8.63910627e-163, 1.93316919e-162)
    assert edge_exit_time(*d, *g, 1.5) == math.inf


def test_a_capture_map_that_is_not_the_geometry_is_refused(dim):
    far = pair_state(dim, 4.0, 0.3)
    with pytest.raises(StateError, match="captured but beyond the edge"):
        Simulation(State(far.position, far.velocity, 0.5, 1.0, far.box, captured_pairs=[[0, 1]]), well=WELL)
    near = pair_state(dim, 1.2, 0.3)
    with pytest.raises(StateError, match="inside the edge but not captured"):
        Simulation(State(near.position, near.velocity, 0.5, 1.0, near.box, captured_pairs=np.zeros((0, 2), int)), well=WELL)
    wide = Simulation(edmd.maxwell_boltzmann(edmd.random_packing(200, 0.3, dim=dim, seed=1), kT=0.6, seed=2), well=WELL)
    wide.run(until_time=2.0)
    with pytest.raises(StateError, match="another state or well width"):
        Simulation(wide.state, well=SquareWell(width=1.2, depth=1.0))
