"""The compiled core: plain ``@njit`` functions over arrays (see ARCHITECTURE.md).

Numba's on-disk cache (``cache=True``) keys a function on its *own* source file, but a compiled
function carries the code of the helpers it inlines or calls from other modules: a change to
``collide.py`` alone would leave a stale compiled ``run_events`` behind. Before anything is
compiled, this package therefore fingerprints each module together with every core module it
imports (directly or not) and clears the cache files of exactly the modules whose fingerprint
changed, in the folder Numba caches them in (next to the sources, ``NUMBA_CACHE_DIR``, or the
user-wide folder): an edit to ``collide.py`` recompiles the collision rules and the loop, not the
queue, the cells or the two-body solver.
"""

import ast
import hashlib
import json
import os
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


def cache_folder(package: Path) -> Path:
    """The folder Numba keeps this package's cache in, chosen as Numba's locators choose it:
    ``NUMBA_CACHE_DIR``'s folder for these sources when that is set, else ``__pycache__`` next to
    them when it can be written, else the user-wide cache folder (read-only installs)."""
    in_tree = package / "__pycache__"
    try:
        from numba.core import caching, config
        from numba.misc.appdirs import AppDirs
    except ImportError:  # pragma: no cover - depends on Numba's private layout
        return in_tree
    source = str(package / "loop.py")
    if config.CACHE_DIR:
        return Path(config.CACHE_DIR) / caching.UserProvidedCacheLocator.get_suitable_cache_subpath(source)
    try:
        in_tree.mkdir(exist_ok=True)
        if os.access(in_tree, os.W_OK):
            return in_tree
    except OSError:
        pass
    user = Path(AppDirs(appname="numba", appauthor=False).user_cache_dir)
    return user / caching.UserWideCacheLocator.get_suitable_cache_subpath(source)


def guard_cache(package: Path, folder: Path | None = None):
    """Delete the Numba cache files (``<module>.*.nb[ic]``) of the modules of ``package`` whose
    fingerprint (:func:`fingerprints`) changed since the last call, in its cache folder.

    The folder is created with the fingerprints when it does not exist yet, so that the cache
    Numba then writes into it is known to be current at the next import.
    """
    sources = {src.stem: src.read_text() for src in sorted(package.glob("*.py"))}
    now = fingerprints(sources)
    folder = cache_folder(package) if folder is None else folder
    stamp = folder / _STAMP
    try:
        before = json.loads(stamp.read_text())
    except (OSError, ValueError):
        before = {}
    if before == now:
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name, digest in now.items():
            if before.get(name) != digest:
                for stale in folder.glob(f"{name}.*.nb[ic]"):
                    stale.unlink(missing_ok=True)
        fresh = stamp.with_name(f"{_STAMP}.{os.getpid()}")  # (whole or not at all: processes importing edmd together read it)
        fresh.write_text(json.dumps(now, indent=0, sort_keys=True))
        os.replace(fresh, stamp)
    except OSError:  # a folder we cannot write: Numba cannot cache there either
        pass


guard_cache(Path(__file__).resolve().parent)
