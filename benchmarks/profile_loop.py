"""Where the event loop spends its time: ``perf`` samples of a benchmark case, by compiled function.

Numba's code has no symbols for ``perf``: this script compiles the core afresh in its own process
(an empty, temporary Numba cache), writes ``/tmp/perf-<pid>.map`` (each compiled function's
address and size, from its object code), then samples the timed part of a case of
:mod:`bench_paired` with ``perf record`` and prints the functions' shares. ``--annotate NAME``
also prints the hottest instructions of the function whose name contains NAME, disassembled
from its loaded code (``objdump``): a sample is credited to the instruction after the one that
stalls (a load that missed, a division); ``--around K`` prints the K instructions before each of
the hottest three, to see what they wait for.

Numba inlines the loop's helpers into one function, so by function the dilute gas is 84 %
``run_events``: ``--lines`` compiles with debug line tables (``NUMBA_DEBUGINFO``; bounds checks
and extended lifetimes, which it would also switch on, stay off: the machine code is the
release one) and credits each sample to its source line, innermost inlined helper first, with
the loop's line that inlined it (``addr2line -i``), plus the shares per source file.

Needs ``perf`` (Linux), ``nm``, ``objdump`` and ``addr2line`` (binutils) and permission to sample one's own process. Run by hand, one core::

    taskset -c 0 python benchmarks/profile_loop.py --n 10000 --eta 0.01 --neighbours cells
    taskset -c 0 python benchmarks/profile_loop.py --n 10000 --eta 0.05 --neighbours cells --emdstar --annotate relocation_scan
    taskset -c 0 python benchmarks/profile_loop.py --n 10000 --eta 0.01 --neighbours cells --lines run_events
"""

from __future__ import annotations

import os
import sys
import tempfile

os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="edmd-profile-")  # before Numba is imported: a fresh compile keeps the object code
if "--lines" in sys.argv:  # (read before Numba is imported, like the cache folder)
    os.environ["NUMBA_DEBUGINFO"] = "1"

import argparse  # noqa: E402
import collections  # noqa: E402
import ctypes  # noqa: E402
import gc  # noqa: E402
import linecache  # noqa: E402
import shutil  # noqa: E402
import signal  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402

from bench_paired import make_case  # noqa: E402


def release_code_with_line_tables() -> None:
    """Keep the release machine code under ``NUMBA_DEBUGINFO``: Numba's debug info also switches
    on bounds checks and extended variable lifetimes, which change the code; both stay off.
    (Helpers made by ``@overload`` have no source file; Numba's warnings about that are muted.)

    Numba writes every line of a function under the function's own file, also the lines of the
    helpers it inlined in its IR (``inline="always"``), which keep their own files' line
    numbers: each location is put in a lexical block of the file of the instruction's own
    source location instead."""
    import os
    import warnings

    from numba.core import cpu, debuginfo, errors, lowering

    warnings.simplefilter("ignore", errors.NumbaDebugInfoWarning)
    lower_inst = lowering.Lower.lower_inst

    def lower_inst_in_its_file(self, inst):
        self.debuginfo.source_now = getattr(self.loc, "filename", None)
        return lower_inst(self, inst)

    def location_in_its_file(self, line):
        path = getattr(self, "source_now", None)
        scope = self.subprograms[-1]
        if path and os.path.isabs(path) and os.path.abspath(path) != self.filepath:
            file = self.module.add_debug_info("DIFile", {"directory": os.path.dirname(path), "filename": os.path.basename(path)})
            scope = self.module.add_debug_info("DILexicalBlockFile", {"scope": scope, "file": file, "discriminator": 0})
        return self.module.add_debug_info("DILocation", {"line": line, "column": 1, "scope": scope})

    lowering.Lower.lower_inst = lower_inst_in_its_file
    debuginfo.DIBuilder._di_location = location_in_its_file

    finalize = cpu.CPUTargetOptions.finalize

    def release(self, flags, options):
        flags.boundscheck = False
        flags.dbg_extend_lifetimes = False
        finalize(self, flags, options)

    cpu.CPUTargetOptions.finalize = release


def compiled_functions() -> dict[int, tuple[int, str, bytes, str]]:
    """``{address: (size, name, object code, symbol)}`` of every function Numba compiled in this process."""
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
                    found[address] = (size, readable if name == entry else f"{readable} [{'wrapper' if 'cpython' in name else 'cfunc'}]", code, name)
    return found


def write_perf_map(functions: dict[int, tuple[int, str, bytes, str]]) -> str:
    path = f"/tmp/perf-{os.getpid()}.map"
    with open(path, "w") as f:
        for address, (size, name, _code, _symbol) in sorted(functions.items()):
            f.write(f"{address:x} {size:x} {name}\n")
    return path


def _named(functions, name):
    """``(address, size, name)`` of the largest compiled function whose name contains ``name`` (``None``: none)."""
    matches = [(a, f[0], f[1]) for a, f in functions.items() if name in f[1] and "[" not in f[1]]
    if not matches:
        print(f"no compiled function named like {name!r}")
        return None
    return max(matches, key=lambda m: m[1])


def _samples_in(data: str, base: int, size: int) -> collections.Counter:
    """Samples per instruction address inside ``[base, base + size)``."""
    ips = subprocess.run(["perf", "script", "-i", data, "-F", "ip"], capture_output=True, text=True).stdout.split()
    return collections.Counter(a for a in (int(x, 16) for x in ips) if base <= a < base + size)


def annotate(data: str, functions: dict[int, tuple[int, str, bytes, str]], name: str, top: int = 24, around: int = 0) -> None:
    """The hottest instructions of the function whose name contains ``name``, with their samples
    (and the ``around`` instructions before the hottest three: what they wait for)."""
    found = _named(functions, name)
    if found is None:
        return
    base, size, full = found
    inside = _samples_in(data, base, size)
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


def by_line(data: str, functions: dict[int, tuple[int, str, bytes, str]], name: str, top: int = 40) -> None:
    """The samples of the function whose name contains ``name`` by source line (``--lines``): the
    innermost inlined helper's line, then the line of the function itself that inlined it, from
    the object code's line tables (``addr2line -i``); then the shares per source file."""
    found = _named(functions, name)
    if found is None:
        return
    base, size, full = found
    _size, _name, code, symbol = functions[base]
    inside = _samples_in(data, base, size)
    total = max(sum(inside.values()), 1)
    with tempfile.NamedTemporaryFile(suffix=".o") as f:
        f.write(code)
        f.flush()
        start = next(int(p[0], 16) for p in (line.split() for line in subprocess.run(["nm", "--defined-only", f.name], capture_output=True, text=True).stdout.splitlines()) if p[-1] == symbol)
        addresses = sorted(inside)
        query = "".join(f"{start + a - base:#x}\n" for a in addresses)
        out = subprocess.run(["addr2line", "-a", "-i", "-e", f.name], input=query, capture_output=True, text=True).stdout.splitlines()
    chains, current = {}, None
    for line in out:
        if line.startswith("0x"):
            current = int(line, 16) - start + base
            chains[current] = []
        elif current is not None and ":" in line and not line.startswith("??"):
            path, _, number = line.partition(" ")[0].rpartition(":")
            if number.isdigit():
                chains[current].append((path, int(number)))
    per_line = collections.Counter()
    per_file = collections.Counter()
    for address, count in inside.items():
        chain = chains.get(address) or [("?", 0)]
        inner, outer = chain[0], chain[-1]
        per_line[(inner, outer if outer != inner else None)] += count
        per_file[os.path.basename(inner[0])] += count
    print(f"\n{full}: {total} samples by source line (innermost helper <- the line that inlined it)")
    for (inner, outer), count in per_line.most_common(top):
        text = linecache.getline(inner[0], inner[1]).strip()
        where = f"{os.path.basename(inner[0])}:{inner[1]}" + (f" <- {os.path.basename(outer[0])}:{outer[1]}" if outer else "")
        print(f"{count:7d} {100 * count / total:5.1f} %  {where:34s} {text[:90]}")
    print("by file: " + ", ".join(f"{k} {100 * v / total:.1f} %" for k, v in per_file.most_common()))


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
    ap.add_argument("--lines", default=None, metavar="NAME", help="the samples of this function (part of its name) by source line, compiled with line tables")
    ap.add_argument("--out", default="perf-edmd.data")
    args = ap.parse_args()
    for tool in ("perf", "nm") + (("objdump",) if args.annotate else ()) + (("addr2line",) if args.lines else ()):
        if shutil.which(tool) is None:
            raise SystemExit(f"profile_loop.py needs {tool} (perf: linux-tools; nm, objdump: binutils); it is not installed")
    if args.lines:
        release_code_with_line_tables()
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
    if args.lines:
        by_line(args.out, functions, args.lines)
    sys.stdout.flush()
    os._exit(0)  # (not the interpreter's teardown)


if __name__ == "__main__":
    main()
