"""Run directories (edmd.app.runner): never lose or mix data, always leave the final state behind."""

import json
import math
import shutil

import numpy as np
import pytest

import edmd
import edmd.app.plots
from edmd.files.checkpoint import CheckpointError, read_checkpoint
from edmd.app.config import ConfigError, parse_config
from edmd.run.engine import CollapseError
from edmd.run.memory import MemoryLimitError
from edmd.app.runner import IgnoredKeyWarning, RunDirectoryError, TrajectorySizeWarning, restart_directory, run_directory
from edmd.files.trajectory import frame_count, read_state, trajectory_run_id


def small(dim=2, n=64, until=2.0, interval=0.5, **sections):
    data = {
        "system": {"dim": dim, "n": n, "packing_fraction": 0.3},
        "run": {"until_time": until, "output_interval": interval, "progress": False},
        "output": {"plots": False},
    }
    for name, values in sections.items():
        data.setdefault(name, {}).update(values)
    return parse_config(data)


def snapshot_files(out):
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.is_file()}


def test_an_existing_run_is_refused_without_force(tmp_path, dim):
    out = tmp_path / "run"
    run_directory(small(dim), out)
    before = snapshot_files(out)
    with pytest.raises(RunDirectoryError, match="already holds a run .*--restart .*--force"):
        run_directory(small(dim, n=100), out)
    assert snapshot_files(out) == before


def test_force_removes_every_file_of_the_old_run(tmp_path):
    out = tmp_path / "run"
    run_directory(small(), out)
    stale = ("temperature.png", "movie.gif", "summary.json", "viscosity.png", "shear_profile.png", "profile_z.csv")  # (steady, transport, shear)
    for name in stale:
        (out / name).write_bytes(b"old")
    (out / "notes.txt").write_text("mine")  # not a run file: kept
    run_directory(small(until=1.0, interval=0.5), out, force=True)
    names = {p.name for p in out.iterdir()}
    assert not names & (set(stale) - {"summary.json"})
    assert (out / "notes.txt").read_text() == "mine"
    assert json.loads((out / "summary.json").read_text())["time"] == 1.0


def test_a_directory_another_process_writes_into_is_refused(tmp_path):
    # the lock is taken before the (possibly long) set-up: two runs started together into one
    # directory once both succeeded, the second removing what the first had written
    out = tmp_path / "run"
    with edmd.app.runner.directory_lock(out):
        for attempt in (lambda: run_directory(small(), out), lambda: run_directory(small(), out, force=True)):
            with pytest.raises(RunDirectoryError, match="in use: another edmd process is writing into it"):
                attempt()
        assert not edmd.app.runner.run_files(out)
    run_directory(small(until=1.0), out)  # released
    with edmd.app.runner.directory_lock(out):
        with pytest.raises(RunDirectoryError, match="in use"):
            restart_directory(out, until_time=2.0)
    assert restart_directory(out, until_time=2.0)["time"] == 2.0


def test_a_file_system_without_locks_runs_unguarded_with_a_warning(tmp_path, monkeypatch):
    import errno

    def no_locks(handle, operation):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(edmd.app.runner.fcntl, "flock", no_locks)  # (Lustre's default, some NFS mounts)
    with pytest.warns(UserWarning, match="no file locks .*nothing stops a second run"):
        assert run_directory(small(until=1.0), tmp_path / "run")["time"] == 1.0


def test_images_of_the_user_are_not_a_run_and_stay(tmp_path):
    out = tmp_path / "project"
    out.mkdir()
    (out / "figure1.png").write_bytes(b"mine")
    (out / "talk.gif").write_bytes(b"mine")
    run_directory(small(until=1.0), out)  # not refused: no file of a run there
    (out / "snapshot.png").write_bytes(b"old")  # a figure edmd writes: stale once the run is replaced
    run_directory(small(until=1.0), out, force=True)
    assert (out / "figure1.png").read_bytes() == (out / "talk.gif").read_bytes() == b"mine"
    assert not (out / "snapshot.png").exists()


@pytest.mark.parametrize("collision", [{}, {"rule": "inelastic", "e_n": 0.9}])
def test_every_figure_of_a_run_is_a_run_file(tmp_path, collision):
    summary = run_directory(small(until=1.0, collision=collision, output={"plots": True}), tmp_path / "run")
    assert summary["plots"] and set(summary["plots"]) <= set(edmd.app.runner.RUN_FIGURES)


def test_a_run_without_thermo_and_trajectory_ends_with_its_summary(tmp_path):
    summary = run_directory(small(until=1.0, output={"thermo": False, "trajectory": False, "plots": True}), tmp_path / "run")
    assert summary["time"] == 1.0 and "plots" not in summary
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["time"] == 1.0


def test_a_failure_of_the_figures_keeps_the_summary_of_the_run(tmp_path, monkeypatch):
    def broken(run_dir):
        raise RuntimeError("no figures today")

    monkeypatch.setattr(edmd.app.plots, "plot_run", broken)
    with pytest.raises(RuntimeError, match="no figures today"):
        run_directory(small(until=1.0, output={"plots": True}), tmp_path / "run")
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["time"] == 1.0


@pytest.mark.parametrize("stop", ["off_grid", "max_events"])
def test_the_end_of_a_run_writes_a_final_frame_and_checkpoint(tmp_path, stop):
    cfg = small(until=0.5, interval=10.0) if stop == "off_grid" else small(until=50.0, interval=10.0, run={"max_events": 1000})
    out = tmp_path / "run"
    summary = run_directory(cfg, out)
    end = summary["time"]
    assert 0 < end <= 0.5 if stop == "off_grid" else 0 < end < 10.0
    assert frame_count(out / "trajectory.gsd") == 2
    assert read_state(out / "trajectory.gsd").time == end
    ck = read_checkpoint(out / "checkpoint.gsd")
    assert ck.final.time == end and ck.time == summary["checkpoint_time"] == 0.0  # restart point: t = 0
    assert np.array_equal(ck.final.position, read_state(out / "trajectory.gsd").position)
    assert ck.final_time == end and ck.final_events == summary["events"]
    lean = read_checkpoint(out / "checkpoint.gsd", final=False)  # (what a restart reads)
    assert lean.final is None and (lean.final_time, lean.final_events) == (end, ck.final_events)


def test_a_run_extended_after_an_off_grid_end_is_the_longer_run(tmp_path):
    short, long = tmp_path / "short", tmp_path / "long"
    run_directory(small(until=0.7, interval=0.5), short)
    restart_directory(short, until_time=2.0)
    run_directory(small(until=2.0, interval=0.5), long)
    for name in ("thermo.csv", "trajectory.gsd"):
        assert (short / name).read_bytes() == (long / name).read_bytes(), name


def test_a_restart_after_max_events_runs_max_events_more(tmp_path):
    # no checkpoint point between t = 0 and the end: the restart recomputes the first 3000 events
    # from the point at t = 0, then runs 3000 new ones (before, it ended where the run had ended)
    cfg = small(until=math.inf, interval=100.0, run={"max_events": 3000})
    out, ref = tmp_path / "run", tmp_path / "ref"
    first = run_directory(cfg, out)
    assert first["events"] == 3000 and first["checkpoint_time"] == 0.0
    assert restart_directory(out)["events"] == 6000
    run_directory(small(until=math.inf, interval=100.0, run={"max_events": 6000}), ref)
    for name in ("thermo.csv", "trajectory.gsd"):
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name


def test_a_thermo_row_cut_by_a_crash_is_written_again_on_restart(tmp_path):
    # a full disk or a node crash can leave half a row at the end of thermo.csv
    out, ref = tmp_path / "run", tmp_path / "ref"
    run_directory(small(until=1.7, interval=0.5, output={"checkpoint_interval": 1.0}), out)
    text = (out / "thermo.csv").read_bytes()
    (out / "thermo.csv").write_bytes(text[: text[:-1].rfind(b"\n") + 26])
    restart_directory(out, until_time=3.0)
    run_directory(small(until=3.0, interval=0.5, output={"checkpoint_interval": 1.0}), ref)
    for name in ("thermo.csv", "trajectory.gsd"):
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name


def test_walls_that_are_not_those_of_the_state_from_a_file_are_refused(tmp_path):
    # a fully periodic state with [walls] axes = ["y"] ran periodic, and its config.toml recorded the walls
    run_directory(small(until=0.5), tmp_path / "a")
    cfg = small(until=1.0, system={"from_file": str(tmp_path / "a" / "trajectory.gsd")}, walls={"axes": ["y"], "e_n": 0.5})
    with pytest.raises(ConfigError, match=r"trajectory.gsd has walls on the axes none, but walls.axes = \['y'\]"):
        run_directory(cfg, tmp_path / "b")


def test_a_foreign_checkpoint_is_refused_and_nothing_changes(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    run_directory(small(until=2.0), a)
    run_directory(small(n=100, until=1.0), b)
    shutil.copy(b / "checkpoint.gsd", a / "checkpoint.gsd")
    before = snapshot_files(a)
    with pytest.raises(RunDirectoryError, match="belongs to run .* another run"):
        restart_directory(a, until_time=3.0)
    assert snapshot_files(a) == before


def test_a_foreign_trajectory_is_refused(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    run_directory(small(until=1.0), a)
    run_directory(small(until=1.0, system={"seed": 7}), b)
    assert trajectory_run_id(a / "trajectory.gsd") in (a / "config.toml").read_text()
    shutil.copy(b / "trajectory.gsd", a / "trajectory.gsd")
    with pytest.raises(RunDirectoryError, match="trajectory.gsd was written by run .* different runs"):
        restart_directory(a, until_time=2.0)
    assert (a / "trajectory.gsd").read_bytes() == (b / "trajectory.gsd").read_bytes()


def test_a_foreign_thermo_file_is_refused(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    run_directory(small(until=1.0), a)
    run_directory(small(until=1.0, system={"seed": 7}), b)
    shutil.copy(b / "thermo.csv", a / "thermo.csv")
    with pytest.raises(RunDirectoryError, match="thermo.csv does not continue into .*different runs"):
        restart_directory(a, until_time=2.0)
    assert (a / "thermo.csv").read_bytes() == (b / "thermo.csv").read_bytes()


def test_restart_refuses_edits_to_the_physics(tmp_path):
    out = tmp_path / "run"
    run_directory(small(until=1.0), out)
    path = out / "config.toml"
    path.write_text(path.read_text().replace("n = 64", "n = 100").replace("packing_fraction = 0.3", "packing_fraction = 0.2"))
    before = snapshot_files(out)
    with pytest.raises(ConfigError, match=r"edited after the run started \(system.n: 64 -> 100; system.packing_fraction: 0.3 -> 0.2\)"):
        restart_directory(out)
    assert snapshot_files(out) == before


def test_restart_takes_and_records_a_new_end_time_from_the_config(tmp_path):
    out = tmp_path / "run"
    run_directory(small(until=1.0), out)
    path = out / "config.toml"
    path.write_text(path.read_text().replace("until_time = 1.0", "until_time = 2.0"))
    summary = restart_directory(out)
    assert summary["time"] == 2.0
    assert summary["restart_changes"] == {"run.until_time": [1.0, 2.0]}
    text = path.read_text()
    assert "# continued at t = 1.0: run.until_time 1.0 -> 2.0" in text and "until_time = 2.0" in text
    assert read_state(out / "trajectory.gsd").time == 2.0


def test_restart_until_a_time_before_the_checkpoint_is_an_error(tmp_path):
    out = tmp_path / "run"
    run_directory(small(until=1.0), out)
    with pytest.raises(ConfigError, match="not after the checkpoint time 1.0"):
        restart_directory(out, until_time=0.5)
    with pytest.raises(ConfigError, match=r"run\.until_time: Input should be greater than 0 \(got -5.0\)") as err:
        edmd.app.runner.set_key(small(), "run.until_time", -5.0)
    assert "errors.pydantic.dev" not in str(err.value)


def test_restart_to_an_end_the_run_passed_is_an_error_and_keeps_its_files(tmp_path):
    out = tmp_path / "run"
    run_directory(small(until=2.0, interval=0.5, output={"checkpoint_interval": 1.5}), out)  # point 1.5, end 2.0
    before = snapshot_files(out)
    with pytest.raises(ConfigError, match=r"--until-time 1.75 is before t = 2.0, where the run already ended"):
        restart_directory(out, until_time=1.75)
    path = out / "config.toml"
    path.write_text(path.read_text().replace("until_time = 2.0", "until_time = 1.75"))
    with pytest.raises(ConfigError, match=r"run.until_time = 1.75 is before t = 2.0"):
        restart_directory(out)
    path.write_bytes(before["config.toml"])
    with pytest.raises(ConfigError, match=r"the run is complete \(it reached run.until_time = 2.0\): give a later --until-time"):
        restart_directory(out)
    assert snapshot_files(out) == before


def test_an_end_time_before_the_time_of_a_from_file_state_is_an_error(tmp_path):
    run_directory(small(until=3.0), tmp_path / "first")
    cfg = small(until=2.0, system={"from_file": str(tmp_path / "first" / "trajectory.gsd")})
    with pytest.raises(ConfigError, match=r"run.until_time = 2.0 is not after the initial time 3.0 \(frame -1 of .*trajectory.gsd\)"):
        run_directory(cfg, tmp_path / "second")
    assert not (tmp_path / "second").exists()
    assert run_directory(small(until=4.0, system={"from_file": str(tmp_path / "first" / "trajectory.gsd")}), tmp_path / "third")["time"] == 4.0


@pytest.mark.parametrize(
    "sections, why",
    [
        ({"output": {"checkpoint": False}}, r"it ran with \[output\] checkpoint = false"),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "k": 1e4, "e_n": 0.8}}, "DEM runs write no checkpoint"),
    ],
)
def test_a_run_without_checkpoints_says_why_it_cannot_be_continued(tmp_path, sections, why):
    run_directory(small(until=0.2, **sections), tmp_path / "run")
    with pytest.raises(CheckpointError, match=f"cannot be continued: {why}; start a new run .* --from .*trajectory.gsd"):
        restart_directory(tmp_path / "run", until_time=1.0)


def test_a_collapse_saves_the_state_and_the_summary(tmp_path):
    # a ball on an inelastic floor, no TC: the bounces accumulate at a finite time (Zeno)
    cfg = parse_config(
        {
            "system": {"dim": 3, "n": 1, "packing_fraction": 1e-6, "radius": 0.001, "density": 7800.0, "kT": 0.0, "gravity": [0.0, 0.0, -9.81]},
            "walls": {"axes": ["x", "y", "z"], "e_n": 0.8},
            "run": {"until_time": 3.0, "output_interval": 0.5, "progress": False},
            "output": {"plots": False},
        }
    )
    out = tmp_path / "ball"
    with pytest.raises(CollapseError, match="error_state.gsd"):
        run_directory(cfg, out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and "CollapseError" in summary["error"]
    state = read_state(out / "error_state.gsd")
    # a drop from rest from height h onto a floor with restitution e ends at t_fall (1 + 2e/(1-e)); the
    # engine stops once bounces no longer advance the clock (remaining flight ~1e-8 of the total)
    h = 0.5 * state.box[2] - 0.001
    t_fall = np.sqrt(2 * h / 9.81)
    assert state.time == summary["error_time"] == pytest.approx(t_fall * (1 + 2 * 0.8 / 0.2), rel=1e-7)
    assert state.position[0, 2] == pytest.approx(-h, abs=1e-9)


def test_a_successful_restart_removes_the_error_state_of_a_failed_attempt(tmp_path):
    out = tmp_path / "run"
    run_directory(small(until=1.0), out)
    (out / "error_state.gsd").write_bytes(b"from a failed attempt")
    restart_directory(out, until_time=2.0)
    assert not (out / "error_state.gsd").exists()


def test_closed_boxes_report_wall_pressures(tmp_path):
    cfg = small(until=2.0, walls={"axes": ["y"]})
    summary = run_directory(cfg, tmp_path / "run")
    assert "pressure_mean" not in summary and summary["wall_pressure_y_mean"] > 0
    periodic = run_directory(small(until=2.0), tmp_path / "periodic")
    assert periodic["pressure_mean"] > 0 and not any(k.startswith("wall_pressure") for k in periodic)


def test_memory_guard_refuses_before_allocating(tmp_path):
    cfg = small(n=10**9)
    with pytest.raises(MemoryLimitError, match=r"N = 1e\+09 particles needs about .* GB"):
        run_directory(cfg, tmp_path / "big")
    with pytest.raises(MemoryLimitError, match="more than the limit of 0.001 GB"):
        run_directory(small(n=4000), tmp_path / "limited", max_memory="1M")
    assert not (tmp_path / "big").exists()


def test_a_large_trajectory_is_announced(tmp_path, monkeypatch):
    monkeypatch.setattr(edmd.app.runner, "TRAJECTORY_WARN_BYTES", 64 * 100 * 4)
    with pytest.warns(TrajectorySizeWarning, match=r"about .* GB \(6 frames of 64 particles\)"):
        run_directory(small(until=2.0), tmp_path / "run")


def test_a_new_run_warns_about_keys_without_effect_and_its_restart_does_not(tmp_path):
    import warnings

    with pytest.warns(IgnoredKeyWarning, match=r"1 key\(s\) .* no effect on this run: walls\.e_n: no walls"):
        run_directory(small(until=1.0, walls={"e_n": 0.8}), tmp_path / "run")
    with warnings.catch_warnings():
        warnings.simplefilter("error", IgnoredKeyWarning)  # (announced once, when the run started)
        restart_directory(tmp_path / "run", until_time=1.5)


def test_a_checkpoint_whose_config_newer_rules_reject_is_explained(tmp_path):
    import gsd.hoomd

    out = tmp_path / "run"
    run_directory(small(until=1.0, interval=0.5), out)
    path = out / "checkpoint.gsd"
    with gsd.hoomd.open(path) as f:
        frames = list(f)
    meta = json.loads(bytes(frames[0].log["checkpoint/meta"]).decode())
    meta["metadata"]["config"] = meta["metadata"]["config"].replace("seed = 1", 'seed = "1"')  # once accepted
    frames[0].log["checkpoint/meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)
    with gsd.hoomd.open(path, "w", precision="double") as f:
        for frame in frames:
            f.append(frame)
    with pytest.raises(edmd.files.checkpoint.CheckpointError, match=r"(?s)not valid for this edmd .*system\.seed.*--from trajectory\.gsd"):
        restart_directory(out, until_time=2.0)
