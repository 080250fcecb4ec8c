"""Loop variants: a run compiles only the code of its features (core v2, compile-time specialisation)."""

import numpy as np
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
FEATURE_CODE = {"emd_contact", "emd_contact_frictional", "finish_contact", "collide_wall", "execute_b", "is_pending", "well_event"}


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


@pytest.mark.parametrize("lists", [False, True], ids=["cells", "lists"])
def test_plain_hard_spheres_compile_no_feature_code(lists):
    names = referenced_globals(loop_variant(*PLAIN, lists=lists).run_events.py_func)
    assert {"collide_pair", "predict_pair", "predict_aux", "queue_top"} <= names
    assert not names & FEATURE_CODE
    assert "_debug_check" in names  # debug mode is a run-time switch of every variant (a called function)
    # the neighbour structure too is a compile-time constant: shell exits or crossings, not both
    structure = {"rebuild_list", "predict_added", "prefetch_neighbours", "cross_cell"}
    assert names & structure == ({"rebuild_list", "predict_added", "prefetch_neighbours"} if lists else {"cross_cell"})


@pytest.mark.parametrize(
    "features, code",
    [
        ((True, False, False, L.NORMAL_CONST), {"collide_wall"}),
        ((False, True, False, L.NORMAL_SOFT), {"emd_contact", "execute_b"}),
        ((True, True, False, L.NORMAL_SOFT), {"collide_wall", "emd_contact", "finish_contact", "execute_b", "is_pending"}),
        ((False, True, True, L.NORMAL_SOFT), {"emd_contact_frictional", "execute_b"}),
        ((False, False, False, L.NORMAL_CONST, False, False, True), {"well_event"}),
    ],
)
def test_each_feature_brings_its_own_code(features, code):
    assert referenced_globals(loop_variant(*features).run_events.py_func) & FEATURE_CODE == code


def test_smooth_emdstar_never_compiles_the_frictional_solver():
    """The A event of each kind (the loop variants above call the one of theirs): smooth runs the
    smooth map only (the frictional solver would cost them ~10 CPU-s of compilation), rough
    (frictional) runs the frictional one."""
    from edmd._core import emdstar

    names = {"smooth": referenced_globals(emdstar.emd_contact.py_func), "frictional": referenced_globals(emdstar.emd_contact_frictional.py_func)}
    assert "smooth_map" in names["smooth"] and "frictional_map" not in names["smooth"]
    assert "frictional_map" in names["frictional"] and "smooth_map" not in names["frictional"]


def test_variants_are_memoised_and_distinct():
    assert loop_variant(*PLAIN) is loop_variant(*PLAIN)
    assert loop_variant(*PLAIN) is not loop_variant(True, *PLAIN[1:])
    cells, lists = loop_variant(*PLAIN), loop_variant(*PLAIN, lists=True)
    assert cells is not lists and cells.setup_events is lists.setup_events  # (the set-up: one for both structures)
    assert (cells.name, cells.neighbours, lists.neighbours) == ("plain", "cells", "lists")


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
    assert sim.engine.loop is loop_variant(*key, lists=neighbours == "list")
    sim.run(max_events=200)
    assert in_disk_cache(sim.engine.loop.run_events)  # each feature set is its own cache entry


def test_in_disk_cache_is_false_for_a_feature_set_never_compiled():
    assert not in_disk_cache(loop_variant(True, False, True, 97).run_events)


def test_the_core_compiles_without_reference_counting():
    # the probe of _core/jit.py finds Numba's private `_nrt` option (4.7x faster calendar)
    assert loop_variant(*PLAIN).run_events.targetoptions.get("_nrt") is False


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("neighbours", ["list", "cells"])
@pytest.mark.parametrize("kind", [L.AUX_WALL, L.AUX_B, 99, "other structure"])
def test_an_event_kind_the_variant_lacks_stops_the_run_naming_it(dim, neighbours, kind):
    # a wall or B event in a plain run was once handled as a shell exit or cell crossing; a cells
    # variant has no shell exits, a lists variant no crossings
    from edmd._core.queue import queue_update

    state = edmd.maxwell_boltzmann(edmd.lattice(64 if dim == 3 else 36, 0.2, dim=dim), 1.0, seed=3)
    sim = edmd.Simulation(state, engine={"neighbours": neighbours})
    sim.run(max_events=50)
    if kind == "other structure":
        kind = L.AUX_CELL if neighbours == "list" else L.AUX_SHELL
    e = sim.engine
    i = 5
    now = float(e.acc[L.A_NOW])
    e.ev.aux_t[i] = now
    e.ev.aux_k[i] = kind
    queue_update(e.q, i, now)
    with pytest.raises(edmd.EngineError, match=rf"particle {int(e.tag[i])} has an event of kind {kind} at t = .* plain event loop \({neighbours}s?\)"):
        sim.run(max_events=50)


def test_no_bundle_is_indexed_by_number_in_the_core():
    import re
    from pathlib import Path

    core = Path(L.__file__).parent
    numeric = re.compile(r"(?<![\w.])(part|ev|q|grid|lists|emd)\[\d")
    hits = [f"{src.name}:{k + 1}" for src in core.glob("*.py") for k, line in enumerate(src.read_text().splitlines()) if numeric.search(line)]
    assert hits == []


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("neighbours", ["list", "cells"])
def test_debug_mode_is_a_switch_of_the_same_variant_that_stops_at_a_false_contact(dim, neighbours):
    # every particle nudged by up to 1 % of sigma behind the calendar's back: the collisions were
    # predicted from the old positions, so their pairs are away from contact; only the debug check sees it
    state = edmd.maxwell_boltzmann(edmd.lattice(216 if dim == 3 else 64, 0.3, dim=dim), 1.0, seed=3)
    runs = {debug: edmd.Simulation(state, engine={"neighbours": neighbours, "debug": debug}) for debug in (False, True)}
    assert runs[True].engine.loop is runs[False].engine.loop is loop_variant(*PLAIN, lists=neighbours == "list")
    for sim in runs.values():
        sim.run(max_events=100)
        sim.engine.part.rows[:, L.X : L.X + dim] += np.random.default_rng(1).uniform(-0.01, 0.01, (state.n, dim))
    runs[False].run(max_events=100)
    with pytest.raises(edmd.EngineError, match=r"debug check failed at t = .*: particles \d+ and \d+ \(relative contact error"):
        runs[True].run(max_events=100)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_load_that_changes_the_neighbour_structure_runs_the_loop_of_the_new_one(dim):
    """``neighbours = "auto"`` picks cells for small particles and lists for the same positions
    with larger radii (a dense state); an assigned state that changes the structure also changes
    the loop variant, and runs as in a Simulation of its own."""
    eta = {2: 0.65, 3: 0.45}[dim]  # (above AUTO_THRESHOLD)
    dense = edmd.maxwell_boltzmann(edmd.random_packing(400, eta, dim=dim, seed=4), 1.0, seed=5)
    dilute = dense.copy()
    dilute.radius = dense.radius * (0.1 / eta) ** (1 / dim)
    sim = edmd.Simulation(dilute)
    assert (sim.engine.mode, sim.engine.loop.neighbours) == ("cells", "cells")
    sim.run(max_events=1000)
    sim.state = dense
    assert (sim.engine.mode, sim.engine.loop) == ("list", loop_variant(*PLAIN, lists=True))
    before = sim.collisions
    fresh = edmd.Simulation(dense)
    for run in (sim, fresh):
        run.run(until_time=1.0)
    assert sim.collisions - before == fresh.collisions > 1000
    assert np.array_equal(sim.state.position, fresh.state.position)
