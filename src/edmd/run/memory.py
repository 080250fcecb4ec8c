"""Memory of a run: an estimate before anything is allocated, a guard, and a bounded cell grid.

A run's peak memory is dominated by per-particle arrays (the State, the engine's rows,
neighbour lists, the calendar, a snapshot for an observer): about :data:`BYTES_PER_PARTICLE`
(measured peak resident memory of hard-sphere runs, N = 1e6 and 1e7, the user's state alive:
215-221 bytes per particle in cells mode, 305-325 with lists; 234-245 and 335-350 while the
outputs of ``edmd run`` are written, a thermo row, a trajectory frame and a checkpoint; a user's
copy of the state adds 72; rough, TC or eMD* runs carry their own arrays;
``benchmarks/bench_memory.py``). The cell
grid would add 4 bytes per cell and grows with the box *volume*: at packing fraction 1e-6 a grid
of one-diameter cells for 1e4 spheres has 5e9 cells. :func:`grid_shape` therefore coarsens the
cells of dilute systems so that there are at most :data:`MAX_CELLS_PER_PARTICLE` cells per
particle (or :data:`MIN_CELL_CAP` in all): cells larger than the contact distance are always correct, and at such densities a
cell holds a few particles at most.
"""

from __future__ import annotations

import math
import os
import re

import numpy as np

from .._core.cells import grid_shape as _grid_shape

#: peak resident bytes per particle of a run (set-up, event loop, outputs; measured, with a margin
#: for rough, TC and eMD* arrays)
BYTES_PER_PARTICLE = 600
#: bytes of one grid cell (the head of its linked list, int32)
BYTES_PER_CELL = 4
#: the cell grid never has more cells than this per particle (dilute systems get larger cells)...
MAX_CELLS_PER_PARTICLE = 16
#: ...unless it is this small anyway (256 KB): small systems keep one-diameter cells
MIN_CELL_CAP = 2**16


class MemoryLimitError(ValueError):
    """A run would need more memory than the machine has (or than ``max_memory`` allows)."""


def grid_shape(box, periodic, min_cell: float, n: int, dim: int) -> np.ndarray:
    """Cells per axis: edges of at least ``min_cell``, at most :func:`max_cells` of them; one cell
    on the axes beyond ``dim`` (a 2D box's third length is a placeholder: cut into cells, it
    multiplied every walk's cells and, in SI units, took the cell cap from the plane).

    Example:
        >>> box = np.array([10000.0, 10000.0, 10000.0])
        >>> grid_shape(box, [True] * 3, 1.0, 10000, 3).tolist()   # not 1e12 cells for 1e4 particles
        [54, 54, 54]
        >>> grid_shape(np.array([0.2, 0.2, 1.0]), [True, True, False], 0.002, 10000, 2).tolist()   # disks in SI units
        [100, 100, 1]
    """
    box = np.where(np.arange(3) < dim, np.asarray(box, float), np.inf)
    nc = _grid_shape(box, periodic, min_cell)
    cap = max_cells(n)
    while int(np.prod(nc)) > cap:
        split = nc > 1
        shrink = (int(np.prod(nc)) / cap) ** (1.0 / int(np.count_nonzero(split)))
        edge = float(np.min(np.asarray(box, float)[split] / nc[split])) * max(shrink, 1.0 + 1e-9)
        min_cell = max(min_cell, edge)
        nc = _grid_shape(box, periodic, min_cell)
    return nc


def max_cells(n: int) -> int:
    """The most cells a grid for ``n`` particles may have.

    Example:
        >>> max_cells(100), max_cells(10**6)
        (65536, 16000000)
    """
    return max(MAX_CELLS_PER_PARTICLE * int(n), MIN_CELL_CAP)


def estimate_bytes(n: int) -> int:
    """Peak memory of a run of ``n`` particles (bytes), before anything is allocated.

    Example:
        >>> estimate_bytes(10**6) / 1e9
        0.664
    """
    return int(n) * (BYTES_PER_PARTICLE + MAX_CELLS_PER_PARTICLE * BYTES_PER_CELL)


def available_bytes() -> int:
    """Memory available to a new allocation now (``MemAvailable`` on Linux, else physical memory)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - exotic platforms
        return 2**63 - 1


_UNITS = {"": 1, "b": 1, "k": 10**3, "kb": 10**3, "m": 10**6, "mb": 10**6, "g": 10**9, "gb": 10**9, "t": 10**12, "tb": 10**12}
_UNITS.update({"kib": 2**10, "mib": 2**20, "gib": 2**30, "tib": 2**40})


def parse_bytes(text: str | int | float) -> int:
    """A memory size: a number of bytes or ``"8G"``, ``"500 MB"``, ``"2GiB"``.

    Example:
        >>> parse_bytes("8G"), parse_bytes("512 MiB"), parse_bytes(1000)
        (8000000000, 536870912, 1000)
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value, unit = float(text), ""
    else:
        match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", str(text))
        if match is None or match.group(2).lower() not in _UNITS:
            raise MemoryLimitError(f"max_memory: {text!r} is not a memory size (e.g. 8G, 500MB, 2GiB)")
        value, unit = float(match.group(1)), match.group(2).lower()
    size = value * _UNITS[unit]
    if not (size > 0 and math.isfinite(size)):
        raise MemoryLimitError(f"max_memory must be a positive size, got {text!r}")
    return int(size)


def _gb(n: float) -> str:
    return f"{n / 1e9:.3g} GB"


def check_memory(n: int, max_memory: str | int | None = None):
    """Refuse a run of ``n`` particles whose estimated memory exceeds ``max_memory`` (default:
    the memory available now), with a message naming the cause and the remedy.

    Example:
        >>> check_memory(1000)                       # fine
        >>> check_memory(10**9, max_memory="8G")
        Traceback (most recent call last):
        ...
        edmd.run.memory.MemoryLimitError: a run of N = 1e+09 particles needs about 664 GB (664 bytes per particle), more than the limit of 8 GB (--max-memory / max_memory): use fewer particles, or raise the limit if the machine has the memory
    """
    need = estimate_bytes(n)
    if max_memory is None:
        limit, what = available_bytes(), "memory available on this machine"
    else:
        limit, what = parse_bytes(max_memory), "limit"
    if need > limit:
        raise MemoryLimitError(
            f"a run of N = {n:.3g} particles needs about {_gb(need)} ({need // max(int(n), 1)} bytes per particle), "
            f"more than the {what} of {_gb(limit)} (--max-memory / max_memory): use fewer particles, "
            "or raise the limit if the machine has the memory"
        )
