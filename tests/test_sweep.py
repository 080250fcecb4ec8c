"""Parameter sweeps: sweep files, local pool vs dask, resumption, failures, equality with `edmd run`."""

import json
import os
import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import edmd
from edmd import SweepError, SweepSpec, read_state
from edmd.app.cli import app
from edmd.app.sweeps import TIMING, replica_seed
from edmd.app.sweeps.files import point_dir, read_json

runner = CliRunner()
EXAMPLES = Path(__file__).parents[1] / "examples"

# Tiny runs: 20 disks, one time unit, thermo and a frame every half unit.
BASE = """
[base.system]
dim = 2
n = 20
[base.collision]
rule = "inelastic"
e_n = 0.9
[base.run]
until_time = 1.0
output_interval = 0.5
"""
GRID = BASE + """
[grid]
"system.packing_fraction" = [0.2, 0.3]
collision.e_n = [0.8, 0.9]
"""


@pytest.fixture(scope="module", autouse=True)
def workers_import_this_edmd():
    """Worker processes (pool, dask) must import the edmd under test, not another installed copy."""
    src = str(Path(edmd.__file__).parents[1])
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PYTHONPATH", os.pathsep.join(p for p in (src, os.environ.get("PYTHONPATH")) if p))
        yield


def _spec(text: str) -> SweepSpec:
    return SweepSpec.from_dict(tomllib.loads(text))


def _write(tmp_path: Path, text: str, name: str = "sweep.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _reproducible(rows):
    return [{k: v for k, v in row.items() if k not in TIMING} for row in rows]


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    """The GRID sweep run once on the default local process pool."""
    out = tmp_path_factory.mktemp("local")
    return edmd.sweep(_spec(GRID), out, workers=2, progress=True)


# ---------------------------------------------------------------------- the sweep file
def test_points_times_grid_times_replicas():
    spec = _spec("replicas = 3\n" + BASE + """
[grid]
"collision.e_n" = [0.8, 0.9]
[[points]]
"system.packing_fraction" = 0.05
"run.until_time" = 2.0
[[points]]
"system.packing_fraction" = 0.1
""")
    points = spec.expand()
    assert len(points) == 2 * 2 * 3
    assert spec.keys == ["system.packing_fraction", "run.until_time", "collision.e_n", "system.seed"]
    first = points[0].overrides
    assert first == {"system.packing_fraction": 0.05, "run.until_time": 2.0, "collision.e_n": 0.8, "system.seed": 1}
    assert [p.replica for p in points[:4]] == [0, 1, 2, 0]
    assert points[3].overrides["collision.e_n"] == 0.9 and points[6].overrides["system.packing_fraction"] == 0.1
    # replicas: distinct seeds, derived from the base seed only (same across the grid), deterministic
    seeds = [p.overrides["system.seed"] for p in points[:3]]
    assert seeds == [1, replica_seed(1, 1), replica_seed(1, 2)] and len(set(seeds)) == 3
    assert [p.overrides["system.seed"] for p in points[3:6]] == seeds
    assert replica_seed(2, 1) not in seeds
    resolved = spec.resolve()
    assert resolved[1].config.system.seed == seeds[1] and resolved[1].params["replica"] == 1
    assert resolved[6].params["run.until_time"] == 1.0 and resolved[0].config.run.until_time == 2.0
    assert len({p.id for p in resolved}) == 12


def test_base_from_a_file(tmp_path):
    (tmp_path / "runs").mkdir()
    _write(tmp_path / "runs", "[system]\ndim = 2\nn = 20\n", "base.toml")
    path = _write(tmp_path, 'base = "runs/base.toml"\n[grid]\n"system.n" = [10, 30]\n')
    points = SweepSpec.load(path).resolve()
    assert [(p.config.system.dim, p.config.system.n) for p in points] == [(2, 10), (2, 30)]
    with pytest.raises(SweepError, match="cannot read base configuration"):
        SweepSpec.load(_write(tmp_path, 'base = "nope.toml"\nreplicas = 2\n'))


@pytest.mark.parametrize(
    "text, match",
    [
        ('[grid]\n"collision.e_nn" = [0.8]', r"grid: unknown key 'collision.e_nn' \(did you mean 'collision.e_n'\?\)"),
        ('[[points]]\nsystem.pakcing_fraction = 0.1', r"points\[0\]: unknown key 'system.pakcing_fraction' \(did you mean 'system.packing_fraction'\?\)"),
        ("[grid]\n", r"\[grid\] is empty"),
        ('[grid]\n"system.n" = 10', r"grid.system.n: expected a list of values, got 10"),
        ('[grid]\n"system.n" = []', r"grid.system.n: empty list"),
        ('[grid]\n"system.n" = [10, 20, 10]', r"grid.system.n: duplicate value 10"),
        ('[grid]\n"system.n" = [10]\nsystem.n = [20]', r"grid: duplicate key 'system.n'"),
        ('[grid]\n"system.n" = [10]\n[[points]]\n"system.n" = 5', r"points\[0\]: 'system.n' is also a \[grid\] key"),
        ("[grid]\nsystem = [1, 2]", r"grid: 'system' is not a dotted key"),
        ("replica = 2", r"unknown sweep key 'replica' \(did you mean 'replicas'\?\)"),
        ("[base.run]\nuntil_time = 1.0\nreplicas = 2", r"base.run.replicas: 'replicas' is a top-level key: put it before the first \[table\]"),
        ("[grid]\n'system.n' = [1, 2]\nreplicas = 2", r"grid: 'replicas' is a top-level key: put it before the first \[table\]"),
        ("replicas = 0", r"replicas must be a positive integer"),
        ('replicas = 100000000\n[grid]\n"system.n" = [10, 20]', r"the sweep has 200000000 points .*more than 100000"),  # (it filled the memory)
        ('[base.system]\nn = 20', r"nothing to sweep"),
        ("points = []", r"points is empty"),
        ('[grid]\n"collision.e_n" = [0.9]', r"point 0 \(collision.e_n=0.9\): collision: rule 'elastic' takes no parameters"),
        ('[grid]\n"system.n" = [20, 20.0]', r"grid.system.n: duplicate value 20.0"),
        ('[[points]]\n"system.kT" = 1.0\n[[points]]\n"system.seed" = 1', r"points 0 and 1 \(system.seed=1\) resolve to the same configuration"),
    ],
)
def test_bad_sweep_files_are_named(text, match):
    with pytest.raises(SweepError, match=match):
        _spec(text).resolve()


def test_emd_exception_map_example_expands_to_the_fig7_grid():
    spec = SweepSpec.load(EXAMPLES / "emd_exception_map.toml")
    resolved = spec.resolve()  # (every point validates as an eMD* configuration)
    assert len({p.id for p in resolved}) == 35
    assert [(p.config.system.packing_fraction, p.config.collision.young) for p in resolved[:6]] == [(0.005, y) for y in (1e7, 1e8, 1e9, 1e10, 6.3e10)] + [(0.01, 1e7)]
    points = spec.expand()
    young = [1e7, 1e8, 1e9, 1e10, 6.3e10]
    eta = [0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3]
    assert len(points) == 35
    assert [(p.config["system"]["packing_fraction"], p.config["collision"]["young"]) for p in points] == [(e, y) for e in eta for y in young]
    for p in points:
        collision, system, run = p.config["collision"], p.config["system"], p.config["run"]
        assert collision["rule"] == "emdstar" and collision["contact"] == "hertz" and collision["A"] == 0.0
        assert (system["n"], system["lattice"], system["radius"], system["density"]) == (1000, "sc", 0.001, 2500)
        assert run["until_time"] == pytest.approx(110 * run["output_interval"])


# ---------------------------------------------------------------------- running
def test_results_table_files(local_sweep):
    pq = pytest.importorskip("pyarrow.parquet")
    csv_path, parquet_path = local_sweep.table.paths
    lines = csv_path.read_text().splitlines()
    assert len(lines) == 5 and lines[0].startswith("point,system.packing_fraction,collision.e_n,status,error,")
    parquet = pq.read_table(parquet_path).to_pylist()
    assert _reproducible(parquet) == _reproducible(local_sweep.table.rows)


def test_sweep_point_is_edmd_run_of_its_config(local_sweep, tmp_path):
    point = point_dir(local_sweep.directory, local_sweep.table.rows[-1]["point"])
    r = runner.invoke(app, ["run", str(point / "config.toml"), "--out", str(tmp_path / "run"), "--no-progress"])
    assert r.exit_code == 0, r.output
    assert (point / "thermo.csv").read_bytes() == (tmp_path / "run" / "thermo.csv").read_bytes()
    assert (point / "config.toml").read_bytes() == (tmp_path / "run" / "config.toml").read_bytes()
    a, b = read_state(point / "trajectory.gsd"), read_state(tmp_path / "run" / "trajectory.gsd")
    for name in ("position", "velocity", "angular_velocity", "image", "radius", "mass", "inertia", "box"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.time == b.time == 1.0


def test_summary_rebuilds_the_table(local_sweep):
    csv_path = local_sweep.table.paths[0]
    before = csv_path.read_bytes()
    csv_path.unlink()
    r = runner.invoke(app, ["sweep", "--summary", str(local_sweep.directory)])
    assert r.exit_code == 0, r.output
    assert "4 points" in r.output and "4 done" in r.output
    assert csv_path.read_bytes() == before


def test_resume_runs_only_missing_points(tmp_path):
    first = edmd.sweep(_spec(BASE + '[grid]\n"system.packing_fraction" = [0.05]\n'), tmp_path, workers=1)
    assert (first.ran, first.skipped) == (1, 0)
    grid = BASE + '[grid]\n"system.packing_fraction" = [0.05, 0.1, 0.15]\n'
    second = edmd.sweep(_spec(grid), tmp_path, workers=2)
    assert (second.ran, second.skipped) == (2, 1)
    ids = [row["point"] for row in second.table.rows]
    assert ids[0] == first.table.rows[0]["point"]
    # interrupt: one point never finished (its status still says running)
    stamps = {pid: (point_dir(tmp_path, pid) / "thermo.csv").stat().st_mtime_ns for pid in ids}
    status = point_dir(tmp_path, ids[1]) / "status.json"
    status.write_text(json.dumps({"status": "running"}))
    third = edmd.sweep(_spec(grid), tmp_path, workers=2)
    assert (third.ran, third.skipped) == (1, 2)
    assert json.loads(status.read_text())["status"] == "done"
    for pid in (ids[0], ids[2]):
        assert (point_dir(tmp_path, pid) / "thermo.csv").stat().st_mtime_ns == stamps[pid]
    assert _reproducible(third.table.rows) == _reproducible(second.table.rows)


def test_failing_point_is_reported_and_the_others_complete(tmp_path):
    text = """
[base.system]
n = 32
[base.run]
until_time = 0.5
[grid]
"system.packing_fraction" = [0.1, 0.9, 0.2]
"""
    path = _write(tmp_path, text)
    out = tmp_path / "out"
    r = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--workers", "2"])
    assert r.exit_code == 1, r.output
    assert "ran 3" in r.output and "2 done" in r.output and "1 failed" in r.output
    rows = edmd.sweep_summary(out).rows
    assert [row["status"] for row in rows] == ["done", "failed", "done"]
    assert "packing fraction 0.9 cannot be built" in rows[1]["error"] and rows[1]["error"].startswith("StateError: ")
    assert "Traceback" in (point_dir(out, rows[1]["point"]) / "error.txt").read_text()
    assert (point_dir(out, rows[1]["point"]) / "config.toml").exists()
    # rerunning retries the failed point only
    r = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--no-progress"])
    assert r.exit_code == 1 and "ran 1, skipped 2" in r.output


def test_corrupt_json_in_a_sweep_directory_is_an_error_naming_it(tmp_path):
    assert read_json(tmp_path / "missing.json") is None  # a point that never started
    status = point_dir(tmp_path, "abc") / "status.json"
    status.parent.mkdir(parents=True)
    status.write_text('{"status": "do')  # cut short
    with pytest.raises(SweepError, match=f"{status} is corrupt"):
        edmd.sweep_summary(tmp_path)
    status.write_bytes(b"\xff\xfe")
    with pytest.raises(SweepError, match="is corrupt"):
        read_json(status)
    r = runner.invoke(app, ["sweep", "--summary", str(tmp_path)])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert f"{status}iscorrupt" in "".join(r.output.split())  # the console wraps lines anywhere


def test_cli_input_errors(tmp_path):
    def fails(*args):
        r = runner.invoke(app, ["sweep", *args])
        assert r.exit_code == 2 and "Traceback" not in r.output
        return " ".join(r.output.split())

    assert "--summary" in fails()
    assert "is not a sweep directory" in fails("--summary", str(tmp_path))
    bad = _write(tmp_path, '[grid]\n"colision.e_n" = [0.8]\n')
    assert "did you mean 'collision.e_n'" in fails(str(bad), "--out", str(tmp_path / "x"))
    assert "error: [grid] is empty" in fails(str(_write(tmp_path, "[grid]\n", "empty.toml")))
    assert "scheduler's cluster has its own workers" in fails(str(_write(tmp_path, GRID)), "--scheduler", "tcp://127.0.0.1:1", "--workers", "2")
    assert "exists and is not a directory" in fails(str(_write(tmp_path, GRID)), "--out", str(bad))  # (a NotADirectoryError traceback)
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "checkpoint.gsd").write_bytes(b"")
    assert "holds a run of `edmd run` (checkpoint.gsd)" in fails(str(_write(tmp_path, GRID)), "--out", str(tmp_path / "run"))


# Last: the in-process dask cluster may leave threads behind, and the pool tests above fork.
def test_local_pool_and_dask_give_identical_tables(local_sweep, tmp_path):
    distributed = pytest.importorskip("distributed")
    assert local_sweep.ran == 4 and local_sweep.skipped == 0 and not local_sweep.failed
    with distributed.LocalCluster(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            on_dask = edmd.sweep(_spec(GRID), tmp_path, executor=client.get_executor(pure=False))
    assert on_dask.ran == 4
    rows = _reproducible(local_sweep.table.rows)
    assert rows == _reproducible(on_dask.table.rows)
    assert [(r["system.packing_fraction"], r["collision.e_n"]) for r in rows] == [(0.2, 0.8), (0.2, 0.9), (0.3, 0.8), (0.3, 0.9)]
    for row in rows:
        assert row["status"] == "done" and row["time"] == 1.0 and row["collisions"] > 0
        assert row["temperature_mean"] > row["temperature"] and row["dissipated_energy"] > 0  # inelastic: cooling
        assert np.isfinite(row["pressure_mean"]) and np.isfinite(row["collision_rate_mean"])
        a, b = point_dir(local_sweep.directory, row["point"]), point_dir(tmp_path, row["point"])
        assert (a / "thermo.csv").read_bytes() == (b / "thermo.csv").read_bytes()
