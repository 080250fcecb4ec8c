"""Where the event loop spends its time: ``perf`` samples of a benchmark case, by compiled function.

Numba's code has no symbols for ``perf``: this script compiles the core afresh in its own process
(an empty, temporary Numba cache), writes ``/tmp/perf-<pid>.map`` (each compiled function's
address and size, from its object code), then samples the timed part of a case of
:mod:`bench_paired` with ``perf record`` and prints the functions' shares. ``--annotate NAME``
also prints the hottest instructions of the function whose name contains NAME, disassembled
from its loaded code (``objdump``): a sample is credited to the instruction after the one that
stalls (a load that missed, a division); ``--around K`` prints the K instructions before each of
the hottest three, to see what they wait for.

Needs ``perf`` (Linux), ``nm`` and ``objdump`` (binutils) and permission to sample one's own process. Run by hand, one core::

    taskset -c 0 python benchmarks/profile_loop.py --n 10000 --eta 0.01 --neighbours cells
    taskset -c 0 python benchmarks/profile_loop.py --n 10000 --eta 0.05 --neighbours cells --emdstar --annotate relocation_scan
"""

from __future__ import annotations

import os
import tempfile

os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="edmd-profile-")  # before Numba is imported: a fresh compile keeps the object code

import argparse  # noqa: E402
import collections  # noqa: E402
import ctypes  # noqa: E402
import gc  # noqa: E402
import shutil  # noqa: E402
import signal  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

from bench_paired import make_case  # noqa: E402


def compiled_functions() -> dict[int, tuple[int, str]]:
    """``{address: (size, name)}`` of every function Numba compiled in this process."""
    from numba.core.registry import CPUDispatcher

    found = {}
    for obj in gc.get_objects():
        if not isinstance(obj, CPUDispatcher):
            continue
        for cres in obj.overloads.values():
            lib = cres.library
            try:
                code = lib._get_compiled_object()  # (private; only after a compile in this process)
            except Exception:
                continue
            with tempfile.NamedTemporaryFile(suffix=".o") as f:
                f.write(code)
                f.flush()
                table = subprocess.run(["nm", "-S", "--defined-only", f.name], capture_output=True, text=True).stdout
            entry = cres.fndesc.llvm_func_name
            for line in table.splitlines():
                parts = line.split()
                if len(parts) != 4 or parts[2] not in "tT":
                    continue
                size, name = int(parts[1], 16), parts[3]
                address = lib.get_pointer_to_function(name)
                if address and size:
                    readable = f"{obj.py_func.__module__}.{obj.py_func.__qualname__}"
                    found[address] = (size, readable if name == entry else f"{readable} [{'wrapper' if 'cpython' in name else 'cfunc'}]")
    return found


def write_perf_map(functions: dict[int, tuple[int, str]]) -> str:
    path = f"/tmp/perf-{os.getpid()}.map"
    with open(path, "w") as f:
        for address, (size, name) in sorted(functions.items()):
            f.write(f"{address:x} {size:x} {name}\n")
    return path


def annotate(data: str, functions: dict[int, tuple[int, str]], name: str, top: int = 24, around: int = 0) -> None:
    """The hottest instructions of the function whose name contains ``name``, with their samples
    (and the ``around`` instructions before the hottest three: what they wait for)."""
    matches = [(a, s, n) for a, (s, n) in functions.items() if name in n and "[" not in n]
    if not matches:
        print(f"no compiled function named like {name!r}")
        return
    base, size, full = max(matches, key=lambda m: m[1])
    ips = subprocess.run(["perf", "script", "-i", data, "-F", "ip"], capture_output=True, text=True).stdout.split()
    hits = collections.Counter(int(x, 16) for x in ips)
    inside = {a: c for a, c in hits.items() if base <= a < base + size}
    total = sum(inside.values())
    with tempfile.NamedTemporaryFile(suffix=".bin") as f:
        f.write(ctypes.string_at(base, size))
        f.flush()
        asm = subprocess.run(["objdump", "-D", "-b", "binary", "-mi386:x86-64", f"--adjust-vma={base:#x}", f.name], capture_output=True, text=True).stdout
    text = {}
    for line in asm.splitlines():
        head, _, rest = line.partition(":")
        try:
            text[int(head.strip(), 16)] = rest.split("\t")[-1].strip()
        except ValueError:
            continue
    print(f"\n{full}: {total} samples; hottest instructions (samples, address offset, instruction)")
    ranked = sorted(inside.items(), key=lambda x: -x[1])
    for address, count in ranked[:top]:
        print(f"{count:7d} {100 * count / max(total, 1):5.1f} %  +{address - base:#07x}  {text.get(address, '?')}")
    addresses = sorted(text)
    for address, _ in ranked[:3] if around else ():
        k = addresses.index(address) if address in text else 0
        print(f"\nbefore +{address - base:#07x}:")
        for a in addresses[max(k - around, 0) : k + 1]:
            print(f"{inside.get(a, 0):7d}  +{a - base:#07x}  {text[a]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--eta", type=float, default=0.05)
    ap.add_argument("--neighbours", default="cells")
    ap.add_argument("--dim", type=int, default=3)
    ap.add_argument("--walls", action="store_true")
    ap.add_argument("--emdstar", action="store_true")
    ap.add_argument("--replicate", type=int, default=1)
    ap.add_argument("--events", type=float, default=100.0, help="sampled events per particle")
    ap.add_argument("--frequency", type=int, default=4000, help="samples per second")
    ap.add_argument("--annotate", default=None, help="also the hottest instructions of this function (part of its name)")
    ap.add_argument("--around", type=int, default=0, help="with --annotate: this many instructions before each of the hottest three")
    ap.add_argument("--out", default="perf-edmd.data")
    args = ap.parse_args()
    for tool in ("perf", "nm") + (("objdump",) if args.annotate else ()):
        if shutil.which(tool) is None:
            raise SystemExit(f"profile_loop.py needs {tool} (perf: linux-tools; nm, objdump: binutils); it is not installed")
    sim = make_case(args.n, args.eta, args.neighbours, args.walls, args.dim, args.emdstar, args.replicate)
    sim.engine.resync()  # (compiled at the first resync: not while sampling)
    sim.state  # (the snapshot)
    functions = compiled_functions()
    print(f"{len(functions)} compiled functions mapped in {write_perf_map(functions)}")
    perf = subprocess.Popen(["perf", "record", "-q", "-F", str(args.frequency), "-p", str(os.getpid()), "-o", args.out], stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)  # (perf attaching)
    if perf.poll() is not None:  # (it could not attach: kernel.perf_event_paranoid, a container)
        raise SystemExit(f"perf record could not sample this process:\n{perf.stderr.read()}")
    c0, e0, t0 = sim.collisions, sim.events, time.process_time()
    sim.run(max_events=int(args.events * args.n))
    seconds = time.process_time() - t0
    perf.send_signal(signal.SIGINT)
    perf.wait()
    collisions = sim.collisions - c0
    print(f"{collisions / seconds / 1e6:.3f} M collisions/s, {(sim.events - e0) / max(collisions, 1):.2f} events per collision (while sampled)")
    report = subprocess.run(["perf", "report", "-i", args.out, "--stdio", "--no-children", "--sort", "sym", "--percent-limit", "0.5"], capture_output=True, text=True).stdout
    print("\n".join(line for line in report.splitlines() if line.strip() and not line.startswith("#")))
    if args.annotate:
        annotate(args.out, functions, args.annotate, around=args.around)
    sys.stdout.flush()
    os._exit(0)  # (not the interpreter's teardown)


if __name__ == "__main__":
    main()
