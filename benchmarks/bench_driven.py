"""Driven granular gases: collision rate under white-noise kicks and the Andersen bath vs free cooling.

A 3D gas of N inelastic spheres (e_n = 0.9) at packing fraction eta in cells mode, on one core.
Each case is equilibrated (which also compiles), then timed over ``--measure`` collisions per
particle with the loop's CPU timer; reported as M collisions/s and as a fraction of the freely
cooling gas's rate. The kick interval is given in units of the mean free time of the gas
(measured from its collision rate), since the cost of a kick is one re-prediction of every
particle whatever the interval.

Usage::

    python benchmarks/bench_driven.py --n 10000 --eta 0.05
"""

from __future__ import annotations

import argparse
import time

import edmd
from bench_hard_spheres import write_results


def rate(sim: edmd.Simulation, collisions_per_particle: float) -> float:
    """M collisions/s over the next ``collisions_per_particle * N`` collisions (CPU time)."""
    n = sim.state.n
    c0, t0 = sim.collisions, time.process_time()
    while sim.collisions - c0 < collisions_per_particle * n:
        sim.run(max_events=n)
    return (sim.collisions - c0) / (time.process_time() - t0) / 1e6


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--eta", type=float, default=0.05)
    ap.add_argument("--measure", type=float, default=10.0, help="collisions per particle per timed run")
    ap.add_argument("--intervals", type=float, nargs="+", default=[0.1, 0.3, 1.0], help="kick intervals in mean free times")
    ap.add_argument("--out", default="benchmarks/results/driven.json")
    args = ap.parse_args()
    state = edmd.maxwell_boltzmann(edmd.random_packing(args.n, args.eta, seed=1), 1.0, seed=2)
    engine = {"neighbours": "cells"}

    free = edmd.Simulation(state, e_n=0.9, engine=engine)
    free.run(max_events=20 * args.n)
    before, t_before = free.totals(), free.state.temperature()
    free_rate = rate(free, args.measure)
    after, t_after = free.totals(), free.state.temperature()
    dt = after.time - before.time
    t_mean = 0.5 * (t_before + t_after)
    tau = args.n * dt / (2.0 * (after.collisions - before.collisions)) * t_mean**0.5  # mean free time at T = 1
    loss = (after.dissipated - before.dissipated) / (args.n * dt) / t_mean**1.5  # per particle and time, at T = 1
    xi0 = (2.0 * loss / 3.0) ** 0.5  # white noise that holds T ~ 1: m d xi0^2 / 2 = loss
    results = [{"case": "free cooling", "M_collisions_per_s": free_rate, "fraction": 1.0, "mean_free_time": tau, "xi0": xi0}]
    print(f"free cooling: {free_rate:.3f} M coll/s, mean free time {tau:.3g} (T = 1), xi0 for T ~ 1: {xi0:.3g}")

    cases = [
        (f"white noise, kick every {k} mean free times", {"forcing": edmd.WhiteNoise(xi0=xi0, interval=k * tau, seed=3)})
        for k in args.intervals
    ]
    cases.append(("Andersen bath, rate 0.1 / mean free time", {"thermostat": edmd.Andersen(kT=1.0, rate=0.1 / tau, seed=4)}))
    for name, driver in cases:
        sim = edmd.Simulation(state, e_n=0.9, engine=engine, **driver)
        sim.run(max_events=20 * args.n)
        r = rate(sim, args.measure)
        results.append({"case": name, "M_collisions_per_s": r, "fraction": r / free_rate, "temperature": sim.state.temperature()})
        print(f"{name}: {r:.3f} M coll/s ({r / free_rate:.0%} of free cooling), T = {sim.state.temperature():.3g}")
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
