"""Every example configuration parses and runs (shortened) into a run directory."""

from pathlib import Path

import pytest

from edmd.app.config import ignored_keys, load_config
from edmd.app.runner import run_directory

EXAMPLES = sorted(Path(__file__).resolve().parents[1].joinpath("examples").glob("*.toml"))
RUNNABLE = [p for p in EXAMPLES if "sweep" not in p.read_text()[:2000] and "[grid]" not in p.read_text() and "[base" not in p.read_text()]


def test_examples_exist():
    names = {p.stem for p in RUNNABLE}
    assert {"cooling_gas_3d", "cooling_gas_2d", "bouncing_ball", "granular_column"} <= names


@pytest.mark.parametrize("path", RUNNABLE, ids=lambda p: p.stem)
def test_example_runs(path, tmp_path):
    cfg = load_config(path)
    assert ignored_keys(cfg) == []  # (an example teaches no key without effect)
    cfg.run.until_time = min(cfg.run.until_time, 3 * cfg.run.output_interval)
    cfg.run.progress = False
    summary = run_directory(cfg, tmp_path)
    assert summary["time"] == pytest.approx(cfg.run.until_time)
    assert (tmp_path / "thermo.csv").exists() and (tmp_path / "trajectory.gsd").exists()


def test_fig6_script_reproduces_its_data(tmp_path, monkeypatch):
    """examples/fig6_two_particle_trajectories.py: eMD* ends on the MD path, classic EDMD does not."""
    import importlib.util

    import numpy as np

    path = Path(__file__).resolve().parents[1] / "examples" / "fig6_two_particle_trajectories.py"
    spec = importlib.util.spec_from_file_location("fig6", path)
    fig6 = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fig6)
    monkeypatch.setattr(fig6, "HERE", tmp_path)
    fig6.main()
    new = np.loadtxt(tmp_path / "data" / "fig6_two_particle_trajectories.csv", delimiter=",", skiprows=1)
    committed = np.loadtxt(path.parent / "data" / "fig6_two_particle_trajectories.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(new, committed, atol=1e-9)
    md, classic, emd = new[-1, 1:5], new[-1, 5:9], new[-1, 9:13]
    assert np.abs(emd - md).max() < 1e-6 and np.abs(classic - md).max() > 0.1
