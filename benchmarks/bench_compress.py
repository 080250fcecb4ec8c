"""Compression by growing particles (edmd.compression): CPU seconds to a packing fraction and to jamming.

A 3D monodisperse fluid of N spheres placed at random at packing fraction 0.1 (kT = 1, m = 1) is
compressed at the default rate (0.02, with the default slow-down near jamming) to ``--eta``
(the issue's target: N = 1e4 to 0.63 in under 60 s on one core) and, with ``--jam N``, a second
system to jamming (reduced pressure 1e12). CPU time of the compression alone (compilation first,
on a small system), ``--repeats`` times (the host is shared: the best run is the clean figure);
also collisions per second and the final reduced pressure.

Usage::

    taskset -c 0 python benchmarks/bench_compress.py --n 10000 --eta 0.63 --jam 4000 --repeats 5
"""

from __future__ import annotations

import argparse
import statistics
import time

import edmd
from bench_hard_spheres import write_results


def timed(n: int, eta: float | None, pressure: float | None, seed: int) -> dict:
    start = edmd.maxwell_boltzmann(edmd.random_packing(n, 0.1, seed=seed), 1.0, seed=seed + 1)
    t0 = time.process_time()
    run = edmd.compression(start, eta, pressure)
    cpu = time.process_time() - t0
    collisions = int(run.history["collisions"][-1])
    out = {"cpu_s": cpu, "packing_fraction": run.packing_fraction, "pressure": run.pressure, "collisions": collisions, "M_collisions_per_s": collisions / cpu / 1e6}
    if pressure is not None:
        net = run.contacts()
        out |= {"mean_contact_number": net.mean_contact_number, "rattler_fraction": net.rattler_fraction}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--eta", type=float, default=0.63)
    ap.add_argument("--jam", type=int, default=0, help="also jam a system of this size (0: no)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default="benchmarks/results/compress.json")
    args = ap.parse_args()
    timed(200, 0.3, None, seed=1)  # compile
    runs = [timed(args.n, args.eta, None, seed=1) for _ in range(args.repeats)]
    cpu = [r["cpu_s"] for r in runs]
    results = [{"case": f"N = {args.n} to eta = {args.eta}", "best_cpu_s": min(cpu), "median_cpu_s": statistics.median(cpu), **runs[0]}]
    print(f"N = {args.n} to {args.eta}: best {min(cpu):.1f} s, median {statistics.median(cpu):.1f} s CPU; Z = {runs[0]['pressure']:.3g}, {runs[0]['M_collisions_per_s']:.2f} M coll/s")
    if args.jam:
        jam = timed(args.jam, None, 1e12, seed=5)
        results.append({"case": f"N = {args.jam} to jamming (Z = 1e12)", **jam})
        print(f"N = {args.jam} jammed: {jam['cpu_s']:.1f} s CPU, phi_J = {jam['packing_fraction']:.5f}, z = {jam['mean_contact_number']:.4f}")
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
