"""How many processes a default pool should start: the cores this process may actually use.

``os.cpu_count()`` counts the host's cores. A batch job (SLURM, a ``taskset``) is usually given
a few of them by CPU affinity, and a container by a CPU quota (cgroup v2 ``cpu.max``); a pool of
one worker per host core then oversubscribes the cores it was given, and every worker pays the
compile of the loop variants it meets.
"""

from __future__ import annotations

import os

#: cgroup v2 CPU quota of this process's container: ``"<quota> <period>"`` or ``"max <period>"``
CGROUP_CPU_MAX = "/sys/fs/cgroup/cpu.max"


def usable_cores() -> int:
    """The cores this process may run on: its CPU affinity, capped by a cgroup CPU quota.

    .. math::

        n = \\min\\left(|\\text{affinity}|,\\ \\max\\left(1, \\lfloor \\text{quota} / \\text{period} \\rfloor\\right)\\right)

    Falls back to ``os.cpu_count()`` where the platform has no affinity (macOS, Windows); a
    missing or unreadable quota file means no quota. Always at least 1.

    Example:
        >>> from edmd.cores import usable_cores
        >>> 1 <= usable_cores() <= (os.cpu_count() or 1)
        True
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    try:
        with open(CGROUP_CPU_MAX) as f:
            quota, period = f.read().split()
        if quota != "max":
            cores = min(cores, max(1, int(quota) // int(period)))
    except (OSError, ValueError):
        pass
    return max(1, cores)
