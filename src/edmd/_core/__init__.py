"""The compiled core: plain ``@njit`` functions over arrays (see ARCHITECTURE.md).

Numba's on-disk cache (``cache=True``) keys a function on its *own* source file, but a compiled
function carries the code of the helpers it inlines or calls from other modules: a change to
``collide.py`` alone would leave a stale compiled ``run_events`` behind. Before anything is
compiled, this package therefore fingerprints each module together with every core module it
imports (directly or not) and clears the cache files of exactly the modules whose fingerprint
changed: an edit to ``collide.py`` recompiles the collision rules and the loop, not the queue,
the cells or the two-body solver.
"""

import ast
import hashlib
import json
from pathlib import Path

_STAMP = "edmd-core-sources.json"


def _core_imports(source: str) -> set[str]:
    """Names of the sibling core modules that ``source`` imports (``from .x import`` / ``from . import x``)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            found.update([node.module.split(".")[0]] if node.module else (a.name for a in node.names))
    return found


def fingerprints(sources: dict[str, str]) -> dict[str, str]:
    """Per module, a hash of its source and of the sources of every core module it depends on.

    Example:
        >>> f = fingerprints({"a": "from .b import x", "b": "x = 1", "c": "y = 2"})
        >>> f["a"] == fingerprints({"a": "from .b import x", "b": "x = 2", "c": "y = 2"})["a"]
        False
        >>> f["c"] == fingerprints({"a": "from .b import x", "b": "x = 2", "c": "y = 2"})["c"]
        True
    """
    direct = {name: _core_imports(src) & sources.keys() for name, src in sources.items()}
    prints = {}
    for name in sources:
        seen, todo = {name}, [name]
        while todo:
            for dep in direct[todo.pop()] - seen:
                seen.add(dep)
                todo.append(dep)
        digest = hashlib.sha256()
        for dep in sorted(seen):
            digest.update(dep.encode() + b"\0" + sources[dep].encode() + b"\0")
        prints[name] = digest.hexdigest()
    return prints


def guard_cache(package: Path):
    """Delete the Numba cache files (``__pycache__/<module>.*.nb[ic]``) of the modules of
    ``package`` whose fingerprint (:func:`fingerprints`) changed since the last call."""
    sources = {src.stem: src.read_text() for src in sorted(package.glob("*.py"))}
    now = fingerprints(sources)
    stamp = package / "__pycache__" / _STAMP
    try:
        try:
            before = json.loads(stamp.read_text())
        except (OSError, ValueError):
            before = {}
        if before == now:
            return
        stamp.parent.mkdir(exist_ok=True)
        for name, digest in now.items():
            if before.get(name) != digest:
                for stale in stamp.parent.glob(f"{name}.*.nb[ic]"):
                    stale.unlink(missing_ok=True)
        stamp.write_text(json.dumps(now, indent=0, sort_keys=True))
    except OSError:  # read-only install: Numba then uses its own cache directory, keyed the same way
        pass


guard_cache(Path(__file__).resolve().parent)
