"""The command line: `edmd init`, `edmd run`, errors."""

import json

import numpy as np
from typer.testing import CliRunner

from edmd import Simulation, Trajectory, lattice, maxwell_boltzmann, read_state, read_thermo
from edmd.app.cli import app
from edmd.app.config import default_job

runner = CliRunner()

SMALL = """
[system]
dim = {dim}
n = 300
packing_fraction = 0.3
[run]
until_time = 2.0
output_interval = 0.5
progress = false
"""


def test_init_writes_a_config_that_runs(tmp_path):
    cfg = tmp_path / "edmd.toml"
    r = runner.invoke(app, ["init", str(cfg)])
    assert r.exit_code == 0 and cfg.exists()
    r = runner.invoke(app, ["init", str(cfg)])
    assert r.exit_code == 2 and "exists" in r.output


def test_messages_name_long_paths_whole(tmp_path):
    # a path wider than the terminal (80 columns without one) is printed on one line, so that it
    # can be copied (and the error names it whole too)
    deep = tmp_path / ("a_folder_with_a_long_name_" * 4)
    deep.mkdir()
    cfg = deep / "edmd.toml"
    assert len(str(cfg)) > 100
    r = runner.invoke(app, ["init", str(cfg)])
    assert r.exit_code == 0 and f"wrote {cfg}" in r.output
    r = runner.invoke(app, ["init", str(cfg)])
    assert r.exit_code == 2 and str(cfg) in r.output


def test_run_writes_the_run_directory(tmp_path, dim):
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=dim))
    out = tmp_path / "run"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    table = read_thermo(out / "thermo.csv")
    assert table["time"].tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]
    for col in ("time", "events", "collisions", "temperature", "pressure"):
        assert np.all(np.isfinite(table[col][1:]))
    final = read_state(out / "trajectory.gsd")
    assert final.time == 2.0 and final.dim == dim
    summary = json.loads((out / "summary.json").read_text())
    assert summary["collisions"] == int(table["collisions"][-1])
    assert (out / "config.toml").read_text().split("\n")[1] == "[system]"  # after the run id line


def test_config_error_exits_cleanly(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[system]\nn = 10\npacking_fractoin = 0.3\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "x")])
    assert r.exit_code == 2
    assert "did you mean 'packing_fraction'" in r.output
    assert "Traceback" not in r.output


def test_impossible_packing_fraction_is_explained(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[system]\nn = 100\npacking_fraction = 0.8\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "cannot be built" in r.output


def test_run_from_a_gsd_frame(tmp_path, dim):
    sim = Simulation(maxwell_boltzmann(lattice(200, 0.3, dim=dim), 1.0, seed=4))
    sim.add(Trajectory(tmp_path / "src.gsd", interval=0.5))
    sim.run(until_time=1.0)
    sim.close()
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=dim).replace("n = 300", "n = 5") + "[output]\nplots = false\n")
    out = tmp_path / "run"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--from", str(tmp_path / "src.gsd"), "--frame", "1"])
    assert r.exit_code == 0, r.output
    assert "[system] settings are ignored" in " ".join(r.output.split())
    start = read_state(out / "trajectory.gsd", 0)
    source = read_state(tmp_path / "src.gsd", 1)
    assert start.time == 0.5 and start.n == 200
    assert np.array_equal(start.velocity, source.velocity)
    assert read_thermo(out / "thermo.csv")["time"].tolist() == [0.5, 1.0, 1.5, 2.0]
    assert f'from_file = "{(tmp_path / "src.gsd").resolve()}"' in (out / "config.toml").read_text()
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--from", str(tmp_path / "nope.gsd")])
    assert r.exit_code == 2 and "no file" in r.output
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run2"), "--from", str(tmp_path / "src.gsd"), "--max-memory", "1K"])
    assert r.exit_code == 2 and "N = 200 particles needs about" in " ".join(r.output.split())  # the frame's N, not [system] n
    r = runner.invoke(app, ["run", "--restart", str(out), "--out", str(tmp_path / "z"), "--max-memory", "8G", "--frame", "0"])
    assert r.exit_code == 2 and "give no --frame, --out, --max-memory" in " ".join(r.output.split())


def test_export_command(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=2) + "[output]\nplots = false\n")
    runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run")])
    r = runner.invoke(app, ["export", str(tmp_path / "run"), str(tmp_path / "f.xyz"), "--frame", "2"])
    assert r.exit_code == 0, r.output
    assert "t = 1" in r.output and (tmp_path / "f.xyz").read_text().startswith("300\n")
    r = runner.invoke(app, ["export", str(tmp_path / "run"), str(tmp_path / "f.txt")])
    assert r.exit_code == 2 and "use a .xyz" in r.output and "Traceback" not in r.output
    thermo = (tmp_path / "run" / "thermo.csv").read_bytes()  # a run's own file (it was replaced by particle rows)
    r = runner.invoke(app, ["export", str(tmp_path / "run"), str(tmp_path / "run" / "thermo.csv")])
    assert r.exit_code == 2 and "thermo.csv exists; use --force" in " ".join(r.output.split())
    assert (tmp_path / "run" / "thermo.csv").read_bytes() == thermo
    r = runner.invoke(app, ["export", str(tmp_path / "run"), str(tmp_path / "f.xyz"), "--force"])
    assert r.exit_code == 0, r.output


def test_a_table_shape_that_is_not_numbers_names_the_option(tmp_path):
    r = runner.invoke(app, ["tables", "build", "--model", "dashpot", "--shape", "a,b,c", "--out", str(tmp_path / "t.npz")])
    assert r.exit_code == 2 and "--shape must be whole numbers" in " ".join(r.output.split()) and "Traceback" not in r.output, r.output


def test_outputs_into_missing_folders_are_refused_before_any_work(tmp_path):
    for args in (["init", str(tmp_path / "nodir" / "x.toml")], ["tables", "build", "--model", "dashpot", "--out", str(tmp_path / "nodir" / "t.npz")]):
        r = runner.invoke(app, args)
        assert r.exit_code == 2 and "there is no folder" in " ".join(r.output.split()) and "Traceback" not in r.output, r.output


def test_default_job_is_a_cooling_granular_gas():
    cfg = default_job()
    assert cfg.collision.rule == "inelastic" and cfg.collision.e_n < 1
    assert cfg.output.checkpoint and cfg.output.plots and cfg.run.progress


def _edmd(*args, cwd=None):
    """``edmd ARGS`` in a subprocess with stdout and stderr piped (not a terminal), as in a batch job."""
    import subprocess
    import sys

    cmd = [sys.executable, "-c", "from edmd.app.cli import app; app()", *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, timeout=600)


def test_cli_data_safety(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=2).replace("progress = false", "progress = true"))
    out = tmp_path / "run"
    first = _edmd("run", cfg, "--out", out, "--debug")
    assert first.returncode == 0, first.stderr
    progress = [line for line in first.stdout.splitlines() if line.startswith("edmd: ")]
    assert len(progress) >= 3 and progress[-1].startswith("edmd: 100.0%")  # plain lines in a batch log
    again = _edmd("run", cfg, "--out", out)
    assert again.returncode == 2 and "already holds a run" in again.stderr and "--force" in again.stderr
    assert _edmd("run", cfg, "--out", out, "--force").returncode == 0
    bad = _edmd("run", "--restart", out, "--until-time", "-5")
    assert bad.returncode == 2 and "--until-time -5.0 is not after the checkpoint time 2.0" in bad.stderr
    assert "pydantic" not in bad.stderr and "Traceback" not in bad.stderr
    big = _edmd("run", cfg, "--out", tmp_path / "big", "--max-memory", "1k")
    assert big.returncode == 2 and "more than the limit" in big.stderr


def test_cli_sweep_file_given_to_run_suggests_sweep(tmp_path):
    sweep = tmp_path / "s.toml"
    sweep.write_text('[base.system]\nn = 10\n[grid]\n"system.packing_fraction" = [0.1, 0.2]\n')
    r = runner.invoke(app, ["run", str(sweep), "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "edmd sweep" in r.output and "unknown key" not in r.output


def test_run_help_shows_section_names():
    r = runner.invoke(app, ["run", "--help"], env={"COLUMNS": "250"})
    assert "[system] settings are then ignored" in r.output and "( is then ignored" not in r.output


def test_cli_announces_a_large_trajectory(tmp_path, monkeypatch):
    import edmd.app.runner

    monkeypatch.setattr(edmd.app.runner, "TRAJECTORY_WARN_BYTES", 1)
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=2))
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run")])
    assert r.exit_code == 0 and "warning: trajectory.gsd will take about" in r.output
    assert "TrajectorySizeWarning" not in r.output  # one readable line, not Python's warning format


def test_cli_names_keys_without_effect(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=2) + "\n[integrator]\ndt = 0.001\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run")])
    assert r.exit_code == 0 and "warning: 1 key(s) of the configuration have no effect on this run: integrator.dt: used by" in r.output


def test_compile_warms_the_loop_of_a_feature_set():
    r = runner.invoke(app, ["compile", "plain", "walls", "bath", "--neighbours", "cells"])
    assert r.exit_code == 0, r.output
    assert "plain (cells):" in r.output and "walls (cells):" in r.output and "bath (cells):" in r.output
    r = runner.invoke(app, ["compile", "walls", "--neighbours", "cells"])  # now cached
    assert "walls (cells): already cached" in r.output
    runner.invoke(app, ["compile", "walls+vibration", "--neighbours", "cells"])
    r = runner.invoke(app, ["compile", "walls+vibration", "--neighbours", "cells"])  # (the cache check once used a geometry one entry short)
    assert "walls+vibration (cells): already cached" in r.output


def test_compile_also_warms_what_the_outputs_compile(monkeypatch):
    from edmd.app.precompile import compile_features, parse_features
    from edmd.run.engine import Engine

    called = []
    for name in ("sums", "stream"):
        method = getattr(Engine, name)
        monkeypatch.setattr(Engine, name, lambda self, *a, _m=method, _n=name, **k: called.append(_n) or _m(self, *a, **k))
    compile_features(parse_features("walls"), "cells")
    assert "sums" in called and "stream" in called  # (a thermo row's sums, a frame's streams: compiled per geometry)


def test_compile_takes_both_neighbour_structures_unless_told():
    # neighbours = "auto" may pick either; square wells and growth run with lists only
    r = runner.invoke(app, ["compile", "plain", "well"])
    assert r.exit_code == 0, r.output
    assert "plain (cells):" in r.output and "plain (lists):" in r.output and "well (lists):" in r.output and "well (cells)" not in r.output
    r = runner.invoke(app, ["compile", "grow", "--neighbours", "cells"])
    assert r.exit_code == 2 and "no variant to compile: grow, well run with lists only" in r.output
    r = runner.invoke(app, ["compile", "plain", "--neighbours", "lists"])
    assert r.exit_code == 2 and "neighbours must be cells, list or both, got 'lists'" in r.output


def test_compile_names_a_bad_feature():
    r = runner.invoke(app, ["compile", "walls+ruogh"])
    assert r.exit_code == 2 and "unknown feature 'ruogh'" in r.output
    r = runner.invoke(app, ["compile", "emdstar+soft"])
    assert r.exit_code == 2 and "cannot be combined" in r.output
    r = runner.invoke(app, ["compile", "vibration"])
    assert r.exit_code == 2 and "vibration needs walls" in r.output
    r = runner.invoke(app, ["compile", "grow+rough"])
    assert r.exit_code == 2 and "grow takes only walls" in r.output
    r = runner.invoke(app, ["compile", "shear+bath"])
    assert r.exit_code == 2 and "shear takes walls" in r.output
    r = runner.invoke(app, ["compile", "walls+debug"])
    assert r.exit_code == 2 and "debug mode is a run-time switch of every loop variant" in r.output


def test_compile_warms_the_vibrating_wall():
    r = runner.invoke(app, ["compile", "walls+vibration", "--neighbours", "cells"])
    assert r.exit_code == 0 and "walls+vibration (cells):" in r.output, r.output


def test_compile_warms_the_sheared_loop():
    r = runner.invoke(app, ["compile", "shear", "--neighbours", "cells"])
    assert r.exit_code == 0 and "plain+shear (cells):" in r.output, r.output


def test_run_says_when_it_compiles_its_loop(tmp_path, monkeypatch):
    import edmd.run.engine

    monkeypatch.setattr(edmd.run.engine, "in_disk_cache", lambda dispatcher, arg=None: False)  # as on a fresh install
    monkeypatch.setattr(edmd._core.loop, "_VARIANTS", {})  # and in a fresh process
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=2))
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run"), "--no-progress"])
    assert r.exit_code == 0, r.output
    assert "compiling the event loop for plain runs" in r.output
    import logging  # the notice handler is gone with the command (the CLI may run inside a program)

    assert not logging.getLogger("edmd.compile").handlers


def _run(tmp_path, config: str, *options):
    """Write ``config`` to a file and run it into ``tmp_path / "run"``; returns the file and the run directory."""
    cfg, run = tmp_path / "c.toml", tmp_path / "run"
    cfg.write_text(config)
    assert runner.invoke(app, ["run", str(cfg), "--out", str(run), *options]).exit_code == 0
    return cfg, run


def test_steady_prints_blocked_averages_and_writes_a_profile(tmp_path):
    _cfg, run = _run(
        tmp_path,
        "[system]\ndim = 2\nn = 400\npacking_fraction = 0.1\nkT = 0.3\n[collision]\nrule = \"inelastic\"\ne_n = 0.8\n"
        "[forcing]\nkind = \"white_noise\"\nxi0 = 0.5\ninterval = 0.05\n[run]\nuntil_time = 40.0\noutput_interval = 0.5\nprogress = false\n",
    )
    r = runner.invoke(app, ["steady", str(run), "--settle", "10", "--profile", "y", "--bins", "4"])
    assert r.exit_code == 0, r.output
    assert "temperature" in r.output and "pressure" in r.output and "profile_y.csv" in r.output
    rows = (run / "profile_y.csv").read_text().splitlines()
    assert rows[0] == "y,density,temperature,velocity_x,velocity_y" and len(rows) == 5
    r = runner.invoke(app, ["steady", str(run), "-c", "kinetic"])
    assert r.exit_code == 2 and "no column 'kinetic'" in r.output
    r = runner.invoke(app, ["steady", str(run), "--settle", "39"])
    assert r.exit_code == 2 and "the error estimate needs at least 32" in r.output


def test_a_vibrating_wall_run_says_when_it_compiles(monkeypatch, caplog):
    # the walls variant compiled for a plain geometry is not the one of a vibrating wall's
    import logging

    import edmd
    import edmd.run.engine

    monkeypatch.setattr(edmd._core.loop, "_VARIANTS", {})  # a fresh process (the disk cache is looked at)
    seen = []
    monkeypatch.setattr(edmd.run.engine, "in_disk_cache", lambda dispatcher, arg=None: seen.append(len(arg[1])) or False)
    caplog.set_level(logging.INFO, logger="edmd.compile")
    state = edmd.random_packing(20, 0.05, dim=2, seed=1, periodic=[True, False])
    edmd.Simulation(state, vibration=edmd.VibratingWall(0.1, 1.0, phase=-1.5707963267948966, axis="y"))
    assert seen == [17] and any("walls+vibration runs" in m for m in caplog.messages)


def test_compress_writes_a_packing_directory(tmp_path, dim):
    """`edmd compress` to the configured packing fraction (the packing runs with `edmd run --from`), then to jamming."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=dim).replace("n = 300", "n = 150"))
    out = tmp_path / "packing"
    r = runner.invoke(app, ["compress", str(cfg), "--out", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    summary = json.loads((out / "summary.json").read_text())
    packing = read_state(out / "packing.gsd")
    assert summary["reached"] == "packing_fraction" and abs(packing.packing_fraction - 0.3) < 1e-12
    assert np.all(packing.radius == 0.5) and packing.time == 0.0  # scaled back to the configured radii
    rows = np.genfromtxt(out / "compression.csv", delimiter=",", names=True)
    assert rows.dtype.names == ("time", "packing_fraction", "pressure", "collisions", "collision_rate") and np.all(np.diff(rows["packing_fraction"]) > 0)
    assert np.all(rows["collision_rate"][1:] > 0) and np.isnan(rows["collision_rate"][0])
    assert (out / "compression.png").exists() and not (out / "contacts.png").exists()
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run"), "--from", str(out / "packing.gsd"), "--no-progress"])
    assert r.exit_code == 0, r.output
    for command, into, holds in (("compress", "run", "holds a run of `edmd run`"), ("run", "packing", "holds a packing of `edmd compress`")):
        r = runner.invoke(app, [command, str(cfg), "--out", str(tmp_path / into), "--no-progress", "--force"])  # (--force mixed the two)
        assert r.exit_code == 2 and holds in " ".join(r.output.split()), r.output
    r = runner.invoke(app, ["compress", str(cfg), "--out", str(out), "--jam", "--no-progress"])
    assert r.exit_code == 2 and "--force" in r.output
    r = runner.invoke(app, ["compress", str(cfg), "--out", str(out), "--jam", "--no-progress", "--force", "--rate", "0.05"])
    assert r.exit_code == 0, r.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reached"] == "pressure" and summary["pressure"] >= 1e12 and summary["rate"] == 0.05
    assert abs(summary["mean_contact_number"] / (2 * dim) - 1) < 0.03 and (out / "contacts.png").exists()


def test_compress_names_bad_targets_and_grows_between_walls(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=3))
    bad = ((["--to", "0.8"], "close packing"), (["--jam", "--pressure", "10"], "not both"), (["--pressure", "0.5"], "above 1"),
           (["--gap", "1e-6"], "--gap goes with"), (["--frame", "3"], "give --from too"), (["--jam", "--gap", "-1"], "must be positive"), (["--speed", "0.1"], "--speed goes with"), (["--film", "z", "--rate", "0.1"], "its wall moves"),
           (["--to", "-0.1"], "must be in (0, 1), got -0.1"))  # fmt: skip
    for args, words in bad:
        r = runner.invoke(app, ["compress", str(cfg), "--out", str(tmp_path / "p"), "--no-progress", *args])
        assert r.exit_code == 2 and words in r.output, (args, r.output)
    cfg.write_text(SMALL.format(dim=3) + '[walls]\naxes = ["z"]\n')
    r = runner.invoke(app, ["compress", str(cfg), "--out", str(tmp_path / "p"), "--no-progress"])
    assert r.exit_code == 0 and list(read_state(tmp_path / "p" / "packing.gsd").periodic) == [True, True, False]  # between walls


def test_compress_squeezes_a_film_between_walls(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL.format(dim=2).replace("n = 300", "n = 200") + '[walls]\naxes = ["y"]\n')
    out = tmp_path / "film"
    r = runner.invoke(app, ["compress", str(cfg), "--out", str(out), "--film", "y", "--to", "0.5", "--no-progress"])
    assert r.exit_code == 0, r.output
    film = read_state(out / "packing.gsd")
    summary = json.loads((out / "summary.json").read_text())
    assert abs(film.packing_fraction - 0.5) < 1e-12 and summary["separation"] == film.box[1] and list(film.periodic) == [True, False]
    assert abs(film.box[0] / film.box[1] - 1.0) < 1e-12  # the configured (square) box
    r = runner.invoke(app, ["compress", str(cfg), "--out", str(tmp_path / "f2"), "--film", "x", "--no-progress"])
    assert r.exit_code == 2 and "closed by walls" in r.output


def test_transport_prints_viscosity_and_diffusion_beside_enskog(tmp_path):
    config = (
        "[system]\ndim = 3\nn = 108\npacking_fraction = 0.2618\nkT = 1.0\n[collision]\nrule = \"inelastic\"\ne_n = 1.0\n"
        "[run]\nuntil_time = 150.0\noutput_interval = 0.25\nprogress = false\n[output]\nplots = false\ncheckpoint = false\n"
    )
    _cfg, run = _run(tmp_path, config)
    r = runner.invoke(app, ["transport", str(run), "--settle", "10", "--lag-max", "2"])
    assert r.exit_code == 0, r.output
    assert all(name in r.output for name in ("shear viscosity", "thermal conductivity", "self-diffusion"))
    assert (run / "viscosity.png").exists() and (run / "conductivity.png").exists()
    r = runner.invoke(app, ["transport", str(run), "--settle", "140", "--lag-max", "2"])
    assert r.exit_code == 2 and "too few" in r.output
    # under gravity the energy flux is not kept: the other coefficients are still reported
    config = config.replace("kT = 1.0\n", "kT = 1.0\ngravity = [0.0, 0.0, -0.01]\n").replace("[run]", "[walls]\naxes = [\"z\"]\n[run]")
    _run(tmp_path, config.replace("150.0", "60.0"), "--force")
    r = runner.invoke(app, ["transport", str(run), "--settle", "10", "--lag-max", "1"])
    assert r.exit_code == 2 and "thermal conductivity: the thermo table has no energy flux" in r.output.replace("\n", "")
    assert "shear viscosity" in r.output and (run / "viscosity.png").exists()
