"""The compiled core: plain ``@njit`` functions over arrays (see ARCHITECTURE.md).

Numba's on-disk cache (``cache=True``) keys a function on its *own* source file, but the event
loop inlines helpers from several modules: a change to ``collide.py`` alone would leave a stale
compiled ``run_events`` behind. Before anything is compiled, this package therefore hashes all
of its sources and clears every cache file of the core when the hash changed.
"""

import hashlib
from pathlib import Path


def _guard_cache():
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for src in sorted(here.glob("*.py")):
        digest.update(src.name.encode())
        digest.update(src.read_bytes())
    stamp = here / "__pycache__" / "edmd-core-sources.sha256"
    try:
        if stamp.exists() and stamp.read_text() == digest.hexdigest():
            return
        stamp.parent.mkdir(exist_ok=True)
        for stale in stamp.parent.glob("*.nb[ic]"):
            stale.unlink(missing_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:  # read-only install: Numba then uses its own cache directory, keyed the same way
        pass


_guard_cache()
