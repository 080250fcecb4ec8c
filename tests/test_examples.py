"""Every example configuration parses and runs (shortened) into a run directory."""

from pathlib import Path

import pytest

from edmd.config import load_config
from edmd.runner import run_directory

EXAMPLES = sorted(Path(__file__).resolve().parents[1].joinpath("examples").glob("*.toml"))
RUNNABLE = [p for p in EXAMPLES if "sweep" not in p.read_text()[:2000] and "[grid]" not in p.read_text() and "[base" not in p.read_text()]


def test_examples_exist():
    names = {p.stem for p in RUNNABLE}
    assert {"cooling_gas_3d", "cooling_gas_2d", "bouncing_ball", "granular_column"} <= names


@pytest.mark.parametrize("path", RUNNABLE, ids=lambda p: p.stem)
def test_example_runs(path, tmp_path):
    cfg = load_config(path)
    cfg.run.until_time = min(cfg.run.until_time, 3 * cfg.run.output_interval)
    cfg.run.progress = False
    summary = run_directory(cfg, tmp_path)
    assert summary["time"] == pytest.approx(cfg.run.until_time)
    assert (tmp_path / "thermo.csv").exists() and (tmp_path / "trajectory.gsd").exists()
