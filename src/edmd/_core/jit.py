"""Compilation policy of the core: every function is cached; hot helpers are inlined.

``error_model="numpy"`` drops Python's zero-division checks (the predictors never divide by
zero by construction, and IEEE results are what the physics wants); inlining at the Numba IR
level avoids the array reference counting of calls (measured +24 % in ARCHITECTURE.md).
"""

from numba import njit

jit = njit(cache=True, error_model="numpy")
hot = njit(cache=True, inline="always", error_model="numpy")
