"""Cost of one frictional two-body solve (docs/physics.md §4.11): the compiled integration alone
and the whole lab-frame call, over random collisions (spins, stick/slip switches), per law and
tolerance. The issue's budget for a direct solve per contact is 50 us.

Usage::

    python benchmarks/bench_friction_solver.py --collisions 200 --out benchmarks/results/friction_solver.json
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from bench_hard_spheres import write_results

import edmd.physics.twobody as tb
from edmd._core import twobody_friction as tf
from edmd.physics.contact import Hertz, LinearDashpot
from edmd.physics.friction import Friction

CASES = {
    "dashpot + linear": (LinearDashpot.from_restitution(0.9, k=1e5, mass=1.0), Friction(mu=0.3, stiffness=2e5 / 7, damping=0.5)),
    "hertz + mindlin": (Hertz(young=1e7, poisson=0.3, A=1e-5), Friction(mu=0.3, law="mindlin")),
    "hertz + linear": (Hertz(young=1e7, poisson=0.3, A=1e-5), Friction(mu=0.3, stiffness=1e5, damping=0.5)),
}


def collisions(n: int, seed: int = 1):
    """Equal unit spheres touching along x, random approach (normal speed 0.5-1.5), tangential velocity and spins."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        v = rng.normal(size=3)
        v[0] = rng.uniform(0.5, 1.5)
        yield [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], v, np.zeros(3), rng.normal(size=3), rng.normal(size=3)


def bench(contact, friction, rtol: float, n: int) -> dict:
    """Best of 5 passes of the compiled map (frictional_update: frame, solve, lab frame) over ``n``
    collisions, and the whole Python call (collide_frictional: checks, arrays, result object)."""
    cases = list(collisions(n))
    t0 = time.perf_counter()
    switches = 0
    for x1, x2, v1, v2, w1, w2 in cases:
        switches += tb.collide_frictional(contact, friction, x1, x2, v1, v2, w1, w2, 1.0, 1.0, 0.5, 0.5, rtol=rtol).switches
    whole = (time.perf_counter() - t0) / n
    ca, cb = contact.constants()
    law, kt, xt, mu = friction.constants(contact)
    inertia = 0.4 * 0.25
    arrays = [tuple(np.asarray(a, float) for a in case) for case in cases]
    F, out = np.zeros((tf.SCRATCH_ROWS, tf.N_STATE)), np.zeros((7, 3))
    best = math.inf
    steps = 0
    for _ in range(5):
        t0 = time.perf_counter()
        for x1, x2, v1, v2, w1, w2 in arrays:
            tf.frictional_update(contact.code, ca, cb, law, kt, xt, mu, 1.0, 1.0, 0.5, 0.5, inertia, inertia, x1, x2, v1, v2, w1, w2, rtol, F, out)
            steps += int(F[tf.ROW_PRM, tf.INFO_AT + tf.I_STEPS])
        best = min(best, (time.perf_counter() - t0) / n)
    return {"rtol": rtol, "core_us": best * 1e6, "call_us": whole * 1e6, "switches_per_contact": switches / n, "steps_per_contact": steps / (5 * n)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--collisions", type=int, default=200)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    results = []
    for name, (contact, friction) in CASES.items():
        bench(contact, friction, 1e-8, 5)  # compile
        for rtol in (1e-6, 1e-8, 1e-10):
            r = bench(contact, friction, rtol, args.collisions)
            r["case"] = name
            results.append(r)
            print(
                f"{name:18s} rtol {rtol:.0e}: core {r['core_us']:7.1f} us, whole call {r['call_us']:7.1f} us, "
                f"{r['steps_per_contact']:.0f} steps, {r['switches_per_contact']:.2f} switches per contact"
            )
    if args.out:
        write_results(args.out, args, results)


if __name__ == "__main__":
    main()
