"""Soft-contact speed: direct two-body solve, table lookup, table accuracy, DEM particle-steps/s.

* **Direct solve**: :func:`edmd._core.twobody.solve_scaled` (DOP853, rtol 1e-12) at random
  points of each model's default table box (damping and eccentricity uniform, softness
  log-uniform in [1e-6, max]), called from a compiled loop: microseconds per contact.
* **Table lookup**: the compiled interpolation at random points of the box, from table
  coordinates (:func:`edmd._core.lookup.lookup`) and from physical impact data including the
  table coordinates (:func:`edmd._core.lookup.matrix_of_restitution`): nanoseconds per lookup;
  for a pair of one species, also from its pair table (:func:`edmd._core.lookup.pair_restitution`,
  physics.md §4.7) against the three-dimensional table on the same impacts.
* **Table accuracy**: :func:`edmd.physics.tables.check_table` on 1e4 points, log and linear softness.
* **DEM**: :class:`edmd.DEMSimulation`, 3D dilute gases (fcc start, kT = 1, sigma = m = 1),
  dashpot (k = 1e4, e_n = 0.9) and Hertz (Y = 1e5, nu = 0.3, A = 1e-4), 50 steps per contact:
  particle-steps per second after 200 warm-up steps.

Medians of ``--repeats`` timed runs on one core, compilation excluded; results with machine
information go to ``results/soft_contacts.json``.

Usage::

    python benchmarks/bench_soft_contacts.py
    python benchmarks/bench_soft_contacts.py --dem-n 4000 32000 --repeats 5
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from pathlib import Path

import numpy as np
from bench_hard_spheres import write_results
from numba import njit

import edmd
from edmd._core import lookup as lk
from edmd.physics.contact import Hertz, LinearDashpot
from edmd.physics.tables import check_table, default_table, pair_table

CONTACTS = {"dashpot": LinearDashpot.from_restitution(0.9, k=1e4, mass=1.0), "hertz": Hertz(young=1e5, poisson=0.3, A=1e-4)}


def box_points(model: str, n: int, seed: int = 0):
    box = default_table(model).box
    rng = np.random.default_rng(seed)
    u1 = rng.uniform(*box.damping, n)
    lam_v = 10.0 ** rng.uniform(-6.0, math.log10(box.softness[1]), n)
    b = rng.uniform(*box.b, n)
    return u1, lam_v, b


@njit(cache=True)
def _physical_lookups(model, a, bb, mu, reff, sigma, vn, vt, values, tg, ctab, cgeo, W, K):
    s = 0.0
    for k in range(vn.shape[0]):
        r = lk.matrix_of_restitution(model, a, bb, mu, reff, sigma, vn[k], vt[k], True, values, tg, ctab, cgeo, 1e-12, W, K)
        s += r[0] + r[2]
    return s


@njit(cache=True)
def _pair_lookups(model, a, bb, m, r, vn, vt, pv, pg, W):
    s = 0.0
    for k in range(vn.shape[0]):
        phi, _d, tc, _eps = lk.pair_restitution(model, a, bb, m, m, r, r, vn[k], vt[k], pv, pg, W)
        s += phi + tc
    return s


def timed(fn, repeats):
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def bench_solver(model: str, points: int, repeats: int) -> dict:
    tab = default_table(model)
    u1, lam_v, b = box_points(model, points)
    out = np.zeros((points, 6))
    K = np.zeros((13, 3))
    lk.direct_many(tab.code, u1[:10], lam_v[:10], b[:10], 1e-12, out[:10], K)  # compile
    times = timed(lambda: lk.direct_many(tab.code, u1, lam_v, b, 1e-12, out, K), repeats)
    us = [t / points * 1e6 for t in times]
    return {"model": model, "points": points, "us_per_solve": statistics.median(us), "us_per_solve_all": us}


def bench_lookup(model: str, points: int, repeats: int) -> dict:
    tab = default_table(model)
    flat, tg, ctab, cgeo = tab.core()
    u1, lam_v, b = box_points(model, points, seed=1)
    out = np.zeros((points, 6))
    W = np.zeros(lk.SCRATCH_SHAPE)
    lk.lookup_many(tab.code, flat, tg, ctab, cgeo, u1[:10], lam_v[:10], b[:10], out[:10], W)
    ns = [t / points * 1e9 for t in timed(lambda: lk.lookup_many(tab.code, flat, tg, ctab, cgeo, u1, lam_v, b, out, W), repeats)]
    # from physical impacts: a polydisperse pair, speeds spread over the table's range
    contact = CONTACTS[model]
    a, bb = contact.constants()
    m1, m2, R1, R2 = 1.0, 1.7, 0.5, 0.6
    mu, reff, sigma = m1 * m2 / (m1 + m2), R1 * R2 / (R1 + R2), R1 + R2
    rng = np.random.default_rng(2)
    v = 10.0 ** rng.uniform(-2, 0.5, points)
    ecc = rng.uniform(0, 0.99, points)
    vn, vt = v * np.sqrt(1 - ecc**2), v * ecc
    K = np.zeros((13, 3))
    _physical_lookups(tab.code, a, bb, mu, reff, sigma, vn[:10], vt[:10], flat, tg, ctab, cgeo, W, K)
    ns_phys = [t / points * 1e9 for t in timed(lambda: _physical_lookups(tab.code, a, bb, mu, reff, sigma, vn, vt, flat, tg, ctab, cgeo, W, K), repeats)]
    # one species (m = 1, R = 0.5): the pair table against the three-dimensional table, same impacts
    pv, pg = pair_table(tab, tab.code, a, bb, 1.0, 0.5, 1.0, 0.5)
    inside = np.zeros((points, 4))
    lk.pair_restitution_many(tab.code, a, bb, 1.0, 1.0, 0.5, 0.5, vn, vt, pv, pg, inside, W)
    vn, vt = vn[np.isfinite(inside[:, 2])], vt[np.isfinite(inside[:, 2])]  # (impacts its grid covers)
    _pair_lookups(tab.code, a, bb, 1.0, 0.5, vn[:10], vt[:10], pv, pg, W)
    ns_pair = [t / vn.size * 1e9 for t in timed(lambda: _pair_lookups(tab.code, a, bb, 1.0, 0.5, vn, vt, pv, pg, W), repeats)]
    ns_same = [t / vn.size * 1e9 for t in timed(lambda: _physical_lookups(tab.code, a, bb, 0.5, 0.25, 1.0, vn, vt, flat, tg, ctab, cgeo, W, K), repeats)]
    return {
        "model": model,
        "points": points,
        "ns_per_pair_table_lookup": statistics.median(ns_pair),
        "ns_per_table_lookup_same_species": statistics.median(ns_same),
        "pair_table_shape": [int(pg[0, lk.PG_SPEED + 4]), int(pg[0, lk.PG_B_AXIS + 4])],
        "pair_table_impacts": int(vn.size),
        "ns_per_lookup": statistics.median(ns),
        "ns_per_lookup_all": ns,
        "ns_per_physical_lookup": statistics.median(ns_phys),
        "ns_per_physical_lookup_all": ns_phys,
        "table_shape": list(tab.shape),
        "table_bytes": int(tab.values.nbytes),
    }


def bench_accuracy(model: str, points: int) -> dict:
    tab = default_table(model)
    res = {s: check_table(tab, points, seed=5, sampling=s) for s in ("log", "linear")}
    return {"model": model, "points": points, "box": tab.box.describe(), **{f"max_rel_error_{s}": r["max"] for s, r in res.items()}, "details": res}


def bench_dem(n: int, eta: float, model: str, steps: int, repeats: int) -> dict:
    state = edmd.maxwell_boltzmann(edmd.lattice(n, eta), kT=1.0, seed=3)
    sim = edmd.DEMSimulation(state, CONTACTS[model])
    sim.run(max_events=200)
    rates = []
    for _ in range(repeats):
        e0 = sim.events
        t0 = time.perf_counter()
        sim.run(max_events=steps)
        rates.append(n * (sim.events - e0) / (time.perf_counter() - t0))
    return {
        "n": n,
        "eta": eta,
        "model": model,
        "dt": sim.dt,
        "particle_steps_per_s": statistics.median(rates),
        "particle_steps_per_s_all": rates,
        "contacts_per_particle_per_step": sim.collisions / (n * sim.events),
        "list_builds_per_step": float(sim.engine.cnt[edmd._core.layout.C_REBUILD] / sim.events),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=20000, help="random contacts per timing")
    ap.add_argument("--dem-n", type=int, nargs="+", default=[4000, 32000])
    ap.add_argument("--dem-eta", type=float, nargs="+", default=[0.05, 0.2])
    ap.add_argument("--dem-steps", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=str(Path(__file__).with_name("results") / "soft_contacts.json"))
    args = ap.parse_args(argv)
    results = {"solver": [], "lookup": [], "accuracy": [], "dem": []}
    for model in ("dashpot", "hertz"):
        r = bench_solver(model, args.points, args.repeats)
        results["solver"].append(r)
        print(f"{model}: direct solve {r['us_per_solve']:.2f} us", flush=True)
        r = bench_lookup(model, 10 * args.points, args.repeats)
        results["lookup"].append(r)
        print(f"{model}: table lookup {r['ns_per_lookup']:.0f} ns, from physical impact data {r['ns_per_physical_lookup']:.0f} ns", flush=True)
        print(f"{model}: one species, pair table {r['ns_per_pair_table_lookup']:.0f} ns, table {r['ns_per_table_lookup_same_species']:.0f} ns ({r['pair_table_impacts']} impacts)", flush=True)
        r = bench_accuracy(model, 10_000)
        results["accuracy"].append(r)
        print(f"{model}: table max relative error {r['max_rel_error_log']:.2e} (log softness), {r['max_rel_error_linear']:.2e} (linear)", flush=True)
    for n in args.dem_n:
        for eta in args.dem_eta:
            for model in ("dashpot", "hertz"):
                r = bench_dem(n, eta, model, args.dem_steps, args.repeats)
                results["dem"].append(r)
                print(f"DEM {model} N={n} eta={eta}: {r['particle_steps_per_s'] / 1e6:.1f} M particle-steps/s", flush=True)
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
