"""Compile cost of the core: CPU seconds and peak memory to the first event, from a cold Numba cache.

Each job runs in a fresh subprocess whose ``NUMBA_CACHE_DIR`` is a new empty folder (a cold cache,
without touching the cache next to the sources), then once more with that folder filled (warm).
CPU time and peak resident memory are the child's (``getrusage``), so they include the
interpreter, imports, set-up and the events the job runs.

Usage::

    python benchmarks/bench_compile.py                      # every job
    python benchmarks/bench_compile.py --jobs hard_spheres  # one of them
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

from bench_hard_spheres import write_results

JOBS = {
    # plain hard spheres: an elastic fluid to its first events
    "hard_spheres": "import edmd\n"
    "s = edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0)\n"
    "edmd.Simulation(s).run(max_events=1000)\n",
    # the same with neighbour lists (the loop variant of the other structure)
    "hard_spheres_lists": "import edmd\n"
    "s = edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0)\n"
    "edmd.Simulation(s, engine={'neighbours': 'list'}).run(max_events=1000)\n",
    # both structures in one process (the tests, `edmd compile` with both): two loop variants
    "hard_spheres_both": "import edmd\n"
    "s = edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0)\n"
    "for mode in ('cells', 'list'):\n"
    "    edmd.Simulation(s, engine={'neighbours': mode}).run(max_events=1000)\n",
    # rough spheres (the tangential rule and spins in the loop) to their first events
    "rough": "import edmd\n"
    "from edmd.physics.collide import Rough\n"
    "s = edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0, spin=True)\n"
    "edmd.Simulation(s, collision=Rough(e_n=0.9, beta=0.5)).run(max_events=1000)\n",
    # the README's first command: the showcase job, from `edmd run` to its end (figures included)
    "showcase": "import sys, tempfile\n"
    "from edmd.app.cli import app\n"
    "sys.argv = ['edmd', 'run', '--out', tempfile.mkdtemp() + '/run', '--no-progress']\n"
    "app(standalone_mode=False)\n",
    # eMD* soft spheres (the contact solver and tables in the loop) to their first contacts
    "emdstar": "import edmd\n"
    "from edmd.physics.contact import Hertz\n"
    "from edmd.physics.emdstar import EMDStar\n"
    "s = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), 1.0, seed=2)\n"
    "edmd.Simulation(s, collision=EMDStar(Hertz(young=1e5, poisson=0.3, A=1e-3))).run(max_events=1000)\n",
    # frictional eMD* (the frictional two-body solver in the A event, spins) to its first contacts
    "emdstar_friction": "import edmd\n"
    "from edmd.physics.contact import Hertz\n"
    "from edmd.physics.emdstar import EMDStar\n"
    "s = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), 1.0, seed=2, spin=True)\n"
    "rule = EMDStar(Hertz(young=1e5, poisson=0.3, A=1e-3), friction=edmd.Friction(mu=0.3, law='mindlin'))\n"
    "edmd.Simulation(s, collision=rule).run(max_events=1000)\n",
    # the same with the hard-limit table of frictional contacts (its build included)
    "emdstar_friction_table": "import edmd\n"
    "from edmd.physics.contact import Hertz\n"
    "from edmd.physics.emdstar import EMDStar\n"
    "s = edmd.maxwell_boltzmann(edmd.random_packing(500, 0.05, seed=1), 1.0, seed=2, spin=True)\n"
    "rule = EMDStar(Hertz(young=1e5, poisson=0.3, A=1e-3), friction=edmd.Friction(mu=0.3, law='mindlin'), friction_table=True)\n"
    "edmd.Simulation(s, collision=rule).run(max_events=1000)\n",
    # Lees-Edwards shear (the sliding-image hooks of the loop), inelastic, cells
    "shear": "import edmd\n"
    "shear = edmd.Shear(0.5)\n"
    "s = shear.with_profile(edmd.maxwell_boltzmann(edmd.random_packing(500, 0.1, seed=1), 1.0, seed=2))\n"
    "edmd.Simulation(s, shear=shear, e_n=0.9).run(max_events=1000)\n",
}


def run_child(code: str, cache: str) -> dict:
    """CPU seconds, peak RSS (MB) and wall seconds of ``python -c code`` with Numba cache ``cache``."""
    start = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-c", code], env={**os.environ, "NUMBA_CACHE_DIR": cache}, stdout=subprocess.DEVNULL)
    _pid, status, usage = os.wait4(child.pid, 0)  # this child's own usage
    wall = time.perf_counter() - start
    if status != 0:
        raise SystemExit(f"the job failed (status {status}):\n{code}")
    cpu = usage.ru_utime + usage.ru_stime
    return {"cpu_seconds": round(cpu, 2), "peak_rss_mb": round(usage.ru_maxrss / 1024, 1), "wall_seconds": round(wall, 2)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--jobs", nargs="+", choices=sorted(JOBS), default=list(JOBS))
    ap.add_argument("--out", default="benchmarks/results/compile.json")
    args = ap.parse_args()
    results = []
    for job in args.jobs:
        with tempfile.TemporaryDirectory() as cache:
            cold = run_child(JOBS[job], cache)
            warm = run_child(JOBS[job], cache)
        print(f"{job}: cold {cold['cpu_seconds']} CPU-s, peak {cold['peak_rss_mb']} MB; warm {warm['cpu_seconds']} CPU-s")
        results.append({"job": job, "cold": cold, "warm": warm})
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
