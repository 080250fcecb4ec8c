"""Neighbour lists with a shell (``_core/nblist.py``): the lists after many per-particle rebuilds
are exactly the pairs of list centres within ``sigma_ij + skin``, found independently here."""

import numpy as np
import pytest

import edmd
from edmd._core import layout as L
from edmd._core import nblist
from edmd._core.bundles import Lists
from edmd.run.engine import EngineOptions


def _listed_pairs(engine) -> set[tuple[int, int]]:
    """The pairs in the engine's lists; each list must hold each partner once and be mirrored."""
    members, size = engine.lists.members, engine.lists.size
    pairs = set()
    for i in range(engine.n):
        row = members[i, : size[i]].tolist()
        assert len(row) == len(set(row)), f"particle {i} lists a partner twice"
        pairs.update((i, j) for j in row)
    assert all((j, i) in pairs for i, j in pairs), "a list is not mirrored"
    return {(i, j) for i, j in pairs if i < j}


def _distance2(d, box) -> np.ndarray:
    """Squared minimum-image lengths of the separations ``d`` (last axis: the components)."""
    d = d - box * np.round(d / box)
    return (d**2).sum(axis=-1)


def _pairs_by_distance(engine, dim) -> set[tuple[int, int]]:
    """All pairs whose list centres are closer than ``sigma_ij + skin`` (minimum image, numpy)."""
    centre = engine.lists.centre[:, :dim]
    radius = engine.part.rows[:, L.R]
    box = engine.box[:dim]
    reach = radius[:, None] + radius[None, :] + engine.fp[L.FP_SKIN]
    i, j = np.nonzero(np.triu(_distance2(centre[:, None, :] - centre[None, :, :], box) < reach**2, k=1))
    return set(zip(i.tolist(), j.tolist()))


def test_a_rebuild_returns_the_neighbours_it_added_as_the_last_entries(dim):
    # each rebuild moves a centre by up to the shell: the neighbours kept keep their order, the
    # new ones follow them (what schedule.predict_added tests), the departed are gone from both lists
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.4, dim=dim, seed=11), 1.0, seed=12)
    engine = edmd.Simulation(s, engine=EngineOptions(neighbours="list")).engine
    P, skin, lists = engine.part.rows, engine.fp[L.FP_SKIN], engine.lists
    rng = np.random.default_rng(2)
    gained = 0
    for i in rng.choice(engine.n, 150, replace=False):
        old = lists.members[i, : lists.size[i]].tolist()
        P[i, :dim] = lists.centre[i, :dim] + rng.uniform(-0.5, 0.5, dim) * skin
        P[i, :dim] -= engine.box[:dim] * np.floor(P[i, :dim] / engine.box[:dim] + 0.5)  # (back into the box)
        added = nblist.rebuild_list(i, P, engine.grid, lists, engine.geo, skin, 1.0, engine.cbuf)
        row = lists.members[i, : lists.size[i]].tolist()
        kept = [j for j in old if j in row]
        assert row == kept + [j for j in row if j not in old] and added == len(row) - len(kept)
        gained += added
    assert gained > 20
    assert _listed_pairs(engine) == _pairs_by_distance(engine, dim)


@pytest.mark.parametrize("radius", [0.5, {"kind": "uniform", "min": 0.1, "max": 1.0}], ids=["equal", "ratio-10"])
def test_lists_after_many_rebuilds_are_the_pairs_within_reach(dim, radius):
    # a dense fluid rebuilds each list many times; with radii 0.1-1.0 the bounds of the radii that
    # spare reading a candidate's radius (r_min, r_max) differ from every radius but two
    s = edmd.random_packing(300 if dim == 2 else 400, 0.4, dim=dim, seed=3, radius=radius)
    sim = edmd.Simulation(edmd.maxwell_boltzmann(s, 1.0, seed=4), engine=EngineOptions(neighbours="list"))
    sim.run(max_events=40 * s.n)
    engine = sim.engine
    assert engine.cnt[L.C_REBUILD] > 5 * s.n
    listed = _listed_pairs(engine)
    assert listed == _pairs_by_distance(engine, dim)
    assert len(listed) > s.n


def test_lists_cut_to_the_fullest_overflow_grow_and_stay_exact(dim):
    # rows cut to the fullest list: a rebuild that finds a new neighbour for a full list first
    # frees the slots of the departed (mid-walk), and a list that is still full makes the engine
    # grow the rows and rebuild; the lists stay exact either way
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.3, dim=dim, seed=5), 1.0, seed=6)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="list"))
    members, size, centre = sim.engine.lists
    fullest = int(size.max())
    sim.engine.lists = Lists(np.ascontiguousarray(members[:, :fullest]), size, centre)
    sim.engine.list_capacity = fullest
    sim.run(max_events=30 * s.n)
    assert sim.engine.list_capacity > fullest
    assert _listed_pairs(sim.engine) == _pairs_by_distance(sim.engine, dim)


def test_a_rebuild_of_a_full_list_frees_the_departed_first(dim):
    # i's row is full of old neighbours when the walk finds a new one: the departed give up their
    # slots mid-walk, and the new list fits
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.3, dim=dim, seed=7), 1.0, seed=8)
    engine = edmd.Simulation(s, engine=EngineOptions(neighbours="list")).engine
    members, size, centre = engine.lists
    cap = int(size.max())
    engine.lists = Lists(np.ascontiguousarray(members[:, :cap]), size, centre)
    P, skin, box = engine.part.rows, engine.fp[L.FP_SKIN], engine.box[:dim]
    rng = np.random.default_rng(1)

    def within_reach(i, x):
        near = set(np.nonzero(_distance2(centre[:, :dim] - x, box) < (P[i, L.R] + P[:, L.R] + skin) ** 2)[0].tolist())
        return near - {i}

    for i in np.nonzero(size == cap)[0]:
        old = set(members[i, :cap].tolist())
        for _ in range(500):  # a new centre that gains a neighbour and still fits the row
            x = centre[i, :dim] + rng.uniform(-0.5, 0.5, dim)
            new = within_reach(i, x)
            if len(new) <= cap and new - old and all(size[j] < cap for j in new - old):
                break
        else:
            continue
        P[i, :dim] = x
        added = nblist.rebuild_list(i, P, engine.grid, engine.lists, engine.geo, skin, 1.0, engine.cbuf)
        assert added >= 0  # (-1: a list ran full)
        row = engine.lists.members[i, : engine.lists.size[i]].tolist()
        assert set(row) == new and set(row[len(row) - added :]) >= new - old  # (old ones found after the free count too)
        assert _listed_pairs(engine) == _pairs_by_distance(engine, dim)
        return
    pytest.fail("no full list found whose rebuild swaps neighbours")


def test_lists_of_intruders_with_hundreds_of_candidates_stay_exact(dim):
    # radius-6 intruders among radius-0.5 particles: an intruder's walk finds over a hundred
    # centres within its reach (its radius + skin + the largest radius), most of them beyond its
    # own sums; the lists stay exact through the builds and every rebuild
    radius = {"kind": "discrete", "values": [0.5, 6.0], "fractions": [0.995, 0.005]}
    s = edmd.maxwell_boltzmann(edmd.random_packing(1000, 0.3, dim=dim, seed=13, radius=radius), 1.0, seed=14)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="list"))
    engine = sim.engine
    centre, box = engine.lists.centre[:, :dim], engine.box[:dim]
    big = int(np.argmax(engine.part.rows[:, L.R]))
    far = 6.0 + engine.fp[L.FP_SKIN] + 6.0
    assert np.count_nonzero(_distance2(centre - centre[big], box) < far**2) > 100
    assert _listed_pairs(engine) == _pairs_by_distance(engine, dim)
    sim.run(max_events=20 * s.n)
    assert engine.cnt[L.C_REBUILD] > 2 * s.n
    assert _listed_pairs(engine) == _pairs_by_distance(engine, dim)


@pytest.mark.parametrize("radius", [0.5, {"kind": "uniform", "min": 0.1, "max": 1.0}], ids=["equal", "ratio-10"])
def test_first_build_counts_then_fills_rows_of_the_fullest(dim, radius):
    # lists of no columns are counted, not built: the counts are the sizes of the built lists
    # (which are the pairs within reach), and the engine's first build makes rows of the fullest
    # plus the margin at once (no transient rows of a guessed size)
    s = edmd.maxwell_boltzmann(edmd.random_packing(400, 0.4, dim=dim, seed=3, radius=radius), 1.0, seed=4)
    engine = edmd.Simulation(s, engine=EngineOptions(neighbours="list")).engine
    sizes = engine.lists.size
    assert engine.lists.members.shape[1] == int(sizes.max() * 1.25) + 4 == engine.list_capacity
    assert _listed_pairs(engine) == _pairs_by_distance(engine, dim)
    grid = type(engine.grid)(*(a.copy() for a in engine.grid))
    counted = Lists(np.zeros((engine.n, 0), np.int32), np.zeros(engine.n, np.int32), np.zeros((engine.n, 3)))
    assert not nblist.build_lists(engine.part.rows, grid, counted, engine.geo, engine.fp[L.FP_SKIN], nblist.list_reach(engine.fp), engine.cbuf)
    assert np.array_equal(counted.size, sizes) and sizes.sum() > 2 * engine.n
