"""The command line: `edmd init`, `edmd run`, errors."""

import json

import numpy as np
from typer.testing import CliRunner

from edmd import read_state, read_thermo
from edmd.cli import app

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
    assert (out / "config.toml").read_text().startswith("[system]")


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
