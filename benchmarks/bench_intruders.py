"""Intruders: a few big particles in a gas of small ones (cells mode's big particles, physics.md §1.4).

Each case: ``n`` particles of radius 0.5, ``bigs`` of them ``ratio`` times larger (equal material
density: an intruder of size ratio 10 is 1000 times heavier in 3D), a random start,
Maxwell-Boltzmann velocities, ``--equilibrate`` events per particle (compiles the core), then
``--repeats`` chunks of ``--chunk`` events per particle, CPU time of the loop. Reports M collisions
per second (best, median), events per collision, the cells per axis and the big particles taken out
of the cell size. Each case runs in a fresh process per source tree (``--tree``, several to compare
them; the order alternates from case to case), one core.

Usage::

    taskset -c 1 python benchmarks/bench_intruders.py --tree OLD --tree .   # the table of benchmarks/README.md
    python benchmarks/bench_intruders.py --case 3 0.05 10 1 cells
    python benchmarks/bench_intruders.py --emdstar --case 3 0.05 10 1 cells   # eMD* soft contacts
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from bench_hard_spheres import write_results

#: (dim, eta, ratio, bigs, neighbours): a monodisperse baseline, one intruder of growing size, eight, other densities, disks, lists
CASES = [
    (3, 0.05, 1, 0, "cells"),
    (3, 0.05, 2, 1, "cells"),
    (3, 0.05, 5, 1, "cells"),
    (3, 0.05, 10, 1, "cells"),
    (3, 0.05, 10, 8, "cells"),
    (3, 0.01, 10, 1, "cells"),
    (3, 0.3, 10, 1, "cells"),
    (3, 0.3, 10, 1, "list"),
    (2, 0.05, 10, 1, "cells"),
]


def measure(dim: int, eta: float, ratio: float, bigs: int, neighbours: str, n: int, equilibrate: float, chunk: float, repeats: int, emdstar: bool = False) -> dict:
    """One case in this process (run through :func:`run_case`); ``emdstar``: the viscoelastic gas
    of bench_emdstar.py (SI units, eMD* soft contacts, the small grains at ~1 m/s) instead."""
    import edmd
    from edmd._core import cells

    bigs_index = getattr(cells, "GI_BIGS", None)  # (None: a tree from before big particles)

    small, density, collision = 0.5, 1.0, None
    if emdstar:
        from bench_emdstar import DENSITY, RADIUS, contact_law
        from edmd.physics.emdstar import EMDStar

        small, density, collision = RADIUS, DENSITY, EMDStar(contact_law())
    radius = small if bigs == 0 else {"kind": "discrete", "values": [small, small * ratio], "fractions": [1 - bigs / n, bigs / n]}
    s = edmd.random_packing(n, eta, dim=dim, seed=1, radius=radius, density=density)
    s = edmd.maxwell_boltzmann(s, float(s.mass.min()) / 3.0 if emdstar else 1.0, seed=2)
    sim = edmd.Simulation(s, collision=collision, engine={"neighbours": neighbours})
    sim.run(max_events=int(equilibrate * n))
    rates, per = [], []
    for _ in range(repeats):
        c0, e0, t0 = sim.collisions, sim.events, time.process_time()
        sim.run(max_events=int(chunk * n))
        dt = time.process_time() - t0
        rates.append((sim.collisions - c0) / dt / 1e6)
        per.append((sim.events - e0) / max(sim.collisions - c0, 1))
    grid = sim.engine.grid
    return {
        "dim": dim,
        "eta": eta,
        "ratio": ratio,
        "bigs": bigs,
        "neighbours": sim.engine.mode,
        "emdstar": emdstar,
        "n": s.n,
        "mcoll_per_s_best": max(rates),
        "mcoll_per_s_median": statistics.median(rates),
        "events_per_collision": statistics.median(per),
        "cells": [int(c) for c in sim.engine.grid_cells[:dim]],
        "bigs_taken_out": 0 if bigs_index is None else int(grid.shape[bigs_index]),
    }


def run_case(tree: str, case: tuple, args) -> dict:
    """:func:`measure` in a fresh process on the sources of ``tree``."""
    env = {**os.environ, "PYTHONPATH": os.path.join(os.path.abspath(tree), "src")}
    code = f"import json, bench_intruders as b; print(json.dumps(b.measure(*{case!r}, {args.n}, {args.equilibrate}, {args.chunk}, {args.repeats}, {args.emdstar})))"
    out = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).parent, env=env, capture_output=True, text=True, check=True)
    return {"tree": tree, **json.loads(out.stdout.strip().splitlines()[-1])}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tree", action="append", help="a source tree (repeat to compare; default: this one)")
    ap.add_argument("--case", nargs=5, action="append", metavar=("DIM", "ETA", "RATIO", "BIGS", "NEIGHBOURS"), help="instead of the default cases")
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--equilibrate", type=float, default=5.0, help="events per particle before the timed chunks")
    ap.add_argument("--chunk", type=float, default=5.0, help="events per particle per timed chunk")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--emdstar", action="store_true", help="the viscoelastic eMD* gas of bench_emdstar.py instead of elastic hard spheres")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results") / "intruders.json"))
    args = ap.parse_args(argv)
    trees = args.tree or [str(Path(__file__).resolve().parent.parent)]
    cases = [(int(d), float(e), float(r), int(b), m) for d, e, r, b, m in args.case] if args.case else CASES
    results = []
    for k, case in enumerate(cases):
        for tree in trees if k % 2 == 0 else trees[::-1]:
            r = run_case(tree, case, args)
            results.append(r)
            print(
                f"{tree}: {r['dim']}D eta={r['eta']} ratio={r['ratio']:g} bigs={r['bigs']} [{r['neighbours']}] "
                f"{r['mcoll_per_s_best']:.4f} / {r['mcoll_per_s_median']:.4f} M coll/s, {r['events_per_collision']:.2f} events/coll, "
                f"cells {r['cells']}, {r['bigs_taken_out']} taken out",
                flush=True,
            )
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
