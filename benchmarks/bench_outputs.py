"""What an output costs: CPU seconds per row of ``edmd.Thermo`` (written to a CSV file) or per
frame of ``edmd.Trajectory`` (``--output trajectory``), for one or more source trees side by
side (issue 11: observers that stream copies).

Each tree runs in a worker process of its own (``PYTHONPATH=TREE/src``) that builds the case
(:func:`bench_paired.make_case`, equilibrated) and then serves rounds: in each, the same span
of simulation time is run without observers and with ``--rows`` outputs, and the output's cost
is the difference of the two CPU times divided by the rows. The trees' rounds alternate. Prints
and writes the best and the median per tree, in ms per row and ns per particle per row.

Usage (one core)::

    taskset -c 1 python benchmarks/bench_outputs.py /tmp/old . --n 10000 --eta 0.05 --emdstar
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

from bench_hard_spheres import write_results


def worker(args) -> None:
    import edmd
    from bench_paired import make_case

    sim = make_case(args.n, args.eta, args.neighbours, False, args.dim, args.emdstar, args.replicate)
    span = args.span * sim.time / 20.0  # (make_case ran 20 events per particle: about `span` of them per round)
    folder = tempfile.mkdtemp(prefix="edmd-bench-outputs-")
    print("ready", flush=True)
    for k, _line in enumerate(sys.stdin):
        t0 = time.process_time()
        sim.run(until_time=sim.time + span)
        bare = time.process_time() - t0
        every, first = span / args.rows, sim.time + span / args.rows
        if args.output == "thermo":
            sim.add(edmd.Thermo(every, path=os.path.join(folder, f"thermo{k}.csv"), start=first))
        else:
            sim.add(edmd.Trajectory(os.path.join(folder, f"trajectory{k}.gsd"), every, start=first))
        t0 = time.process_time()
        sim.run(until_time=sim.time + span)
        observed = time.process_time() - t0
        sim.observers.clear()
        print((observed - bare) / args.rows, flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("trees", nargs="*", help="source trees to compare (default: this one)")
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--eta", type=float, default=0.05)
    ap.add_argument("--dim", type=int, default=3)
    ap.add_argument("--neighbours", default="cells")
    ap.add_argument("--emdstar", action="store_true", help="the eMD* gas of bench_emdstar.py")
    ap.add_argument("--replicate", type=int, default=1, help="tile a relaxed box of n / replicate^dim particles (large N)")
    ap.add_argument("--output", choices=["thermo", "trajectory"], default="thermo")
    ap.add_argument("--rows", type=int, default=50, help="outputs per round")
    ap.add_argument("--span", type=float, default=2.0, help="events per particle per round (roughly)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default=None)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(args)
    trees = args.trees or [os.path.join(os.path.dirname(__file__), "..")]
    flags = ["--n", str(args.n), "--eta", str(args.eta), "--dim", str(args.dim), "--neighbours", args.neighbours, "--rows", str(args.rows), "--output", args.output, "--replicate", str(args.replicate), "--span", str(args.span)]
    procs = []
    for tree in trees:
        env = {**os.environ, "PYTHONPATH": os.path.join(os.path.abspath(tree), "src")}
        cmd = [sys.executable, __file__, "--worker", *flags] + (["--emdstar"] if args.emdstar else [])
        p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env, cwd=os.path.dirname(os.path.abspath(__file__)))
        assert p.stdout.readline().strip() == "ready"
        procs.append(p)
    costs = [[] for _ in trees]
    for _ in range(args.rounds):
        for k, p in enumerate(procs):
            p.stdin.write("go\n")
            p.stdin.flush()
            costs[k].append(float(p.stdout.readline()))
    for p in procs:
        p.stdin.close()
        p.wait()
    results = []
    for tree, c in zip(trees, costs):
        best, median = min(c), statistics.median(c)
        results.append({"tree": tree, "seconds_per_row": c, "best_ms": best * 1e3, "median_ms": median * 1e3, "best_ns_per_particle": best * 1e9 / args.n})
        print(f"{tree}: {best * 1e3:.3f} / {median * 1e3:.3f} ms per {'row' if args.output == 'thermo' else 'frame'} (best / median), {best * 1e9 / args.n:.1f} ns per particle")
    write_results(args.out or os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", f"outputs_{args.output}_{args.n}_{args.eta}{'_emdstar' if args.emdstar else ''}.json"), args, results)


if __name__ == "__main__":
    main()
