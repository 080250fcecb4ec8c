"""Paired speed of two builds of edmd in ONE process: alternating chunks of events (large N).

At N = 1e6 a process keeps its rate for life, and two processes of the same code read up to
17 % apart (benchmarks/README.md, "Large N"), so :mod:`bench_paired` needs many process pairs to
see a few per cent. Here each tree's ``src/edmd`` is imported as a package of its own (edmd has
relative imports only), both build the same hard-sphere state and take turns in one process,
one chunk of ``--chunk`` events per particle each (the order flips every round).

The build made first runs faster (at N = 1e6, eta = 0.5, lists: by ~12 %, the same in both
orders: where its arrays land in memory), so the script runs two processes, one per order of
construction, and reports the geometric mean of their median ratios, in which that bias cancels.
Reported: per process the median M collisions/s of each build, the per-round ratios B/A, and
the combined ratio.

Usage (one core)::

    taskset -c 0 python benchmarks/bench_same_process.py OLD_TREE NEW_TREE --n 1000000 --eta 0.5 --replicate 5
"""

from __future__ import annotations

import argparse
import atexit
import importlib
import json
import math
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_hard_spheres import write_results
from bench_paired import make_case


def load_builds(trees: list[str]) -> list[object]:
    """Each tree's ``edmd`` package, imported from a copy named ``edmd_<k>``."""
    root = Path(tempfile.mkdtemp(prefix="edmd-builds-"))
    atexit.register(shutil.rmtree, root, ignore_errors=True)
    sys.path.insert(0, str(root))
    builds = []
    for k, tree in enumerate(trees):
        name = f"edmd_{k}"
        shutil.copytree(Path(tree) / "src" / "edmd", root / name, ignore=shutil.ignore_patterns("__pycache__"))
        builds.append(importlib.import_module(name))
    return builds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", help="source tree A")
    ap.add_argument("new", help="source tree B")
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--eta", type=float, default=0.5)
    ap.add_argument("--neighbours", default="list")
    ap.add_argument("--replicate", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--chunk", type=float, default=10.0, help="events per particle per turn")
    ap.add_argument("--out", default=None)
    ap.add_argument("--first", choices=("A", "B"), default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.first is None:
        combine(args)
        return
    trees = [args.old, args.new] if args.first == "A" else [args.new, args.old]
    sims = [make_case(args.n, args.eta, args.neighbours, False, 3, False, args.replicate, package=edmd) for edmd in load_builds(trees)]
    if args.first == "B":
        sims.reverse()  # (sims[0] is A, sims[1] is B, whichever was made first)
    rates = [[], []]
    for r in range(args.rounds):
        for k in (0, 1) if r % 2 == 0 else (1, 0):
            sim = sims[k]
            c0, t0 = sim.collisions, time.process_time()
            sim.run(max_events=int(args.chunk * args.n))
            rates[k].append((sim.collisions - c0) / (time.process_time() - t0))
        print(f"  {args.first} made first, round {r}: A {rates[0][-1] / 1e6:.3f}  B {rates[1][-1] / 1e6:.3f}  B/A {rates[1][-1] / rates[0][-1]:.3f}", file=sys.stderr, flush=True)
    print(json.dumps(rates))


def combine(args) -> None:
    """Both orders of construction, each in a process of its own; the geometric mean of their median ratios."""
    orders = {}
    for first in ("A", "B"):
        cmd = [sys.executable, __file__, args.old, args.new, "--n", str(args.n), "--eta", str(args.eta), "--neighbours", args.neighbours, "--replicate", str(args.replicate), "--rounds", str(args.rounds), "--chunk", str(args.chunk), "--first", first]
        rates = json.loads(subprocess.run(cmd, stdout=subprocess.PIPE, text=True, check=True).stdout)
        ratios = [b / a for a, b in zip(*rates)]
        orders[first] = {"A_median": statistics.median(rates[0]) / 1e6, "B_median": statistics.median(rates[1]) / 1e6, "ratio_median": statistics.median(ratios), "ratio_min": min(ratios), "ratio_max": max(ratios), "rates": rates}
        o = orders[first]
        print(f"{first} made first: A {o['A_median']:.4f}, B {o['B_median']:.4f} M collisions/s (medians); B/A {o['ratio_median']:.4f} ({o['ratio_min']:.4f}-{o['ratio_max']:.4f})", flush=True)
    combined = math.sqrt(orders["A"]["ratio_median"] * orders["B"]["ratio_median"])
    print(f"B/A, both orders: {combined:.4f} (the build made first is faster by {math.sqrt(orders['B']['ratio_median'] / orders['A']['ratio_median']):.3f})")
    if args.out:
        write_results(args.out, args, {"orders": orders, "ratio": combined})


if __name__ == "__main__":
    main()
