"""The event engine against an independent brute-force reference, and its invariants."""

import tracemalloc

import numpy as np
import pytest

import edmd
from edmd._core import layout as L
from edmd._core.cells import GI_BIGS, GI_REACH
from edmd import LinearDashpot
from edmd.physics.emdstar import EMDStar
from edmd.run.engine import EngineOptions
from edmd.state import StateError
from reference import run_reference

MODES = ["list", "cells"]


def _system(dim, n, eta, seed, poly=True):
    radius = {"kind": "uniform", "min": 0.4, "max": 0.6} if poly else 0.5
    s = edmd.random_packing(n, eta, dim=dim, seed=seed, radius=radius, density=1.0)
    return edmd.maxwell_boltzmann(s, 1.0, seed=seed + 1)


def _assert_brute_force(sim, s, t_end, min_collisions):
    """``sim`` (started from ``s``) run to ``t_end`` has the brute-force reference's collisions
    (pairs, times to 1e-9) and final positions and velocities (to 1e-9)."""
    sim.engine.enable_log()
    sim.run(until_time=t_end)
    log = sim.engine.take_log()
    pos, vel, ref = run_reference(s.position, s.velocity, s.radius, s.mass, s.box, t_end)
    ref = np.array(ref)
    assert len(ref) > min_collisions
    assert len(log) == len(ref)
    assert np.array_equal(np.sort(log[:, 1:3], axis=1).astype(int), ref[:, 1:].astype(int))
    assert np.abs(log[:, 0] - ref[:, 0]).max() < 1e-9
    final = sim.state
    d = final.position - pos
    d -= final.box * np.round(d / final.box)
    assert np.abs(d).max() < 1e-9
    assert np.abs(final.velocity - vel).max() < 1e-9


@pytest.mark.parametrize("mode", MODES)
def test_same_collisions_and_final_state_as_brute_force(dim, mode):
    # 3-5 collisions per particle: long enough to exercise every event type, short enough
    # that chaos has not amplified the round-off difference of lazy vs eager updating above 1e-9.
    n, eta, t_end = (100, 0.3, 1.6) if dim == 2 else (80, 0.2, 1.2)
    s = _system(dim, n, eta, seed=4)
    _assert_brute_force(edmd.Simulation(s, engine=EngineOptions(neighbours=mode, debug=True)), s, t_end, 2 * n)


@pytest.mark.parametrize("cell_size", [1.0, 2.5, None])
def test_wide_cells_with_a_size_ratio_of_ten_match_brute_force(dim, cell_size):
    # dilute, radii 0.1-1.0 (equal masses: no fast dust amplifying round-off above 1e-9 in a few
    # collisions): 1.0 pins the edge, 2.5 is capped at 4 cells per axis (3D) and the cost model's
    # cells (None) are wider than the largest contact distance in 2D (19, 7 and 10 cells; in 3D
    # the largest particles set them: 6, 4 and 6). Every choice must give the reference's
    # collisions, then run on with the debug checks of every collision.
    n, eta, t_end = (120, 0.1, 3.0) if dim == 2 else (100, 0.05, 3.0)
    s = edmd.random_packing(n, eta, dim=dim, seed=9, radius={"kind": "uniform", "min": 0.1, "max": 1.0})
    s = edmd.maxwell_boltzmann(s, 1.0, seed=10)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="cells", cell_size=cell_size, debug=True))
    assert np.all(sim.engine.grid_cells[:dim] >= 4)
    _assert_brute_force(sim, s, t_end, n // 2)
    sim.run(max_events=100_000)
    assert abs(sim.state.kinetic_energy() / s.kinetic_energy() - 1) < 1e-10


def _intruders(dim, n, bigs, ratio, eta, seed=9, **kwargs):
    """``bigs`` particles of radius 1 among ``n`` of radius ``1 / ratio`` (equal masses: no fast dust
    amplifying round-off), Maxwell-Boltzmann velocities."""
    radius = {"kind": "discrete", "values": [1.0 / ratio, 1.0], "fractions": [1 - bigs / n, bigs / n]}
    s = edmd.random_packing(n, eta, dim=dim, seed=seed, radius=radius, **kwargs)
    return edmd.maxwell_boltzmann(s, 1.0, seed=seed + 1)


def _assert_big_split(sim, bigs):
    """Cells mode took ``bigs`` big particles out of the cell size, which scan more than 1 cell around."""
    grid = sim.engine.grid
    assert sim.engine.mode == "cells" and grid.shape[GI_BIGS] == bigs and grid.shape[GI_REACH] >= 2
    assert np.all(sim.engine.part.rows[grid.head[-bigs:], L.R] == 1.0)


@pytest.mark.parametrize("slow_case", [False, pytest.param(True, marks=pytest.mark.slow)], ids=["fast", "ratio-10-3d"])
def test_big_particles_match_brute_force(dim, slow_case):
    # intruders of size ratio 10 (3D: 5 in the fast case, whose box must fit their blocks with a
    # reference that stays quick) among small particles: cells sized for the small ones, the
    # bigs' blocks of cells and the tests of every big by every scan (physics.md §1.4 "Big
    # particles") give the reference's collisions, then run on with the debug checks
    if slow_case and dim == 2:
        pytest.skip("the 2D case is the fast one")
    n, bigs, ratio, eta, t_end = {2: (150, 2, 10, 0.1, 2.0), 3: (400, 2, 10, 0.03, 2.0) if slow_case else (200, 3, 5, 0.05, 2.4)}[dim]
    _assert_big_split_is_brute_force(dim, n, bigs, ratio, eta, t_end)


def test_lists_with_big_particles_match_brute_force(dim):
    # the intruders of the fast case in list mode: list builds read a candidate's radius only
    # between the bounds of the radii (a size ratio of 5-10 puts many candidates there); the
    # reference's collisions, then on with the debug checks
    n, bigs, ratio, eta, t_end = {2: (150, 2, 10, 0.1, 2.0), 3: (200, 3, 5, 0.05, 2.4)}[dim]
    s = _intruders(dim, n, bigs, ratio, eta)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="list", debug=True))
    _assert_brute_force(sim, s, t_end, n // 2)
    assert sim.engine.cnt[L.C_REBUILD] > n
    sim.run(max_events=50_000)
    assert abs(sim.state.kinetic_energy() / s.kinetic_energy() - 1) < 1e-10


def _assert_big_split_is_brute_force(dim, n, bigs, ratio, eta, t_end):
    s = _intruders(dim, n, bigs, ratio, eta)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="cells", debug=True))
    _assert_big_split(sim, bigs)
    _assert_brute_force(sim, s, t_end, n // 2)
    sim.run(max_events=50_000)
    assert abs(sim.state.kinetic_energy() / s.kinetic_energy() - 1) < 1e-10
    return sim


def test_one_big_particle_in_a_short_box_matches_brute_force(dim):
    """One intruder of size ratio 5 in a box shorter than twice the contact of two bigs plus 4
    cells, but not than twice its contact with a small one (plus 4 cells): the largest contact
    that exists sets the box a split needs (physics.md §1.4, "Big particles")."""
    n, eta = {2: (60, 0.35), 3: (250, 0.15)}[dim]
    sim = _assert_big_split_is_brute_force(dim, n, 1, 5, eta, 1.0)  # (dense: round-off grows past 1e-9 by t = 2)
    assert sim.state.box[0] < 2.0 * 2.0 + 4.0 * sim.engine.grid.size[0]


def test_auto_keeps_cells_for_big_particles_at_any_density(dim):
    """Dense systems, where 'auto' takes lists: with an intruder of size ratio 10 it keeps cells
    with the intruder taken out (lists would size their centre cells and every list by it), with
    one of ratio 2 (below AUTO_BIG_RATIO) it takes lists."""
    eta = 0.45 if dim == 3 else 0.65
    for ratio, mode in ((10, "cells"), (2, "list")):
        sim = edmd.Simulation(_intruders(dim, 3000, 1, ratio, eta))
        assert sim.engine.mode == mode
    _assert_big_split(edmd.Simulation(_intruders(dim, 3000, 1, 10, eta)), 1)


@pytest.mark.parametrize("soft", [False, True], ids=["hard", "emdstar"])
def test_big_particles_agree_with_lists(dim, soft):
    """A larger gas with five intruders of size ratio 10: cells with big particles and neighbour
    lists (the other structure, whose lists hold every partner of a big) meet the same collisions;
    with eMD* soft contacts too (their A events' relocation scans walk a big's block and test
    every big, emdstar.relocation_scan), and the same exceptions."""
    s = _intruders(dim, 3000, 5, 10, 0.05 if dim == 3 else 0.1, seed=5)
    logs, counters = [], []
    for mode in MODES:
        collision = EMDStar(LinearDashpot(k=1e4, gamma=20.0)) if soft else None
        sim = edmd.Simulation(s, collision=collision, engine=EngineOptions(neighbours=mode))
        if mode == "cells":
            _assert_big_split(sim, 5)
        sim.engine.enable_log()
        sim.run(until_time=0.5)
        logs.append(sim.engine.take_log())
        counters.append(sim.emd_counters() if soft else None)
    assert counters[0] == counters[1] and (not soft or counters[0]["emd_contacts"] > 1000)
    big = np.flatnonzero(s.radius == 1.0)
    assert len(logs[0]) == len(logs[1]) > 1000
    assert np.isin(logs[0][:, 1:3], big).any(axis=1).sum() > 20
    assert np.array_equal(np.sort(logs[0][:, 1:3], axis=1), np.sort(logs[1][:, 1:3], axis=1))
    assert np.abs(logs[0][:, 0] - logs[1][:, 0]).max() < 1e-9


def test_big_particles_are_not_split_with_a_fixed_cell_size(dim):
    """A fixed cell size keeps the cells as wide as the largest contact."""
    s = _intruders(dim, 3000, 5, 10, 0.05 if dim == 3 else 0.1, seed=5)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="cells", cell_size=1.0))
    assert sim.engine.grid.shape[GI_BIGS] == 0
    assert np.all(sim.engine.grid.size[:dim] >= 2.0 - 1e-12)


def test_neighbour_modes_agree_on_a_collision_sequence(dim):
    s = _system(dim, 200, 0.25, seed=11)
    logs = []
    for mode in MODES:
        sim = edmd.Simulation(s, engine=EngineOptions(neighbours=mode))
        sim.engine.enable_log()
        sim.run(until_time=1.5)
        logs.append(sim.engine.take_log())
    assert len(logs[0]) == len(logs[1]) > 250
    assert np.array_equal(np.sort(logs[0][:, 1:3], axis=1), np.sort(logs[1][:, 1:3], axis=1))
    assert np.abs(logs[0][:, 0] - logs[1][:, 0]).max() < 1e-9


@pytest.mark.parametrize("mode, eta", [("list", 0.45), ("cells", 0.1)])
def test_million_events_invariants(dim, mode, eta):
    s = _system(dim, 1000, 0.1, seed=2, poly=False)
    if eta > 0.1:
        s = edmd.maxwell_boltzmann(edmd.lattice(1000, eta, dim=dim), 1.0, seed=3)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours=mode, debug=True))
    e0, p0 = s.kinetic_energy(), s.momentum()
    scale = float(np.sum(s.mass * np.linalg.norm(s.velocity, axis=1)))
    sim.run(max_events=1_000_000)
    assert sim.events >= 1_000_000
    f = sim.state
    assert abs(f.kinetic_energy() / e0 - 1) < 1e-10
    assert np.abs(f.momentum() - p0).max() < 1e-12 * scale
    assert f.overlapping_pair(1e-9) is None


def test_neighbour_lists_stay_symmetric_and_complete(dim):
    s = _system(dim, 400, 0.35 if dim == 2 else 0.3, seed=5)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="list", resync_every=1e9))
    sim.run(max_events=200_000)
    e = sim.engine
    assert e.cnt[L.C_REBUILD] > 1000
    nbl, nbl_n, centre = e.lists
    P = e.part.rows
    skin = e.fp[L.FP_SKIN]
    box, half = e.box, e.half
    sets = [set(nbl[i, : nbl_n[i]].tolist()) for i in range(s.n)]
    for i in range(s.n):
        d = centre[i] - centre
        d = np.where(np.isfinite(half), d - box * np.round(d / box), d)
        close = np.flatnonzero(np.linalg.norm(d, axis=1) < P[i, L.R] + P[:, L.R] + skin)
        assert set(close.tolist()) - {i} <= sets[i]
        for j in sets[i]:
            assert i in sets[j]


def test_list_capacity_grows_when_needed(dim):
    s = _system(dim, 300, 0.3, seed=6)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="list"))
    sim.engine.list_capacity = 2
    sim.state = s  # rebuild with the tiny capacity: it must grow, not fail
    sim.run(until_time=0.5)
    assert sim.engine.list_capacity > 2
    assert sim.state.overlapping_pair(1e-9) is None


def test_cells_mode_needs_a_big_enough_box():
    s = _system(3, 20, 0.3, seed=1)
    with pytest.raises(edmd.StateError, match="neighbours='cells' needs periodic box lengths"):
        edmd.Simulation(s, engine=EngineOptions(neighbours="cells"))


def test_frozen_system_is_idle(dim):
    s = edmd.lattice(8, 0.1, dim=dim)
    sim = edmd.Simulation(s)
    sim.run(until_time=5.0)
    assert sim.time == 5.0 and sim.events == 0


@pytest.mark.parametrize("mode, eta", [("cells", 0.02), ("cells", 0.45), ("list", 0.45)])
def test_work_per_event_does_not_grow_with_n(dim, mode, eta):
    """Cells scanned, pairs tested and calendar entries moved per event are the same at N = 500
    and 4000 (a scan or a calendar that grows with N would make large runs stall). The dense
    cases start from a lattice, whose particles sit on cell faces: thousands of events at t = 0
    once gave the calendar a zero bucket width, and every event then walked all particles."""
    per_event = []
    for n in (500, 4000):
        s = edmd.lattice(n, eta, dim=dim) if eta > 0.3 else edmd.random_packing(n, eta, dim=dim, seed=3)
        sim = edmd.Simulation(edmd.maxwell_boltzmann(s, 1.0, seed=4), engine=EngineOptions(neighbours=mode))
        sim.run(max_events=20 * n)
        w = sim.engine.work_counters()
        assert w["events"] == 20 * n
        per_event.append(np.array([w["cells_scanned"], w["pairs_tested"], w["calendar_moves"]]) / w["events"])
    small, large = per_event
    assert np.all(small > 0.5)
    assert np.all(large < 1.15 * small), (small, large)


def test_cells_need_four_cells_per_periodic_axis_and_auto_falls_back_to_lists():
    """A dilute thin slab: the memory cap on the cell count leaves 3 cells across it, where two
    cells are adjacent through two periodic images (collisions through the second were missed).
    'cells' refuses it naming the problem, 'auto' takes lists and runs."""
    rng = np.random.default_rng(3)
    pos = np.c_[rng.uniform(-100, 100, (1000, 2)), rng.uniform(-2.5, 2.5, 1000)]
    s = edmd.State(position=pos, velocity=rng.normal(size=(1000, 3)), radius=0.01, mass=1.0, box=[200, 200, 5])
    with pytest.raises(edmd.StateError, match=">= 4 cells on every periodic axis.*memory cap"):
        edmd.Simulation(s, engine={"neighbours": "cells"})
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours="auto", debug=True))
    assert sim.engine.mode == "list"
    sim.run(max_events=20_000)
    assert abs(sim.state.kinetic_energy() / s.kinetic_energy() - 1) < 1e-10


@pytest.mark.parametrize("mode", MODES)
def test_engine_memory_per_particle(dim, mode):
    """The engine's arrays of a smooth hard-sphere run: the 64-byte row, mass, image, counter,
    the two events, the calendar, the cell links and, in list mode, the lists; nothing for spins,
    TC times, eMD* contacts or the bath (size 0 when off). Bounds with the measured figures of
    benchmarks/README.md ("Memory"): cells 155 B, lists 252 B (capacity 19) in 3D."""
    s = edmd.maxwell_boltzmann(edmd.lattice(4000, 0.4, dim=dim), 1.0, seed=1)
    sim = edmd.Simulation(s, engine=EngineOptions(neighbours=mode))
    e = sim.engine
    for field in (e.part.omega, e.part.inertia, e.part.last_collision, e.emd.pending_dv, e.emd.pending_until, e.drive.bath_t):
        assert field.size == 0
    arrays = [*e.part, *e.ev, *e.q, *e.grid, *e.lists, *e.emd, *e.drive, *e.pairs, e.tag]
    per_particle = sum(a.nbytes for a in arrays) / s.n
    lists = e.lists.members.nbytes / s.n if mode == "list" else 0.0
    assert per_particle - lists < 175 + 28 * (mode == "list"), per_particle


@pytest.mark.parametrize("mode", ["cells", "list"])
def test_a_resync_needs_less_than_a_state_beyond_the_run(mode):
    """A maintenance resync rebuilds the engine in place: the event, calendar, cell and list arrays
    go first, and the rows are streamed and sorted in place (no snapshot). With a snapshot (96 B
    per particle) on top of the whole engine it took +135-145 B per particle above the run, then
    +63-67 with the arrays dropped first and the snapshot handed over to the load; in place 39-49
    (the rebuild's transients: the calendar's sorted keys, the lists' count)."""
    n = 8000
    s = edmd.maxwell_boltzmann(edmd.lattice(n, 0.5), 1.0, seed=2)
    edmd.Simulation(s, engine={"neighbours": mode}).run(max_events=100)  # (compiled before tracing)
    tracemalloc.start()
    try:
        sim = edmd.Simulation(s, engine={"neighbours": mode})
        sim.run(max_events=2 * n)
        tracemalloc.reset_peak()
        before = tracemalloc.get_traced_memory()[0]
        sim.engine.resync()
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    assert peak <= 56 * n, f"the resync took {peak / n:.0f} B per particle beyond the run"


def _engine_arrays(e) -> dict[str, np.ndarray]:
    """Every array of an engine (its bundles' fields, the tag, counters and accumulators) and its
    other attributes as reprs, for bit-for-bit comparisons."""
    out = {"tag": e.tag, "acc": e.acc, "cnt": e.cnt}
    for name in ("part", "ev", "q", "grid", "lists", "emd", "drive", "pairs"):
        out.update({f"{name}.{field}": a for field, a in zip(getattr(e, name)._fields, getattr(e, name))})
    out.update({k: np.array([repr(v)]) for k, v in vars(e).items() if isinstance(v, (int, float, tuple, str, bool))})
    return out


def _in_place_case(dim, case):
    periodic = [True] * (dim - 1) + [case not in ("walls", "soft_walls_gravity")]
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.3, dim=dim, periodic=periodic, seed=2), 1.0, seed=3, spin=case == "rough")
    down = [0.0] * (dim - 1) + [-0.5]
    soft = EMDStar(edmd.Hertz(young=2e3, poisson=0.3, A=2e-3))
    kw = {
        "rough": {"collision": edmd.collide.Rough(0.9, -0.5)},
        "tc": {"collision": edmd.collide.TC(edmd.collide.Inelastic(0.8), duration=1e-3)},
        "walls": {"e_n": 0.9},
        "soft": {"collision": soft},
        "soft_walls_gravity": {"collision": soft, "gravity": down},
        "shear": {"shear": edmd.Shear(1.0), "e_n": 0.9},
        "bath_and_kicks": {"e_n": 0.9, "thermostat": edmd.Andersen(kT=1.0, rate=0.5, seed=4), "forcing": edmd.WhiteNoise(xi0=1.0, interval=0.05, seed=3)},
    }[case]
    return (kw["shear"].with_profile(s) if "shear" in kw else s), kw


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("case", ["rough", "tc", "walls", "soft", "soft_walls_gravity", "shear", "bath_and_kicks"])
def test_a_resync_in_place_makes_the_arrays_a_reload_of_its_snapshot_makes(dim, mode, case, monkeypatch):
    """A resync streams the rows to its time and sorts them in place (no snapshot of every
    particle): every engine array must be bit for bit what a load of the snapshot makes, which a
    restart from a checkpoint at that time also makes. Several resyncs in a row, with an origin
    other than 0 (the local time of the snapshot is ``(origin + now) - origin``)."""
    s, kw = _in_place_case(dim, case)
    if mode == "cells" and "gravity" in kw:
        kw["engine"] = {"neighbours": mode, "cell_size": 1.5}  # (automatic cells under gravity follow the bed: a reload)
    else:
        kw["engine"] = {"neighbours": mode}
    sims = [edmd.Simulation(s, **kw), edmd.Simulation(s, **kw)]
    in_place = edmd.run.engine.Engine._rebases_in_place
    assert in_place(sims[0].engine)
    for _ in range(3):
        for sim, way in zip(sims, (in_place, lambda self: False)):
            monkeypatch.setattr(edmd.run.engine.Engine, "_rebases_in_place", way)
            sim.run(max_events=2500)
            sim.engine.resync()
        a, b = (_engine_arrays(sim.engine) for sim in sims)
        assert sims[0].engine.t_origin > 0.0 and a.keys() == b.keys()
        assert not [k for k in a if not (a[k].dtype == b[k].dtype and a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes())]
    if isinstance(kw.get("collision"), EMDStar):
        assert sims[0].engine.emd_counters()["emd_contacts"] > 100 and sims[0].state.has_pending


def test_a_fault_found_by_a_resync_stops_the_engine_with_the_state_readable():
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0, seed=1))
    sim.run(max_events=1000)
    sim.engine.part.rows[7, 3] = np.nan  # (a corrupted velocity)
    with pytest.raises(StateError, match=r"is not finite \(NaN or inf\) at particle"):
        sim.engine.resync()
    assert np.isnan(sim.state.velocity).any() and sim.state.n == 500  # (still readable)
    with pytest.raises(edmd.run.engine.EngineError, match="stopped at a fault of its last resync: .* is not finite"):
        sim.run(max_events=10)


@pytest.mark.parametrize("case", ["rough", "spinning", "inertia", "tc"])
def test_cold_arrays_are_carried_when_needed(dim, case):
    """Spins (and moments of inertia) are carried by rough runs and by smooth runs of a state that
    spins or has its own moments of inertia, TC times by TC runs: snapshots give them back."""
    s = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.2, dim=dim, seed=2), 1.0, seed=3, spin=case == "spinning")
    if case == "inertia":
        s.inertia = 0.3 * s.inertia
    rule = {"rough": edmd.collide.Rough(0.9, -0.5), "tc": edmd.collide.TC(edmd.collide.Inelastic(0.8), duration=1e-3)}.get(case)
    sim = edmd.Simulation(s, collision=rule)
    sim.run(max_events=4000)
    e, out = sim.engine, sim.state
    assert (e.part.omega.size > 0) == (case != "tc") and (e.part.last_collision.size > 0) == (case == "tc")
    assert np.array_equal(out.inertia, s.inertia)
    if case == "spinning":
        assert np.array_equal(out.angular_velocity, s.angular_velocity)  # smooth: spins never change
    if case == "rough":
        assert out.rotational_energy() > 0
    if case == "tc":
        assert np.isfinite(out.last_collision).sum() > 100


@pytest.mark.parametrize("dim", [2, 3])
def test_auto_takes_cells_up_to_the_measured_crossover_and_lists_from_it(dim):
    """'auto' follows AUTO_THRESHOLD (where lists overtook cells in benchmarks/README.md,
    "Neighbour structure"); an explicit auto_threshold overrides it."""
    from edmd.run.engine import AUTO_THRESHOLD

    edge = AUTO_THRESHOLD[dim]
    assert edge == {2: 0.6, 3: 0.35}[dim]
    for eta, mode in ((edge - 0.02, "cells"), (edge + 0.02, "list")):
        state = edmd.random_packing(400, eta, dim=dim, seed=1)
        assert edmd.Simulation(state).engine.mode == mode
    state = edmd.random_packing(400, 0.25, dim=dim, seed=1)
    assert edmd.Simulation(state, engine={"auto_threshold": 0.2}).engine.mode == "list"


@pytest.mark.parametrize("mode", ["cells", "list"])
def test_a_loaded_state_with_larger_particles_gets_its_own_neighbour_structure(dim, mode):
    """A state assigned to a Simulation built for smaller particles runs as in a Simulation of its
    own: cells, lists (and a big particle's block) are chosen again for its radii. (They were
    kept: the larger particles' contacts were missed, and the debug check failed.)"""
    n = 600
    big = {"kind": "discrete", "values": [0.5, 1.2 if mode == "list" else 3.0], "fractions": [n - 20, 20]}
    a = edmd.maxwell_boltzmann(edmd.random_packing(n, 0.1, dim=dim, radius=big, seed=1), 1.0, seed=2)
    b = a.copy()
    b.radius = np.full(n, 0.5)
    sim = edmd.Simulation(b, engine=EngineOptions(neighbours=mode, debug=True))
    sim.state = a
    fresh = edmd.Simulation(a, engine=EngineOptions(neighbours=mode, debug=True))
    for run in (sim, fresh):
        run.run(until_time=5.0)
    assert sim.collisions == fresh.collisions > 300
    assert np.array_equal(sim.state.position, fresh.state.position)


def test_a_loaded_state_must_have_the_same_box(dim):
    """A state of another box (or other periodic axes) is refused, naming both, instead of running in the old box."""
    a = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.1, dim=dim, seed=1), 1.0, seed=2)
    sim = edmd.Simulation(a)
    with pytest.raises(StateError, match=r"must have the simulation's box .* got"):
        sim.state = edmd.maxwell_boltzmann(edmd.random_packing(200, 0.3, dim=dim, seed=1), 1.0, seed=2)
    walled = edmd.random_packing(200, 0.1, dim=dim, seed=1, periodic=[True] * (dim - 1) + [False])
    with pytest.raises(StateError, match="periodic axes"):
        sim.state = edmd.State(position=walled.position, velocity=walled.velocity, radius=walled.radius, mass=walled.mass, box=a.box, periodic=walled.periodic)


def test_resyncs_after_every_event_or_two_are_spaced_out():
    """resync_every * N < 2 was reported as an inelastic collapse (simultaneous events never advanced
    the clock); resyncs are now at least MIN_RESYNC_EVENTS apart."""
    sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(108, 0.2), 1.0, seed=1), engine={"resync_every": 0.008})
    sim.run(until_time=2.0)
    assert sim.time == 2.0 and sim.collisions > 300


def test_snapshots_give_one_radius_and_mass_as_one(dim):
    """A run of particles of one radius and mass gives them (and the default moments) back as
    one number in its snapshots and views (no memory per particle; the values the arrays had),
    growing radii too; polydisperse runs give arrays."""
    mono = edmd.maxwell_boltzmann(edmd.lattice(200, 0.2, dim=dim), 1.0, seed=1)
    sim = edmd.Simulation(mono)
    sim.run(max_events=2000)
    for state in (sim.state, sim.state_view()):
        for name in ("radius", "mass", "inertia"):
            a = getattr(state, name)
            assert not any(a.strides) and a.tobytes() == getattr(mono, name).tobytes(), name
    grown = edmd.Simulation(mono, growth=edmd.Growth(rate=0.05))
    grown.run(max_events=2000)
    r = grown.state.radius
    assert not any(r.strides) and r[0] > mono.radius[0]
    poly = _system(dim, 200, 0.2, seed=3)
    sim = edmd.Simulation(poly)
    sim.run(max_events=2000)
    assert sim.state.radius.strides == (8,) and np.array_equal(sim.state.radius, poly.radius)
