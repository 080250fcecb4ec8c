"""A vibrated 2D bed: collision rate of N inelastic disks on a sinusoidally vibrating floor.

``--layers`` layers of disks (diameter 1, e_n = 0.9, TC 1e-3) at rest over a floor ``N / layers``
diameters wide (periodic sideways), a box 150 diameters high, gravity 1, and the floor shaken
with amplitude 1 and ``Gamma = a omega^2 / g``. The bed is driven to its steady state for
``--settle`` time units (which also compiles), then timed over ``--measure`` collisions per
particle with the CPU timer, one core. Cells or lists as the engine chooses (``auto``).

Usage::

    python benchmarks/bench_vibrated.py --n 10000 --layers 10 --gamma 9
"""

from __future__ import annotations

import argparse
import math

import edmd
from bench_driven import rate
from bench_hard_spheres import write_results


def vibrated_bed(n: int, layers: float, gamma: float, height: float = 150.0, seed: int = 1) -> edmd.Simulation:
    width = n / layers
    eta = n * math.pi * 0.25 / (width * height)
    state = edmd.random_packing(n, eta, dim=2, aspect=[1.0, height / width], periodic=[True, False], seed=seed)
    state = edmd.maxwell_boltzmann(state, 1.0, seed=seed + 1)
    floor = edmd.VibratingWall(amplitude=1.0, omega=math.sqrt(gamma), phase=-0.5 * math.pi, axis="y")
    rule = edmd.collide.TC(edmd.collide.Inelastic(0.9), 1e-3)
    return edmd.Simulation(state, collision=rule, walls=edmd.collide.Wall(e_n=0.9), gravity=[0.0, -1.0], vibration=floor)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--layers", type=float, default=10.0)
    ap.add_argument("--gamma", type=float, default=9.0)
    ap.add_argument("--settle", type=float, default=100.0, help="time units before timing")
    ap.add_argument("--measure", type=float, default=10.0, help="collisions per particle per timed run")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default="benchmarks/results/vibrated.json")
    args = ap.parse_args()
    sim = vibrated_bed(args.n, args.layers, args.gamma)
    sim.run(until_time=args.settle)
    rates = [rate(sim, args.measure) for _ in range(args.repeat)]
    t = sim.totals()
    result = {
        "case": f"2D vibrated bed, N = {args.n}, {args.layers:g} layers, Gamma = {args.gamma:g}",
        "neighbours": sim.engine.mode,
        "M_collisions_per_s_best": max(rates),
        "M_collisions_per_s_median": sorted(rates)[len(rates) // 2],
        "wall_collisions_per_collision": t.wall_collisions / t.collisions,
        "temperature": sim.state.temperature(),
    }
    print(result)
    write_results(args.out, args, [result])


if __name__ == "__main__":
    main()
