"""Peak memory of a hard-sphere run, stage by stage, in bytes per particle above the interpreter.

Each case runs in a fresh process: imports and a small warm-up run (compiles or loads the
core) set the baseline resident memory; then the state is built (``lattice``, ``random``, or ``replicated``: an amorphous packing of
``n / 125`` particles tiled 5 x 5 x 5; Maxwell-Boltzmann velocities), the Simulation made from it (the user's state stays
alive, as in a script), ``--events`` events per particle run, and the engine resynced (as
maintenance does every 200 events per particle). The peak resident set of each
stage comes from the kernel's high-water mark (reset between stages through
``/proc/self/clear_refs``, Linux), so transient copies count; then the outputs of ``edmd run``
fire twice (a thermo row, a trajectory frame, a checkpoint), and last a user takes a copy of the
state (``Simulation.state``; its freed arrays stay in glibc's heap below its ``mmap`` threshold,
which rises to 32 MB: a stage after it would start from that level). A restart from that checkpoint is
measured in a fresh process of its own (``restart``). Also reported: the engine's own arrays per
particle and the wall-clock time of the set-up and of the restart.

Usage::

    python benchmarks/bench_memory.py                                  # N = 1e6 and 1e7, eta = 0.5, lists and cells
    python benchmarks/bench_memory.py --n 1000000 --eta 0.05 --mode cells
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_hard_spheres import engine_bytes, write_results


def _status(field: str) -> float:
    """``VmRSS`` / ``VmHWM`` of this process, bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return float(line.split()[1]) * 1024
    raise RuntimeError(f"no {field} in /proc/self/status")


def _reset_peak() -> None:
    Path("/proc/self/clear_refs").write_text("5")


def measure(n: int, eta: float, mode: str, start: str, events: float, folder: str) -> dict:
    """One case, in this process (call through :func:`run_case`); its outputs go to ``folder``."""
    import gc

    import edmd

    def build(count):
        if start == "lattice":
            s = edmd.lattice(count, eta)
        elif start == "replicated":  # an amorphous packing of count / 125 tiled 5 x 5 x 5
            s = edmd.replicate(edmd.random_packing(count // 125, eta, seed=1), [5, 5, 5])
        else:
            s = edmd.random_packing(count, eta, seed=1)
        return edmd.maxwell_boltzmann(s, 1.0, seed=2)

    warm_state = edmd.replicate(edmd.random_packing(250, eta, seed=1), [2, 2, 2]) if start == "replicated" else build(2000)
    warm = edmd.Simulation(edmd.maxwell_boltzmann(warm_state, 1.0, seed=2), engine={"neighbours": mode})
    warm.run(max_events=20 * 2000)
    del warm
    gc.collect()
    base = _status("VmRSS")
    stages = {}

    def stage(name):
        stages[name] = {"rss": (_status("VmRSS") - base) / n, "peak": (_status("VmHWM") - base) / n}
        _reset_peak()

    _reset_peak()
    t0 = time.perf_counter()
    state = build(n)
    stage("state")
    t1 = time.perf_counter()
    sim = edmd.Simulation(state, engine={"neighbours": mode})
    t2 = time.perf_counter()
    stage("simulation")
    sim.run(max_events=int(events * n))
    stage("run")
    sim.engine.resync()  # (a maintenance resync, every 200 events per particle; each checkpoint makes one)
    stage("resync")
    for obs in _outputs(folder):
        sim.add(obs)  # the outputs of edmd run, due at once
    sim.run(until_time=sim.time + 1.5e-3)  # (two outputs: a trajectory's later frames differ from its first)
    sim.close()
    stage("outputs")
    # a user's copy of the state, last: below glibc's mmap threshold (which rises to 32 MB) its
    # freed arrays stay resident in the C heap, and a stage after it would start from that level
    snap = sim.state
    del snap
    stage("snapshot")
    return {
        "n": n,
        "eta": eta,
        "start": start,
        "neighbours": sim.engine.mode,
        "state_seconds": t1 - t0,
        "simulation_seconds": t2 - t1,
        "baseline_mb": base / 2**20,
        "stages_bytes_per_particle": stages,
        "peak_bytes_per_particle": max(s["peak"] for s in stages.values()),
        "engine_bytes_per_particle": engine_bytes(sim) / n,
    }


def _outputs(folder: str) -> list:
    """The observers of ``edmd run`` (files in ``folder``), due every 1e-3."""
    import edmd

    return [edmd.Thermo(1e-3, path=f"{folder}/thermo.csv"), edmd.Trajectory(f"{folder}/trajectory.gsd", 1e-3), edmd.Checkpoint(f"{folder}/checkpoint.gsd", 1e-3)]


def measure_restart(folder: str, mode: str) -> dict:
    """Peak memory of a restart from the checkpoint of :func:`measure` in ``folder``
    (``Simulation.from_checkpoint`` with its outputs), in this process, above the interpreter
    after a small run and restart of the same kind."""
    import gc

    import edmd

    with tempfile.TemporaryDirectory() as tmp:
        warm = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(2000, 0.3), 1.0, seed=2), engine={"neighbours": mode})
        for obs in _outputs(tmp):
            warm.add(obs)
        warm.run(until_time=2.5e-3)
        warm.close()
        again = edmd.Simulation.from_checkpoint(f"{tmp}/checkpoint.gsd", _outputs(tmp))
        again.run(max_events=2000)
        again.close()
        del warm, again
    gc.collect()
    base = _status("VmRSS")
    _reset_peak()
    t0 = time.perf_counter()
    sim = edmd.Simulation.from_checkpoint(f"{folder}/checkpoint.gsd", _outputs(folder))
    seconds = time.perf_counter() - t0
    return {"peak": (_status("VmHWM") - base) / sim.engine.n, "rss": (_status("VmRSS") - base) / sim.engine.n, "seconds": seconds}


def _in_process(call: str) -> dict:
    code = f"import json, bench_memory as b; print(json.dumps(b.{call}))"
    out = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).parent, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_case(n: int, eta: float, mode: str, start: str, events: float) -> dict:
    """:func:`measure`, then :func:`measure_restart` from its checkpoint, each in a fresh process
    (a clean baseline and high-water mark)."""
    with tempfile.TemporaryDirectory() as folder:
        result = _in_process(f"measure({n}, {eta}, {mode!r}, {start!r}, {events}, {folder!r})")
        restart = _in_process(f"measure_restart({folder!r}, {mode!r})")
    result["stages_bytes_per_particle"]["restart"] = {"rss": restart["rss"], "peak": restart["peak"]}
    result["restart_seconds"] = restart["seconds"]
    result["peak_bytes_per_particle"] = max(s["peak"] for s in result["stages_bytes_per_particle"].values())
    return result


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1_000_000, 10_000_000])
    ap.add_argument("--eta", type=float, nargs="+", default=[0.5])
    ap.add_argument("--mode", nargs="+", default=["list", "cells"], choices=["auto", "list", "cells"])
    ap.add_argument("--start", default="lattice", choices=["lattice", "random", "replicated"], help="replicated: random n / 125, tiled 5 x 5 x 5")
    ap.add_argument("--events", type=float, default=2.0, help="events per particle of the run stage")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results") / "memory.json"))
    args = ap.parse_args(argv)
    results = []
    for n in args.n:
        for eta in args.eta:
            for mode in args.mode:
                r = run_case(n, eta, mode, args.start, args.events)
                results.append(r)
                st = r["stages_bytes_per_particle"]
                print(
                    f"N={n:9d} eta={eta:.2f} [{r['neighbours']:5s}] peak {r['peak_bytes_per_particle']:4.0f} B/particle "
                    f"(state {st['state']['peak']:.0f}, simulation {st['simulation']['peak']:.0f}, run {st['run']['peak']:.0f}, resync {st['resync']['peak']:.0f}, "
                    f"snapshot {st['snapshot']['peak']:.0f}, outputs {st['outputs']['peak']:.0f}, restart {st['restart']['peak']:.0f}); "
                    f"engine {r['engine_bytes_per_particle']:.0f} B/particle; set-up {r['state_seconds']:.1f} + "
                    f"{r['simulation_seconds']:.1f} s; restart {r['restart_seconds']:.1f} s",
                    flush=True,
                )
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
