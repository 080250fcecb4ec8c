"""wall_impacts.csv ([output] wall_impacts, files/impacts.py): the impacts of a vibrated bed, byte for
byte across a restart, and their phase statistics from `edmd steady --impacts`."""

import math

import numpy as np
from typer.testing import CliRunner

from edmd.app.cli import app
from edmd.files.impacts import read_wall_impacts

CONFIG = """
[system]
dim = 2
n = 100
packing_fraction = 0.05
init = "random"
kT = 1.0
gravity = [0.0, -1.0]
[collision]
rule = "inelastic"
e_n = 0.9
tc = 1e-3
[walls]
axes = ["y"]
e_n = 0.9
[vibration]
axis = "y"
amplitude = 0.5
omega = 3.0
phase = -1.5707963267948966
[run]
until_time = {until}
output_interval = 0.25
progress = false
[output]
plots = false
wall_impacts = true
"""

runner = CliRunner()


def _run(tmp_path, name, until):
    cfg = tmp_path / f"{name}.toml"
    cfg.write_text(CONFIG.format(until=until))
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / name)])
    assert r.exit_code == 0, r.output
    return tmp_path / name


def test_wall_impacts_restart_byte_for_byte_and_phase_statistics(tmp_path):
    ref = _run(tmp_path, "ref", 20.0)
    rows = read_wall_impacts(ref / "wall_impacts.csv")
    assert len(rows) > 100 and set(np.unique(rows[:, 2])) <= {2.0, 3.0}  # the floor and the lid of y
    assert np.all(np.diff(rows[:, 0]) >= 0) and np.all(rows[:, 3] > 0)
    part = _run(tmp_path, "part", 9.7)
    r = runner.invoke(app, ["run", "--restart", str(part), "--until-time", "20.0"])
    assert r.exit_code == 0, r.output
    assert (part / "wall_impacts.csv").read_bytes() == (ref / "wall_impacts.csv").read_bytes()
    r = runner.invoke(app, ["steady", str(ref), "--settle", "5", "--impacts"])
    assert r.exit_code == 0, r.output
    assert "impacts on the vibrating wall" in r.output and (ref / "impact_phases.png").exists()
    floor = rows[(rows[:, 2] == 2.0) & (rows[:, 0] >= 5.0)]
    assert f"{floor.shape[0]} impacts" in r.output
    # the floor meets particles while it rises into the bed: mostly in the rising half of its cycle
    phase = np.mod(3.0 * floor[:, 0] - 0.5 * math.pi, 2 * math.pi)
    rising = (phase < 0.5 * math.pi) | (phase > 1.5 * math.pi)
    assert rising.mean() > 0.6


def test_impacts_need_the_file_and_a_vibrating_wall(tmp_path):
    ref = _run(tmp_path, "ref", 10.0)
    (ref / "wall_impacts.csv").unlink()
    r = runner.invoke(app, ["steady", str(ref), "--impacts"])
    assert r.exit_code == 2 and "wall_impacts = true" in r.output and "Traceback" not in r.output
