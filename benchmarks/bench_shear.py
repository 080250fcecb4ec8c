"""Sheared hard-sphere fluid (Lees-Edwards) vs the same fluid unsheared: collision rate on one core.

A 3D elastic fluid of N spheres at packing fraction eta, from one random start with
Maxwell-Boltzmann velocities (T = 1; sheared runs start in the linear profile). Each round runs
every case once, alternating, over ``--measure`` collisions per particle after ``--warm``, timed by
the process's CPU clock; the best and the median of the rounds are reported, with the ratio of the
sheared rates to the best unsheared neighbour structure; sheared runs use both neighbour
structures. Pin it to one core: ``taskset -c 1 python benchmarks/bench_shear.py``.

Usage::

    python benchmarks/bench_shear.py --n 10976 --eta 0.3 --rates 0.1 1.0 --rounds 5
"""

from __future__ import annotations

import argparse
import statistics

import edmd
from bench_driven import rate
from bench_hard_spheres import write_results


def measure(state: edmd.State, warm: float, collisions: float, **physics) -> float:
    """M collisions/s (CPU) of a fresh simulation of ``state`` over ``collisions`` per particle after ``warm`` events per particle."""
    sim = edmd.Simulation(state, **physics)
    sim.run(max_events=int(warm * state.n))
    return rate(sim, collisions)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10976)
    ap.add_argument("--eta", type=float, default=0.3)
    ap.add_argument("--rates", type=float, nargs="+", default=[0.1, 1.0], help="shear rates (units of sigma, m, kT = 1)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--warm", type=float, default=2.0, help="events per particle before timing")
    ap.add_argument("--measure", type=float, default=20.0, help="collisions per particle per timed run")
    ap.add_argument("--out", default="benchmarks/results/shear.json")
    args = ap.parse_args()
    state = edmd.maxwell_boltzmann(edmd.random_packing(args.n, args.eta, seed=1), 1.0, seed=2)
    cases = {"unsheared, lists": {"engine": {"neighbours": "list"}}, "unsheared, cells": {"engine": {"neighbours": "cells"}}}
    for gamma in args.rates:
        for mode, neighbours in (("lists", "list"), ("cells", "cells")):
            cases[f"sheared, rate {gamma:g}, {mode}"] = {"shear": edmd.Shear(gamma), "engine": {"neighbours": neighbours}}
    runs = {name: [] for name in cases}
    for k in range(args.rounds):
        for name, physics in cases.items():
            start = physics["shear"].with_profile(state) if "shear" in physics else state
            runs[name].append(measure(start, args.warm, args.measure, **physics))
        print(f"round {k + 1}: " + ", ".join(f"{name} {r[-1]:.3f}" for name, r in runs.items()), flush=True)
    plain = max(max(runs["unsheared, lists"]), max(runs["unsheared, cells"]))
    results = []
    for name, r in runs.items():
        best, median = max(r), statistics.median(r)
        results.append({"case": name, "best_M_collisions_per_s": best, "median_M_collisions_per_s": median, "runs": r, "best_over_best_unsheared": best / plain})
        print(f"{name}: best {best:.3f}, median {median:.3f} M coll/s, best / best unsheared {best / plain:.2f}")
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
