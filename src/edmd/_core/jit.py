"""Compilation policy of the core: every function is cached; helpers of the event loop are inlined.

* ``error_model="numpy"`` drops Python's zero-division checks: the predictors never divide by
  zero by construction, and IEEE results are what the physics wants.
* ``_nrt=False`` compiles without Numba's reference counting. Array arguments are then plain
  views and no ``NRT_incref``/``NRT_decref`` calls are emitted; the pruning pass leaves many of
  them in code with branches, and without them the event calendar runs 4.7x faster (183 -> 39
  ns per pop+update, measured). Such functions cannot allocate arrays: scratch buffers come
  from Python. Functions that allocate (snapshots, initial packings) use :data:`jit_alloc`.
* Two ways of inlining, chosen by what they cost to compile (``benchmarks/bench_compile.py``):

  - :data:`leaf` (``forceinline``): the function is typed and compiled **once** per signature
    and LLVM inlines its machine-level body into every caller. Numba's own IR inlining re-runs
    the callee's front end (bytecode, SSA, typing) at every call site, nested helpers included:
    with every helper IR-inlined, the loop spent 17 of its 43 compile seconds inlining and 7
    in SSA reconstruction of the grown body. Scalar helpers and the queue, cell and list
    internals are leaves.
  - :data:`hot` (``inline="always"``, Numba IR level): kept for the loop-level pieces whose
    branches depend on the loop variant's feature flags (``predict_aux``, ``collide_pair``,
    ...). Inlined in the IR, Numba prunes those branches before typing, so a plain run never
    types wall, spin or eMD* code (see :func:`.loop.loop_variant`).
"""

from numba import njit

def _no_refcount_option() -> dict:
    """``{"_nrt": False}`` if this Numba has the (private) option, else ``{}`` (reference counting kept).

    Decorating is lazy (options are checked at the first compile), so the probe asks the CPU
    target's option table instead of decorating a dummy function.
    """
    try:
        from numba.core.cpu import CPUTargetOptions
    except ImportError:  # pragma: no cover - depends on the Numba version
        return {}
    return {"_nrt": False} if hasattr(CPUTargetOptions, "_nrt") else {}


_NO_RC = _no_refcount_option()

jit = njit(cache=True, error_model="numpy", **_NO_RC)
hot = njit(cache=True, inline="always", error_model="numpy", **_NO_RC)
leaf = njit(cache=True, forceinline=True, error_model="numpy", **_NO_RC)
jit_alloc = njit(cache=True, error_model="numpy")


def in_disk_cache(dispatcher, arg: tuple[int, object] | None = None) -> bool:
    """Whether Numba's on-disk cache holds compiled code of ``dispatcher`` (any signature, or
    one whose argument ``arg[0]`` has the type of the value ``arg[1]``).

    Closure values are part of the cache key, so for a loop variant this tells whether that
    feature set was compiled before; ``arg`` tells apart the signatures of one variant (the
    geometry of a vibrating wall is a longer tuple). ``False`` whenever it cannot tell (a Numba
    without this private cache interface, an unreadable cache): the caller then expects to compile.
    """
    try:
        cache = dispatcher._cache
        tail = cache._index_key(None, dispatcher.targetctx.codegen())[1:]
        keys = [key for key in cache._cache_file._load_index() if key[1:] == tail]
        if arg is not None:
            wanted = dispatcher.typeof_pyval(arg[1])
            keys = [key for key in keys if key[0][arg[0]] == wanted]
        return bool(keys)
    except Exception:  # pragma: no cover - depends on Numba's private cache layout
        return False
