"""Loop variants: a run compiles only the code of its features (core v2, compile-time specialisation)."""

import pytest
from numba.core import ir, types
from numba.core.analysis import dead_branch_prune
from numba.core.compiler import run_frontend

import edmd
from edmd import collide
from edmd._core import layout as L
from edmd._core.jit import in_disk_cache
from edmd._core.loop import loop_variant

PLAIN = (False, False, False, L.NORMAL_CONST)
FEATURE_CODE = {"_debug_check", "_emd_contact", "_finish_contact", "collide_wall", "execute_b", "is_pending"}


def referenced_globals(func) -> set[str]:
    """Global and closure names the function's IR still uses after Numba's dead-branch pruning."""
    fir = run_frontend(func)
    dead_branch_prune(fir, (types.pyobject,) * func.__code__.co_argcount)
    names = set()
    for block in fir.blocks.values():
        for inst in block.body:
            if isinstance(inst, ir.Assign) and isinstance(inst.value, (ir.Global, ir.FreeVar)):
                names.add(inst.value.name)
    return names


def test_plain_hard_spheres_compile_no_feature_code():
    names = referenced_globals(loop_variant(*PLAIN).run_events.py_func)
    assert {"collide_pair", "predict_pair", "predict_aux", "queue_top", "rebuild_list", "_cross_cell"} <= names
    assert not names & FEATURE_CODE


@pytest.mark.parametrize(
    "features, code",
    [
        ((True, False, False, L.NORMAL_CONST), {"collide_wall"}),
        ((False, False, False, L.NORMAL_CONST, True), {"_debug_check"}),
        ((False, True, False, L.NORMAL_SOFT), {"_emd_contact", "execute_b"}),
        ((True, True, False, L.NORMAL_SOFT), {"collide_wall", "_emd_contact", "_finish_contact", "execute_b", "is_pending"}),
    ],
)
def test_each_feature_brings_its_own_code(features, code):
    assert referenced_globals(loop_variant(*features).run_events.py_func) & FEATURE_CODE == code


def test_variants_are_memoised_and_distinct():
    assert loop_variant(*PLAIN) is loop_variant(*PLAIN)
    assert loop_variant(*PLAIN) is not loop_variant(True, *PLAIN[1:])


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize(
    "rule, walls, neighbours, key",
    [
        (None, False, "list", PLAIN),
        (collide.Inelastic(0.9), True, "cells", (True, False, False, L.NORMAL_CONST)),
        (collide.Rough(e_n=0.9, beta=0.3), False, "list", (False, False, True, L.NORMAL_CONST)),
    ],
)
def test_engine_picks_the_variant_of_its_features(dim, rule, walls, neighbours, key):
    periodic = [True] * dim
    if walls:
        periodic[0] = False
    state = edmd.maxwell_boltzmann(edmd.lattice(64 if dim == 3 else 36, 0.1, dim=dim, periodic=periodic), 1.0, seed=3)
    sim = edmd.Simulation(state, collision=rule, engine={"neighbours": neighbours})
    assert sim.engine.loop is loop_variant(*key)
    sim.run(max_events=200)
    assert in_disk_cache(sim.engine.loop.run_events)  # each feature set is its own cache entry


def test_in_disk_cache_is_false_for_a_feature_set_never_compiled():
    assert not in_disk_cache(loop_variant(True, False, True, 97).run_events)


def test_the_core_compiles_without_reference_counting():
    # the probe of _core/jit.py finds Numba's private `_nrt` option (4.7x faster calendar)
    assert loop_variant(*PLAIN).run_events.targetoptions.get("_nrt") is False
