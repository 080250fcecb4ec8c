"""Checkpoints and restarts: exact round trips, bit-for-bit continuation (also after kill -9), errors."""

import shutil
import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import gsd.hoomd
import numpy as np
import pytest
from typer.testing import CliRunner

import edmd
import edmd.app.runner
from edmd import Thermo, Trajectory, read_thermo
from test_thermo import RUN_COLUMNS
from edmd.files.atomic import atomic_path
from edmd.files.checkpoint import Checkpoint, CheckpointError, load_checkpoint, read_checkpoint, save_checkpoint, save_final_state
from edmd.app.cli import app

FIELDS = ("position", "velocity", "radius", "mass", "box", "angular_velocity", "inertia", "image", "periodic")


def _initial(dim, eta):
    return edmd.maxwell_boltzmann(edmd.lattice(400, eta, dim=dim), 1.0, seed=5)


def _observers(d: Path, ck_interval=0.5, wall=None):
    return [
        Thermo(0.25, path=d / "thermo.csv"),
        Trajectory(d / "traj.gsd", 0.25),  # a frame at 2.25: past the checkpoint at 2.0 where "part" runs are cut
        Checkpoint(d / "ck.gsd", ck_interval, wall_interval=wall),
    ]


def _run(d: Path, state, until, e_n=1.0, engine=None, physics=None, **kw):
    d.mkdir(exist_ok=True)
    sim = edmd.Simulation(state, engine=engine, **(physics or {"e_n": e_n}))
    for o in _observers(d, **kw):
        sim.add(o)
    sim.run(until_time=until)
    sim.close()
    return sim


def assert_same_files(a: Path, b: Path, traj="traj.gsd"):
    """Thermo CSV byte for byte; every trajectory frame chunk for chunk, then the whole file byte for byte."""
    assert (a / "thermo.csv").read_bytes() == (b / "thermo.csv").read_bytes()
    with gsd.hoomd.open(a / traj) as fa, gsd.hoomd.open(b / traj) as fb:
        assert len(fa) == len(fb) > 1
        for x, y in zip(fa, fb):
            for attr in ("position", "velocity", "image", "angmom", "diameter", "mass"):
                assert np.array_equal(getattr(x.particles, attr), getattr(y.particles, attr)), attr
            assert x.log.keys() == y.log.keys()
            for k in x.log:
                assert np.array_equal(x.log[k], y.log[k]), k
    assert (a / traj).read_bytes() == (b / traj).read_bytes()


def test_checkpoint_holds_the_exact_state_and_engine(tmp_path, dim):
    s = edmd.maxwell_boltzmann(_initial(dim, 0.3), 1.0, seed=2, spin=True)
    sim = edmd.Simulation(s, e_n=0.8)
    sim.run(max_events=7000)
    save_checkpoint(sim, tmp_path / "c.gsd", metadata={"note": "x"})
    data = read_checkpoint(tmp_path / "c.gsd")
    now = sim.state
    for f in FIELDS:
        assert np.array_equal(getattr(data.state, f), getattr(now, f)), f
    assert data.time == sim.time and data.metadata == {"note": "x"}
    assert np.array_equal(data.arrays["counters"], sim.engine.cnt)
    assert np.array_equal(data.arrays["accumulators"], sim.engine.acc)
    again = load_checkpoint(tmp_path / "c.gsd")
    assert again.params == sim.params and again.time == sim.time
    assert again.totals() == sim.totals()
    assert again.engine.events_at_sync == sim.engine.events_at_sync
    assert again.engine.list_capacity == sim.engine.list_capacity


@pytest.mark.parametrize("mode", ["list", "cells"])
def test_a_restart_holds_one_copy_of_the_particles(tmp_path, mode):
    """A restart reads the state chunk by chunk and hands it over to the engine, which drops its
    positions, velocities and images as it takes them (loaded once, not twice). Before: 587 B per
    particle at the peak (gsd.hoomd's frame), then the State beside the engine's arrays."""
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(8000, 0.5), 1.0, seed=2), engine={"neighbours": mode})
    sim.run(max_events=16000)
    save_checkpoint(sim, tmp_path / "c.gsd")
    e = sim.engine
    engine = sum(a.nbytes for a in (*e.part, *e.ev, *e.q, *e.grid, *e.lists))
    state = sum(getattr(sim.state, f).nbytes for f in ("position", "velocity", "radius", "mass", "inertia", "image"))
    tracemalloc.start()
    try:
        again = load_checkpoint(tmp_path / "c.gsd")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert again.totals() == sim.totals() and np.array_equal(again.state.position, sim.state.position)
    assert peak <= engine + state, f"the restart peaked at {peak / 8000:.0f} B per particle; engine {engine / 8000:.0f}, state {state / 8000:.0f}"


@pytest.mark.parametrize("eta, mode", [(0.3, "list"), (0.04, "cells")])
def test_interrupted_run_continues_bit_for_bit(tmp_path, dim, eta, mode):
    s = _initial(dim, eta)
    every = 1.5 if mode == "list" else 0.3  # (wide dilute cells: few events per particle)
    engine = {"resync_every": every, "neighbours": mode}  # maintenance resyncs fall between checkpoints
    whole = _run(tmp_path / "whole", s, 4.0, e_n=0.9, engine=engine)
    part = _run(tmp_path / "part", s, 2.3, e_n=0.9, engine=engine)  # "interrupted" after t = 2.0
    assert read_checkpoint(tmp_path / "part" / "ck.gsd").time == 2.0
    sim = load_checkpoint(tmp_path / "part" / "ck.gsd", _observers(tmp_path / "part"))
    assert sim.time == 2.0 and part.time == 2.3
    sim.run(until_time=4.0)
    sim.close()
    assert_same_files(tmp_path / "whole", tmp_path / "part")
    assert sim.totals() == whole.totals()
    assert np.array_equal(sim.engine.cnt, whole.engine.cnt)
    assert whole.events > 3 * every * 400  # several maintenance resyncs on the way


def test_granular_run_with_tc_walls_and_gravity_restarts_bit_for_bit(tmp_path, dim):
    """Rough particles, TC memory, Coulomb walls and gravity all survive a checkpoint exactly."""
    from edmd import collide

    periodic = [True] * (dim - 1) + [False]
    s = edmd.random_packing(300, 0.2, dim=dim, periodic=periodic, seed=9, radius={"kind": "uniform", "min": 0.4, "max": 0.6}, density=1.0)
    s = edmd.maxwell_boltzmann(s, 1.0, seed=10, spin=True)
    g = np.zeros(dim)
    g[-1] = -0.5
    physics = {
        "collision": collide.TC(collide.Rough(collide.Viscoelastic(young=1e4, poisson=0.3, A=1e-3), beta=0.1), 0.05),
        "walls": collide.Wall(e_n=0.7, beta=0.0, mu=0.4),
        "gravity": g,
    }
    whole = _run(tmp_path / "whole", s, 4.0, physics=physics)
    _run(tmp_path / "part", s, 2.3, physics=physics)
    sim = load_checkpoint(tmp_path / "part" / "ck.gsd", _observers(tmp_path / "part"))
    assert np.isfinite(sim.state.last_collision).any()
    sim.run(until_time=4.0)
    sim.close()
    assert_same_files(tmp_path / "whole", tmp_path / "part")
    assert sim.totals() == whole.totals() and whole.engine.cnt[10] > 0  # TC was active
    assert whole.totals().wall_collisions > 50


@pytest.mark.parametrize("contacts", ["smooth", "frictional", "friction_table"])
def test_emdstar_run_with_pending_contacts_restarts_bit_for_bit(tmp_path, dim, contacts):
    """eMD* with walls and gravity: pending contacts (increments, B times, partners) survive a
    checkpoint (with the hard-limit table of frictional contacts, which a restart rebuilds)."""
    from edmd.physics.emdstar import EMDStar

    periodic = [True] * (dim - 1) + [False]
    # (seed 9 sends the tabled 3D run into a Zeno stall at t = 2.27: a particle left on the floor
    # by exception b) and a fallback collision with its former partner hops at 1e-4 speed)
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.2, dim=dim, periodic=periodic, seed=11), 1.0, seed=12, spin=contacts != "smooth")
    g = np.zeros(dim)
    g[-1] = -0.5
    friction = None if contacts == "smooth" else edmd.Friction(mu=0.3, law="mindlin")
    rule = EMDStar(edmd.Hertz(young=2e3, poisson=0.3, A=2e-3), friction=friction, friction_table=contacts == "friction_table")
    physics = {"collision": rule, "gravity": g}
    whole = _run(tmp_path / "whole", s, 4.0, physics=physics)
    _run(tmp_path / "part", s, 2.3, physics=physics)
    ck = read_checkpoint(tmp_path / "part" / "ck.gsd")
    assert ck.state.has_pending
    sim = load_checkpoint(tmp_path / "part" / "ck.gsd", _observers(tmp_path / "part"))
    sim.run(until_time=4.0)
    sim.close()
    assert_same_files(tmp_path / "whole", tmp_path / "part")
    assert sim.totals() == whole.totals()
    counters = whole.engine.emd_counters()
    assert counters["emd_contacts"] > 100 and whole.totals().wall_collisions > 10


def test_final_state_without_pending_contacts_beside_a_point_with_them(tmp_path):
    """GSD reads a log entry missing from frame 1 from frame 0: the final state must not inherit
    the checkpoint point's pending eMD* contacts."""
    from edmd.physics.emdstar import EMDStar

    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.2, dim=2, seed=9), 1.0, seed=10)
    sim = edmd.Simulation(s, collision=EMDStar(edmd.Hertz(young=2e3, poisson=0.3, A=2e-3)))
    sim.run(until_time=1.0)
    path = tmp_path / "ck.gsd"
    save_checkpoint(sim, path)
    point = sim.state
    assert point.has_pending
    fields = {f: getattr(point, f) for f in ("position", "velocity", "radius", "mass", "box", "time", "angular_velocity", "image", "periodic")}
    settled = edmd.State(**fields, check_overlaps=False)  # the same particles with no contact pending
    save_final_state(path, settled, sim.totals())
    ck = read_checkpoint(path)
    assert ck.state.has_pending and not ck.final.has_pending
    assert np.array_equal(ck.final.pending_partner, settled.pending_partner)


def test_wall_clock_interval_decides_only_what_is_written(tmp_path):
    s = _initial(3, 0.3)
    a = _run(tmp_path / "a", s, 2.0)
    b = _run(tmp_path / "b", s, 2.0, wall=3600.0)
    ck_a, ck_b = a.observers[-1], b.observers[-1]
    assert ck_a.writes == 5 and ck_b.writes == 2  # b: the first point and, at close, the last one
    assert_same_files(tmp_path / "a", tmp_path / "b")
    assert read_checkpoint(tmp_path / "b" / "ck.gsd").time == 2.0


def _late_observers(d: Path):
    """Output that begins after the checkpoint at t = 0.5 (``start``)."""
    return [Thermo(0.25, path=d / "thermo.csv", start=1.0), Trajectory(d / "traj.gsd", 0.25, start=1.0), Checkpoint(d / "ck.gsd", 0.5)]


@pytest.mark.parametrize("cut", [0.7, 1.1], ids=["before the first output", "after it"])
def test_restart_from_before_the_first_output_is_bit_for_bit(tmp_path, cut):
    """A checkpoint taken before the output's first time has no rows and no frames yet; the
    interrupted run may already have written some after it (cut at 1.1), which are dropped."""
    state = _initial(3, 0.2)
    for name, until in (("ref", 2.0), ("part", cut)):
        (tmp_path / name).mkdir()
        sim = edmd.Simulation(state, e_n=0.9)
        for o in _late_observers(tmp_path / name):
            sim.add(o)
        sim.run(until_time=until)
        sim.close()
    part = tmp_path / "part"
    shutil.copy(part / "ck.gsd", part / "ck0.gsd")  # the point at 0.5 (the run cut at 1.1 wrote one at 1.0)
    sim = load_checkpoint(part / "ck0.gsd", _late_observers(part))
    assert sim.time == (0.5 if cut < 1 else 1.0)
    sim.run(until_time=2.0)
    sim.close()
    assert_same_files(tmp_path / "ref", part)


def test_a_thermo_file_appended_to_keeps_its_earlier_rows_across_a_restart(tmp_path):
    """The checkpoint counts the file's rows instead of saving them (saving the table at every
    checkpoint made runs quadratic in their rows); a restart cuts the file back to that count, so
    the rows it held before the run stay (a restart rewrote it from this run's rows alone)."""
    earlier = ",".join(RUN_COLUMNS) + "\r\n" + ",".join("-1.0" if c == "time" else "0" for c in RUN_COLUMNS) + "\r\n"
    state = _initial(3, 0.2)
    for name, until in (("ref", 2.0), ("part", 1.2)):
        (tmp_path / name).mkdir()
        (tmp_path / name / "thermo.csv").write_text(earlier, newline="")
        sim = edmd.Simulation(state, e_n=0.9)
        sim.add(Thermo(0.25, path=tmp_path / name / "thermo.csv"))
        sim.add(Checkpoint(tmp_path / name / "ck.gsd", 0.5))
        sim.run(until_time=until)
        sim.close()
    part = tmp_path / "part"
    data = read_checkpoint(part / "ck.gsd")
    assert not any(k.endswith("/rows") for k in data.arrays) and data.meta["observers"][0]["data"]["file_rows"] == 6
    sim = load_checkpoint(part / "ck.gsd", [Thermo(0.25, path=part / "thermo.csv"), Checkpoint(part / "ck.gsd", 0.5)])
    assert [r["time"] for r in sim.observers[0].rows] == [0.0, 0.25, 0.5, 0.75, 1.0]
    sim.run(until_time=2.0)
    sim.close()
    assert (part / "thermo.csv").read_bytes() == (tmp_path / "ref" / "thermo.csv").read_bytes()
    assert read_thermo(part / "thermo.csv")["time"][:2].tolist() == [-1.0, 0.0]


def test_a_checkpoint_forces_the_rows_and_frames_it_counts_onto_the_disk(tmp_path, monkeypatch):
    """A power cut after a checkpoint must not lose frames or rows the checkpoint counts: the
    observers' files are fsynced before the checkpoint is written (flushing alone leaves them in
    the page cache)."""
    synced = []
    real = edmd.files.atomic._fsync
    monkeypatch.setattr(edmd.files.atomic, "_fsync", lambda path: synced.append(Path(path).name) or real(path))
    _run(tmp_path / "a", _initial(2, 0.3), 0.5)
    points = [k for k, name in enumerate(synced) if name.startswith(".ck.")]
    assert len(points) == 2  # t = 0 and 0.5
    for k in points:
        assert synced[k - 2 : k] == ["thermo.csv", "traj.gsd"]


def test_restarted_observers_must_match(tmp_path):
    _run(tmp_path / "a", _initial(2, 0.3), 1.0)
    ck = tmp_path / "a" / "ck.gsd"
    with pytest.raises(CheckpointError, match=r"saved with observers \['Thermo', 'Trajectory', 'Checkpoint'\]"):
        load_checkpoint(ck, [Thermo(0.25)])
    wrong = _observers(tmp_path / "a")
    wrong[0] = Thermo(0.3)
    with pytest.raises(CheckpointError, match="observer 0 .Thermo. cannot be restored: interval"):
        load_checkpoint(ck, wrong)


def test_bad_checkpoints_are_clear_errors(tmp_path):
    with pytest.raises(CheckpointError, match="no checkpoint file"):
        read_checkpoint(tmp_path / "missing.gsd")
    (tmp_path / "junk.gsd").write_bytes(b"\x00garbage" * 100)
    with pytest.raises(CheckpointError, match="not a readable checkpoint"):
        read_checkpoint(tmp_path / "junk.gsd")
    edmd.write_state(tmp_path / "plain.gsd", _initial(3, 0.1))
    with pytest.raises(CheckpointError, match="not an edmd checkpoint"):
        read_checkpoint(tmp_path / "plain.gsd")
    _run(tmp_path / "a", _initial(3, 0.3), 1.0)
    (tmp_path / "a" / "traj.gsd").unlink()
    with pytest.raises(CheckpointError, match="fewer than the 5 the checkpoint expects"):
        load_checkpoint(tmp_path / "a" / "ck.gsd", _observers(tmp_path / "a"))


def test_an_atomic_write_into_a_missing_folder_names_the_file_not_its_temporary(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"cannot write .*nodir/c\.gsd: there is no folder"):
        with atomic_path(tmp_path / "nodir" / "c.gsd"):
            pass


def test_atomic_write_keeps_the_old_file_on_failure(tmp_path):
    p = tmp_path / "f.txt"
    p.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(p) as tmp:
            tmp.write_text("half")
            raise RuntimeError("killed while writing")
    assert p.read_text() == "old"
    assert list(tmp_path.iterdir()) == [p]


CONFIG = """
[system]
dim = {dim}
n = 300
packing_fraction = 0.3
[collision]
rule = "inelastic"
e_n = 0.95
[run]
until_time = {until}
output_interval = 0.1
progress = false
[output]
trajectory_interval = 0.2
checkpoint_interval = {ck}
plots = false
{extra}"""

#: every driver on: the Andersen bath (per-particle events) and white-noise kicks (a global timer)
DRIVERS = """
[thermostat]
kind = "andersen"
kT = 1.0
rate = 0.5
seed = 3
[forcing]
kind = "white_noise"
xi0 = 0.5
interval = 0.03
seed = 4
"""


#: a vibrating wall (its phase is re-based at every resync)
VIBRATION = """
[walls]
axes = ["z"]
e_n = 0.9
[vibration]
axis = "z"
amplitude = 0.3
omega = 5.0
phase = -1.5707963267948966
"""


def _config(tmp_path, dim, until, ck=0.2, extra=""):
    p = tmp_path / f"c{until}.toml"
    p.write_text(CONFIG.format(dim=dim, until=until, ck=ck, extra=extra))
    return p


def test_cli_restart_extends_a_run_exactly(tmp_path, dim):
    runner = CliRunner()
    r = runner.invoke(app, ["run", str(_config(tmp_path, dim, 3.0)), "--out", str(tmp_path / "ref")])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["run", str(_config(tmp_path, dim, 1.6)), "--out", str(tmp_path / "x")])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["run", "--restart", str(tmp_path / "x"), "--until-time", "3.0"])
    assert r.exit_code == 0, r.output
    assert_same_files(tmp_path / "ref", tmp_path / "x", traj="trajectory.gsd")
    assert "until_time = 3.0" in (tmp_path / "x" / "config.toml").read_text()


def test_cli_restart_errors_are_clean(tmp_path):
    runner = CliRunner()
    r = runner.invoke(app, ["run", "--restart", str(tmp_path / "nothing")])
    assert r.exit_code == 2 and "no run directory" in r.output and "Traceback" not in r.output
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "checkpoint.gsd").write_bytes(b"broken")
    r = runner.invoke(app, ["run", "--restart", str(tmp_path / "d")])
    assert r.exit_code == 2 and "not a readable checkpoint" in r.output and "Traceback" not in r.output


#: Lees-Edwards shear (the images' offset travels in the checkpoint's state)
SHEAR = """
[shear]
rate = 0.4
"""


@pytest.mark.parametrize("extra", ["", DRIVERS, VIBRATION, SHEAR], ids=["plain", "bath+kicks", "vibrating wall", "shear"])
def test_kill_9_mid_run_then_restart_is_bit_for_bit(tmp_path, extra):
    """A child process runs "forever"; it is killed with SIGKILL after some checkpoints, then continued."""
    dim, t_end = 3, 3.0
    runner = CliRunner()
    # checkpoints every other frame: the kill often leaves frames past the last checkpoint,
    # which the restart cuts off and writes again (byte for byte)
    r = runner.invoke(app, ["run", str(_config(tmp_path, dim, t_end, ck=0.4, extra=extra)), "--out", str(tmp_path / "ref")])
    assert r.exit_code == 0, r.output  # also compiles the core (cached) before the child starts
    # the watch below reads checkpoints: compile what that takes now (with a cold numba cache its
    # first read took long enough for the child to run tens of time units past the window)
    read_checkpoint(tmp_path / "ref" / "checkpoint.gsd")
    out = tmp_path / "killed"
    # the child imports the same edmd as this process (installed or editable), so it finds the
    # compiled core in the same numba cache
    cmd = [sys.executable, "-m", "edmd", "run", str(_config(tmp_path, dim, 1e6, ck=0.4, extra=extra)), "--out", str(out), "--no-progress"]
    child = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    ck = out / "checkpoint.gsd"
    deadline = time.monotonic() + 300
    try:
        while time.monotonic() < deadline and child.poll() is None:
            if ck.exists() and read_checkpoint(ck).time >= 1.0:
                break
            time.sleep(0.02)
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait()
    assert child.returncode == -signal.SIGKILL, child.stderr.read().decode()
    t_ck = read_checkpoint(ck).time
    assert 1.0 <= t_ck < t_end, f"the child got to t = {t_ck} before the kill"
    r = runner.invoke(app, ["run", "--restart", str(out), "--until-time", str(t_end)])
    assert r.exit_code == 0, r.output
    assert_same_files(tmp_path / "ref", out, traj="trajectory.gsd")


def test_cli_interrupt_points_to_restart(tmp_path, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(edmd.app.runner, "run_directory", interrupted)
    r = CliRunner().invoke(app, ["run", str(_config(tmp_path, 2, 1.0)), "--out", str(tmp_path / "x")])
    assert r.exit_code == 130 and f"edmd run --restart {tmp_path / 'x'}" in " ".join(r.output.split())


def test_expanding_bed_with_an_intruder_restarts_bit_for_bit(tmp_path):
    """A bed under gravity with an intruder of ratio 8 in cells mode: its cells follow the bed's
    density at every resync, and with the intruder taken out they must keep fitting its block as
    the bed expands (the smallest cells when the cost model's do not). A checkpoint of the expanded
    bed then loads with the same grid and continues bit for bit (it once kept an old grid that a
    new Simulation of the same state refused: the restart failed)."""
    n = 1500
    radius = {"kind": "discrete", "values": [0.5, 4.0], "fractions": [n - 1, 1]}
    bed = edmd.random_packing(n, 0.25, dim=3, radius=radius, seed=1, periodic=[True, True, False])
    box = bed.box * [1.0, 1.0, 20.0]
    pos = bed.position + [0.0, 0.0, 0.5 * (bed.box[2] - box[2])]  # (at the floor of a tall box)
    s = edmd.State(position=pos, velocity=np.zeros_like(pos), radius=bed.radius, mass=bed.mass, box=box, periodic=[True, True, False])
    s = edmd.maxwell_boltzmann(s, 200.0, seed=2)
    kw = dict(gravity=[0.0, 0.0, -0.5], engine={"neighbours": "cells", "resync_every": 1.0})
    sim = edmd.Simulation(s, **kw)
    grid0 = sim.engine.grid_cells.copy()
    sim.run(until_time=20.0)
    assert np.ptp(sim.state.position[:, 2]) > 10 * bed.box[2] and sim.engine.grid.shape[5] == 1  # (expanded; the intruder taken out)
    save_checkpoint(sim, tmp_path / "c.gsd")
    again = load_checkpoint(tmp_path / "c.gsd")
    assert np.array_equal(again.engine.grid_cells, sim.engine.grid_cells) and np.array_equal(grid0, sim.engine.grid_cells)
    for run in (sim, again):
        run.run(until_time=22.0)
    assert np.array_equal(again.state.position, sim.state.position) and again.collisions == sim.collisions
