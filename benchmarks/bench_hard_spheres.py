"""Hard-sphere EDMD speed: collisions/s and events/s on one core, excluding compilation.

For each (N, eta): an amorphous start (random positions, overlaps relaxed), Maxwell-Boltzmann
velocities, equilibration (compiles the core, melts any order), then ``--repeats`` timed runs of
``--measure`` collisions per particle. Reports the median rate, the engine's bytes per particle
(all compiled-core arrays) and the process's peak resident memory, with machine info.

Usage::

    python benchmarks/bench_hard_spheres.py                       # the issue's four cases
    python benchmarks/bench_hard_spheres.py --n 10976 --eta 0.5 --repeats 5
    python benchmarks/bench_hard_spheres.py --n 1000000 --eta 0.5 --replicate 5   # 8000 relaxed, tiled
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import edmd
from edmd._core import layout as L


def machine_info() -> dict:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import numba

    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "numba": numba.__version__,
        "platform": platform.platform(),
        "date": datetime.date.today().isoformat(),
    }


def write_results(path: str, args: argparse.Namespace, results) -> None:
    """Write the results with machine information and the arguments as JSON."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": machine_info(), "args": vars(args), "results": results}, indent=2))
    print(f"wrote {out}")


def engine_bytes(sim: edmd.Simulation) -> int:
    e = sim.engine
    arrays = [*e.part, *e.ev, *e.q, *e.grid, *e.lists]
    return sum(a.nbytes for a in arrays)


def bench(n: int, eta: float, mode: str, equilibrate: float, measure: float, repeats: int, seed: int = 1, replicate: int = 1) -> dict:
    start = edmd.random_packing(n // replicate**3, eta, dim=3, seed=seed)
    state = edmd.maxwell_boltzmann(edmd.replicate(start, [replicate] * 3), 1.0, seed=seed + 1)
    sim = edmd.Simulation(state, engine={"neighbours": mode})
    sim.run(max_events=int(equilibrate * n))
    u0 = sim.state.unwrapped_position
    rates, event_rates, ratios = [], [], []
    for _ in range(repeats):
        c0, e0 = sim.collisions, sim.events
        t0 = time.perf_counter()
        sim.run(max_events=int(measure * n * 1.6))
        dt = time.perf_counter() - t0
        rates.append((sim.collisions - c0) / dt)
        event_rates.append((sim.events - e0) / dt)
        ratios.append((sim.events - e0) / max(sim.collisions - c0, 1))
    msd = float(((sim.state.unwrapped_position - u0) ** 2).sum(axis=1).mean())
    cnt = sim.engine.cnt
    return {
        "n": state.n,
        "eta": eta,
        "replicate": replicate,
        "neighbours": sim.engine.mode,
        "collisions_per_s": statistics.median(rates),
        "collisions_per_s_all": rates,
        "events_per_s": statistics.median(event_rates),
        "events_per_collision": statistics.median(ratios),
        "stale_per_collision": float(cnt[L.C_STALE] / cnt[L.C_COLL]),
        "rebuilds_per_collision": float(cnt[L.C_REBUILD] / cnt[L.C_COLL]),
        "msd_during_measurement": msd,
        "engine_bytes_per_particle": engine_bytes(sim) / n,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[10976, 108000])
    ap.add_argument("--eta", type=float, nargs="+", default=[0.3, 0.5])
    ap.add_argument("--mode", default="auto", choices=["auto", "list", "cells"])
    ap.add_argument("--equilibrate", type=float, default=30.0, help="events per particle before timing")
    ap.add_argument("--measure", type=float, default=10.0, help="collisions per particle per timed run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--replicate", type=int, default=1, help="relax n / k^3 particles and tile them k x k x k (large N)")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results") / "hard_spheres.json"))
    args = ap.parse_args(argv)
    results = []
    for n in args.n:
        for eta in args.eta:
            r = bench(n, eta, args.mode, args.equilibrate, args.measure, args.repeats, replicate=args.replicate)
            results.append(r)
            print(
                f"N={n:7d} eta={eta:.2f} [{r['neighbours']}]: {r['collisions_per_s'] / 1e6:.3f} M coll/s, "
                f"{r['events_per_s'] / 1e6:.3f} M events/s, {r['events_per_collision']:.2f} events/coll, "
                f"{r['engine_bytes_per_particle']:.0f} B/particle, peak RSS {r['peak_rss_mb']:.0f} MB, "
                f"MSD {r['msd_during_measurement']:.2f}",
                flush=True,
            )
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
