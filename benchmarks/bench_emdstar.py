"""eMD* speed: wall time of a dilute viscoelastic gas against force-based MD, and event rates.

A 3D gas of N = 1e4 viscoelastic spheres in SI units (R = 1 mm, 2500 kg/m^3, Y = 1e8 Pa,
nu = 0.3, A = 1e-6 s: e_n ~ 0.94 and t_c ~ 3e-5 s at the thermal speed sqrt(<v^2>) = 1 m/s)
at packing fractions 0.01, 0.05 and 0.1 is advanced over the same physical time (about two
collisions per particle) by

* **eMD*** (:class:`edmd.physics.emdstar.EMDStar`, default tables), and
* **DEM** (:class:`edmd.DEMSimulation`) at 50 steps per shortest contact (common practice, the
  trajectories then deviate from Newton's by ~1e-4 sigma per contact) and at 400 steps per
  contact (~1e-6 sigma, eMD*'s accuracy with tables, see ``tests/test_emdstar.py``).

It also runs elastic hard spheres (plain EDMD) from the same state: eMD*'s collision rate
relative to it. Compilation excluded (one warm-up run each); medians of ``--repeats``.
Results with machine information go to ``results/emdstar.json``. ``--friction MU`` gives every
contact Hertz-Mindlin friction with that coefficient (eMD*: the frictional two-body solver per
contact; DEM: the same laws; spins at the same temperature as the translation at the start),
results in ``results/emdstar_friction.json``; ``--friction-table`` takes the tangential impulse
from the hard-limit table instead (docs/physics.md §4.12). ``--young Y`` sets a harder or softer
material with the same restitution (A scaled as Y^(-2/5), so the damping at a given speed is
the same; the softness Lambda scales as Y^(-2/5), the contact duration too). ``--alternate K``
measures eMD*'s collision rate relative to hard spheres the way ``bench_paired.py`` pairs builds:
both from the same state in one process (20 events per particle first), then K rounds of
alternating chunks of 30 events per particle, CPU time of each chunk (short wall-time runs of a
shared host scatter by tens of per cent).

Usage::

    python benchmarks/bench_emdstar.py
    python benchmarks/bench_emdstar.py --n 4000 --eta 0.01 0.05 --repeats 1
    python benchmarks/bench_emdstar.py --friction 0.3 --eta 0.05 --out benchmarks/results/emdstar_friction.json
    python benchmarks/bench_emdstar.py --friction 0.3 --friction-table --young 1e9 --eta 0.05 --n 4000
    taskset -c 1 python benchmarks/bench_emdstar.py --eta 0.01 0.05 --alternate 8 --out benchmarks/results/emdstar_alternate.json
"""

from __future__ import annotations

import argparse
import statistics
import time

from bench_hard_spheres import write_results

import edmd
from edmd.physics.emdstar import EMDStar

RADIUS, DENSITY = 1e-3, 2500.0


def contact_law(young: float = 1e8) -> edmd.Hertz:
    """The benchmark's material (Y = 1e8 Pa, A = 1e-6 s), or one of Young's modulus ``young`` with the same e_n(v)."""
    return edmd.Hertz(young=young, poisson=0.3, A=1e-6 * (young / 1e8) ** -0.4)


def gas(n: int, eta: float, spin: bool = False) -> edmd.State:
    state = edmd.random_packing(n, eta, dim=3, radius=RADIUS, density=DENSITY, seed=1)
    kT = float(state.mass[0]) / 3.0  # <v^2> = 1 (m/s)^2
    return edmd.maxwell_boltzmann(state, kT, seed=2, spin=spin)


def timed(make, t_end: float, repeats: int) -> tuple[float, object]:
    """Median wall time of ``make().run(until_time=t_end)`` (a first untimed run compiles)."""
    make().run(until_time=t_end * 1e-3)
    times = []
    for _ in range(repeats):
        sim = make()
        t0 = time.perf_counter()
        sim.run(until_time=t_end)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), sim


def bench(n: int, eta: float, repeats: int, friction=None, table: bool = False, young: float = 1e8) -> dict:
    state = gas(n, eta, spin=friction is not None)
    contact = contact_law(young)
    rule = EMDStar(contact, friction=friction, friction_table=table)
    probe = edmd.Simulation(state, collision=rule)
    probe.run(max_events=20 * n)
    rate = 2.0 * probe.collisions / (n * probe.time)  # collisions per particle and second
    t_end = 2.0 / rate
    emd_s, emd = timed(lambda: edmd.Simulation(state, collision=rule), t_end, repeats)
    hs_s, hs = timed(lambda: edmd.Simulation(state), t_end, repeats)
    row = {
        "n": n,
        "eta": eta,
        "friction_mu": None if friction is None else friction.mu,
        "friction_table": table,
        "young": young,
        "physical_time_s": t_end,
        "collisions_per_particle": 2.0 * emd.collisions / n,
        "emd_seconds": emd_s,
        "emd_collisions_per_second": emd.collisions / emd_s,
        "emd_events_per_second": emd.events / emd_s,
        "emd_counters": emd.engine.emd_counters(),
        "hard_sphere_collisions_per_second": hs.collisions / hs_s,
        "hard_sphere_events_per_second": hs.events / hs_s,
    }
    row["emd_rate_relative_to_hard_spheres"] = row["emd_collisions_per_second"] / row["hard_sphere_collisions_per_second"]
    for spc in (50, 400):
        dem_s, dem = timed(lambda: edmd.DEMSimulation(state, contact, steps_per_contact=spc, friction=friction), t_end, 1)
        row[f"dem{spc}_seconds"] = dem_s
        row[f"dem{spc}_steps"] = dem.steps
        row[f"speedup_vs_dem{spc}"] = dem_s / emd_s
    print(
        f"N={n} eta={eta}: t={t_end:.3g} s, eMD* {emd_s:.3g} s ({row['emd_collisions_per_second'] / 1e6:.3f} M coll/s, "
        f"{row['emd_rate_relative_to_hard_spheres']:.2f} x hard spheres), DEM50 {row['dem50_seconds']:.3g} s "
        f"(x{row['speedup_vs_dem50']:.0f}), DEM400 {row['dem400_seconds']:.3g} s (x{row['speedup_vs_dem400']:.0f})"
    )
    return row


def alternate(n: int, eta: float, rounds: int) -> dict:
    """eMD* and hard spheres from the same state in this process, alternating chunks (``--alternate``)."""
    state = gas(n, eta)
    sims = {"emd": edmd.Simulation(state, collision=EMDStar(contact_law())), "hard_spheres": edmd.Simulation(state)}
    for sim in sims.values():
        sim.run(max_events=20 * n)
    rates = {name: [] for name in sims}
    for r in range(rounds):
        for name in sorted(sims, reverse=r % 2 == 1):
            sim = sims[name]
            c0, t0 = sim.collisions, time.process_time()
            sim.run(max_events=30 * n)
            rates[name].append((sim.collisions - c0) / (time.process_time() - t0))
    ratios = [e / h for e, h in zip(rates["emd"], rates["hard_spheres"])]
    row = {"n": n, "eta": eta, "rounds": rounds, **{f"{name}_rates": v for name, v in rates.items()}}
    row.update(ratio_median=statistics.median(ratios), ratio_min=min(ratios), ratio_max=max(ratios))
    print(
        f"N={n} eta={eta}: eMD* {max(rates['emd']) / 1e6:.3f} / {statistics.median(rates['emd']) / 1e6:.3f}, hard spheres "
        f"{max(rates['hard_spheres']) / 1e6:.3f} / {statistics.median(rates['hard_spheres']) / 1e6:.3f} M coll/s (best / median); "
        f"eMD* / hard spheres per round {row['ratio_median']:.3f} ({row['ratio_min']:.3f}-{row['ratio_max']:.3f})"
    )
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=10_000)
    parser.add_argument("--eta", type=float, nargs="+", default=[0.01, 0.05, 0.1])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--friction", type=float, default=None, metavar="MU", help="Hertz-Mindlin friction with this coefficient")
    parser.add_argument("--friction-table", action="store_true", help="frictional contacts from the hard-limit table (docs/physics.md 4.12)")
    parser.add_argument("--young", type=float, default=1e8, help="Young's modulus in Pa (A scaled to keep e_n(v))")
    parser.add_argument("--alternate", type=int, default=0, metavar="K", help="only eMD* / hard spheres: K rounds of alternating chunks in one process")
    parser.add_argument("--out", default="benchmarks/results/emdstar.json")
    args = parser.parse_args()
    if args.alternate:
        write_results(args.out, args, [alternate(args.n, eta, args.alternate) for eta in args.eta])
        return
    if args.friction_table and args.friction is None:
        parser.error("--friction-table needs --friction MU")
    friction = None if args.friction is None else edmd.Friction(mu=args.friction, law="mindlin")
    results = [bench(args.n, eta, args.repeats, friction, args.friction_table, args.young) for eta in args.eta]
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
