"""The default size of process pools: the cores a process may use, not the host's."""

import os

import pytest

from edmd import cores


@pytest.fixture
def host(monkeypatch, tmp_path):
    """A host of 16 cores whose affinity and cgroup quota the test sets."""

    def make(affinity=16, quota=None):
        monkeypatch.setattr(os, "cpu_count", lambda: 16)
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(affinity)), raising=False)
        path = tmp_path / "cpu.max"
        if quota is not None:
            path.write_text(quota)
        monkeypatch.setattr(cores, "CGROUP_CPU_MAX", str(path))

    return make


@pytest.mark.parametrize(
    "affinity, quota, expected",
    [
        (16, None, 16),  # no quota file
        (3, None, 3),  # taskset / SLURM: the affinity counts
        (16, "max 100000\n", 16),  # a quota file without a quota
        (16, "250000 100000\n", 2),  # 2.5 cores of quota: 2 whole workers
        (2, "800000 100000\n", 2),  # the smaller of the two
        (16, "50000 100000\n", 1),  # half a core still runs one
        (16, "garbage\n", 16),  # an unreadable quota is no quota
    ],
)
def test_usable_cores_is_the_affinity_capped_by_the_quota(host, affinity, quota, expected):
    host(affinity, quota)
    assert cores.usable_cores() == expected


def test_without_affinity_the_host_count_is_used(host, monkeypatch):
    host()
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)
    assert cores.usable_cores() == 16


def test_sweeps_and_tables_size_their_default_pools_by_it(host, monkeypatch, tmp_path):
    """The default pools of :func:`edmd.sweep` and :func:`build_table` start usable_cores() workers."""
    import concurrent.futures

    from edmd.app.sweeps import execute
    from edmd.physics import tables

    host(affinity=3)
    sizes = []

    class Recording(concurrent.futures.ThreadPoolExecutor):
        def __init__(self, max_workers):
            sizes.append(max_workers)
            super().__init__(max_workers)

    monkeypatch.setattr(execute, "ProcessPoolExecutor", Recording)
    monkeypatch.setattr(concurrent.futures, "ProcessPoolExecutor", Recording)
    points = [execute.Point(index=k, params={}, config={}, text="", id=f"p{k}") for k in range(5)]
    monkeypatch.setattr(execute, "run_point", lambda text, directory: {"status": "ok"})
    monkeypatch.setattr(execute, "_outcome", lambda future, directory: future.result() is not None)

    class Bar:
        def __enter__(self):
            return lambda ok: None

        def __exit__(self, *exc):
            return False

    execute._run_all(points, tmp_path, None, None, Bar)
    tables.build_table("dashpot", "damping=0:0.2,softness=0:0.01,b=0:0.5", shape=(6, 6, 6))
    assert sizes == [3, 3]
