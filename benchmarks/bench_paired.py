"""Paired speed of two builds of edmd: alternating chunks of events in two live processes.

Each build (a source tree with ``src/edmd``) runs in its own process pinned to one core, from the
same amorphous start, equilibrated for 20 events per particle (which also compiles). The two
processes then take turns, one chunk of ``--chunk`` events per particle each (the order flips
every round), so a slow spell of the shared host hits both builds of a round alike. With
``--pairs K`` this is repeated with K fresh process pairs: at large N a process keeps its rate
for life (the same code in both processes read 0.83 in one pair, 1.00 in another at N = 1e6).
Reported:
per build the best and the median M collisions/s (the loop's own CPU-time timer), and the
median, min and max of the per-round ratio B/A.

Usage::

    python benchmarks/bench_paired.py OLD_TREE NEW_TREE --n 10976 --eta 0.5 --neighbours list
    python benchmarks/bench_paired.py OLD_TREE NEW_TREE --n 10000 --eta 0.05 --neighbours cells --emdstar
    python benchmarks/bench_paired.py OLD_TREE NEW_TREE --n 1000000 --eta 0.5 --replicate 5 --chunk 5
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

from bench_hard_spheres import write_results


def make_case(n: int, eta: float, neighbours: str, walls: bool, dim: int, emdstar: bool, replicate: int, package=None, rough: bool = False, bath: bool = False):
    """The Simulation of a benchmark case (also :mod:`profile_loop`'s), equilibrated for 20 events
    per particle (which also compiles). ``package``: the edmd build to use (:mod:`bench_same_process`;
    hard spheres only), else the one imported as ``edmd``. ``rough``: perfectly rough elastic
    spheres (``e_n = 1``, ``beta = 1``: energy conserved, shared between translation and spin).
    ``bath``: an Andersen heat bath at ``kT = 1`` that re-draws a particle's velocity 0.05 times per
    unit time (about one bath event per ten collisions at eta = 0.05)."""
    import edmd

    if package is not None:
        if emdstar:
            raise ValueError("the eMD* case uses the edmd imported as edmd")
        edmd = package

    periodic = [True] * (dim - 1) + [not walls]
    if emdstar:  # the viscoelastic gas of bench_emdstar.py (SI units)
        from bench_emdstar import DENSITY, RADIUS, contact_law
        from edmd.physics.emdstar import EMDStar

        state = edmd.random_packing(n, eta, dim=dim, radius=RADIUS, density=DENSITY, seed=1, periodic=periodic)
        state = edmd.maxwell_boltzmann(state, float(state.mass[0]) / 3.0, seed=2)
        sim = edmd.Simulation(state, collision=EMDStar(contact_law()), engine={"neighbours": neighbours})
    else:
        start = edmd.random_packing(n // replicate**dim, eta, dim=dim, seed=1, periodic=periodic)
        state = edmd.maxwell_boltzmann(edmd.replicate(start, [replicate] * dim) if replicate > 1 else start, 1.0, seed=2, spin=rough)
        rule = edmd.physics.collide.Rough(e_n=1.0, beta=1.0) if rough else None
        bath_rule = edmd.Andersen(kT=1.0, rate=0.05, seed=4) if bath else None
        sim = edmd.Simulation(state, collision=rule, thermostat=bath_rule, engine={"neighbours": neighbours})
    sim.run(max_events=20 * n)
    return sim


def worker(n: int, eta: float, neighbours: str, chunk: float, walls: bool, dim: int, emdstar: bool, replicate: int, rough: bool = False, bath: bool = False) -> None:
    """Serve chunks: read a line, run ``chunk * n`` events, print the collision rate."""
    sim = make_case(n, eta, neighbours, walls, dim, emdstar, replicate, rough=rough, bath=bath)
    print("ready", *_huge_pages(), flush=True)
    for _line in sys.stdin:
        c0, t0 = sim.collisions, time.process_time()
        sim.run(max_events=int(chunk * n))
        print((sim.collisions - c0) / (time.process_time() - t0), flush=True)


def _huge_pages() -> tuple[int, int]:
    """MB of this process's memory on transparent huge pages, and its resident MB (0, 0 where unknown)."""
    try:
        with open("/proc/self/smaps_rollup") as f:
            kb = {line.split(":")[0]: int(line.split()[1]) for line in f if line.split()[-1] == "kB"}
        return kb.get("AnonHugePages", 0) // 1024, kb.get("Rss", 0) // 1024
    except OSError:
        return 0, 0


def start(tree: str, args) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.path.join(os.path.abspath(tree), "src")}
    cmd = [sys.executable, __file__, "--worker", "--n", str(args.n), "--eta", str(args.eta), "--neighbours", args.neighbours, "--chunk", str(args.chunk), "--dim", str(args.dim), "--replicate", str(args.replicate)] + (["--walls"] if args.walls else []) + (["--emdstar"] if args.emdstar else []) + (["--rough"] if args.rough else []) + (["--bath"] if args.bath else [])
    proc = subprocess.Popen(["taskset", "-c", str(args.core), *cmd], env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    ready = proc.stdout.readline().split()
    if not ready or ready[0] != "ready":
        raise SystemExit(f"the build in {tree} failed to start")
    print(f"{tree}: {ready[1]} of {ready[2]} MB resident on huge pages", flush=True)
    return proc


def rate(proc: subprocess.Popen) -> float:
    proc.stdin.write("go\n")
    proc.stdin.flush()
    return float(proc.stdout.readline())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("old", nargs="?", help="source tree A")
    ap.add_argument("new", nargs="?", help="source tree B")
    ap.add_argument("--n", type=int, default=10976)
    ap.add_argument("--eta", type=float, default=0.5)
    ap.add_argument("--neighbours", default="list")
    ap.add_argument("--rounds", type=int, default=16, help="turns of each process pair")
    ap.add_argument("--pairs", type=int, default=1, help="fresh process pairs, one after the other (large N: a process keeps its rate for life; pairs of the same code differed by up to 17 %%)")
    ap.add_argument("--chunk", type=float, default=30.0, help="events per particle per turn")
    ap.add_argument("--core", type=int, default=0)
    ap.add_argument("--walls", action="store_true", help="elastic walls on the last axis (the wall code paths)")
    ap.add_argument("--dim", type=int, default=3)
    ap.add_argument("--replicate", type=int, default=1, help="relax n / k^dim particles and tile them k times per axis (large N; hard spheres)")
    ap.add_argument("--emdstar", action="store_true", help="eMD* (the viscoelastic gas of bench_emdstar.py) instead of elastic hard spheres")
    ap.add_argument("--rough", action="store_true", help="perfectly rough elastic spheres (e_n = 1, beta = 1; the rough loop variant)")
    ap.add_argument("--bath", action="store_true", help="an Andersen heat bath (the bath loop variant)")
    ap.add_argument("--out", default=None)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(args.n, args.eta, args.neighbours, args.chunk, args.walls, args.dim, args.emdstar, args.replicate, args.rough, args.bath)
    ra, rb, pair_medians = [], [], []
    for p in range(args.pairs):
        # the process started first may find more free huge pages: the order alternates too
        if p % 2 == 0:
            a = start(args.old, args)
            b = start(args.new, args)
        else:
            b = start(args.new, args)
            a = start(args.old, args)
        pa, pb = [], []
        for r in range(args.rounds):
            for proc, out in ((a, pa), (b, pb)) if (r + p) % 2 == 0 else ((b, pb), (a, pa)):
                out.append(rate(proc))
        for proc in (a, b):
            proc.stdin.close()
            proc.wait()
        pair_medians.append(statistics.median(y / x for x, y in zip(pa, pb)))
        if args.pairs > 1:
            print(f"pair {p + 1}: B/A median {pair_medians[-1]:.4f}", flush=True)
        ra += pa
        rb += pb
    ratios = [y / x for x, y in zip(ra, rb)]
    summary = {
        "A": {"tree": args.old, "best": max(ra) / 1e6, "median": statistics.median(ra) / 1e6},
        "B": {"tree": args.new, "best": max(rb) / 1e6, "median": statistics.median(rb) / 1e6},
        "ratio_B_over_A": {"median": statistics.median(ratios), "min": min(ratios), "max": max(ratios)},
        "pair_medians": pair_medians,
    }
    print(f"A: best {summary['A']['best']:.4f} median {summary['A']['median']:.4f} M collisions/s")
    print(f"B: best {summary['B']['best']:.4f} median {summary['B']['median']:.4f} M collisions/s")
    print(f"B/A per round: median {statistics.median(ratios):.4f} (min {min(ratios):.4f}, max {max(ratios):.4f}, {args.rounds} rounds x {args.pairs} pairs)")
    out = args.out or f"benchmarks/results/paired_{args.n}_{args.eta}_{args.neighbours}{'_2d' if args.dim == 2 else ''}{'_emdstar' if args.emdstar else ''}{'_rough' if args.rough else ''}{'_bath' if args.bath else ''}.json"
    write_results(out, args, [summary])


if __name__ == "__main__":
    main()
