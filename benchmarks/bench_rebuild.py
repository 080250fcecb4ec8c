"""The cost of one neighbour-list rebuild (a shell exit) at large N, for two or more source trees in one process.

At N = 1e6 a process keeps its speed for life, and two processes of the same code differ by up to
17 % (benchmarks/README.md, "Large N"): end-to-end pairs need many processes to see a few per
cent. This isolates the rebuild instead: each tree's ``edmd`` is imported as a package of
its own (:func:`bench_same_process.load_builds`), and each replays the same random sequence of shell
exits (a particle moved by half the skin, then ``rebuild_list``) on its own copy of one engine's
arrays, the copies alternating, in one process. Reported: ns per rebuild, best and median.

Usage (one core)::

    taskset -c 0 python benchmarks/bench_rebuild.py OLD_TREE NEW_TREE --replicate 5 --out results/rebuild.json
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from numba import njit

import edmd
from bench_hard_spheres import write_results
from bench_same_process import load_builds


def make_driver(rebuild_list):
    """A compiled replay of shell exits: move particle ``seq[m]`` by ``kick[m]``, rebuild its list."""

    @njit
    def replay(seq, kick, P, grid, lists, geo, skin, cbuf):
        rebuilt = 0
        for m in range(seq.shape[0]):
            i = seq[m]
            for k in range(3):
                P[i, k] += kick[m, k]
            rebuilt += rebuild_list(i, P, grid, lists, geo, skin, 1.0, cbuf) >= 0  # (a bool in older trees)
        return rebuilt

    return replay


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees", nargs="+", help="source trees (each with src/edmd/_core)")
    ap.add_argument("--eta", type=float, default=0.5)
    ap.add_argument("--replicate", type=int, default=5, help="8000 relaxed spheres tiled k x k x k")
    ap.add_argument("--rebuilds", type=int, default=300_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()

    cores = {tree: build._core for tree, build in zip(args.trees, load_builds(args.trees))}
    state = edmd.replicate(edmd.random_packing(8000, args.eta, seed=1), [args.replicate] * 3)
    sim = edmd.Simulation(edmd.maxwell_boltzmann(state, 1.0, seed=2), engine={"neighbours": "list"})
    sim.run(max_events=5 * state.n)  # (lists that have been rebuilt in a run, not only built)
    e = sim.engine
    skin = float(e.fp[edmd._core.layout.FP_SKIN])
    rng = np.random.default_rng(3)
    seq = rng.integers(0, state.n, args.rebuilds)
    kick = rng.normal(size=(args.rebuilds, 3))
    kick *= 0.5 * skin / np.linalg.norm(kick, axis=1)[:, None]

    def fresh(core):
        g, lists = e.grid, e.lists
        grid = core.bundles.Grid(g.head.copy(), g.link.copy(), g.cell.copy(), g.shape.copy(), g.size.copy())
        return e.part.rows.copy(), grid, core.bundles.Lists(*(a.copy() for a in lists))

    drivers = {tree: make_driver(core.nblist.rebuild_list) for tree, core in cores.items()}
    for tree, core in cores.items():  # (compiles)
        drivers[tree](seq[:100], kick[:100], *fresh(core), e.geo, skin, e.cbuf.copy())
    times = {tree: [] for tree in args.trees}
    for r in range(args.rounds):
        for tree in args.trees if r % 2 == 0 else args.trees[::-1]:
            P, grid, lists = fresh(cores[tree])
            t0 = time.perf_counter()
            done = drivers[tree](seq, kick, P, grid, lists, e.geo, skin, e.cbuf.copy())
            times[tree].append((time.perf_counter() - t0) / args.rebuilds * 1e9)
            if done != args.rebuilds:
                raise SystemExit(f"{tree}: a list ran full ({done} of {args.rebuilds} rebuilds)")
            del P, grid, lists
    results = []
    for tree, t in times.items():
        print(f"{tree}: {min(t):.0f} ns per rebuild best, {statistics.median(t):.0f} median ({', '.join(f'{x:.0f}' for x in t)})")
        results.append({"tree": tree, "n": state.n, "ns_best": min(t), "ns_median": statistics.median(t), "ns_all": t})
    if args.out:
        write_results(args.out, args, results)


if __name__ == "__main__":
    main()
