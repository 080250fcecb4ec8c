"""Lees-Edwards images (``_core/images.py``): minimum images, pair times and whole runs against a
brute-force reference that tests every sliding image explicitly (``tests/reference.py``)."""

import dataclasses

import numpy as np
import pytest

import edmd
from edmd._core import layout as L
from edmd._core.images import fold_face, image_offset, shear_image
from edmd.run.engine import EngineOptions
from edmd.state import StateError
from reference import _sheared_pair_times, run_sheared_reference


def _geo(box, rate, offset):
    box3 = np.ones(3)
    box3[: len(box)] = box
    half = np.full(3, np.inf)
    half[: len(box)] = 0.5 * np.asarray(box)
    return L.make_geo(box3, half, shear=(rate, offset))


def _sheared_state(dim, n, eta, seed, rate, offset=0.0, poly=True):
    """A gas in the linear profile whose images are offset by ``offset`` (mod L_x): sheared from 0 until then."""
    radius = {"kind": "uniform", "min": 0.4, "max": 0.6} if poly else 0.5
    s = edmd.maxwell_boltzmann(edmd.random_packing(n, eta, dim=dim, seed=seed, radius=radius), 1.0, seed=seed + 1)
    s = edmd.Shear(rate).with_profile(s)
    if offset == 0.0:
        return s
    sim = edmd.Simulation(s, shear=edmd.Shear(rate))
    sim.run(until_time=(offset % s.box[0]) / (rate * s.box[1]))
    return dataclasses.replace(sim.state, time=0.0)


@pytest.mark.parametrize("offset", [0.0, 1.3, -4.9, 7.7])
def test_minimum_image_is_the_nearest_of_all_sliding_images(dim, offset):
    # within half the shortest box length (the reach of any contact: cells need 4 per axis) the
    # image chosen, nearest along y and then along x, is the nearest of all
    rng = np.random.default_rng(3)
    box = np.array([10.0, 8.0, 9.0])[:dim]
    geo = _geo(box, 0.25, offset)
    delta = image_offset(0.0, geo)
    assert -5.0 <= delta < 5.0 and np.isclose((delta - offset) / 10.0, np.round((delta - offset) / 10.0))
    near = 0
    for _ in range(3000):
        d = rng.uniform(-1.0, 1.0, dim) * box
        d3 = np.zeros(3)
        d3[:dim] = d
        dx, dy, dz, ux = shear_image(*d3, 0.0, geo)
        best = None
        for sy in (-1, 0, 1):  # every image explicitly
            for sx in range(-2, 3):
                for sz in (-1, 0, 1) if dim == 3 else (0,):
                    e = d3 - np.array([sx * box[0] + sy * offset, sy * box[1], sz * (box[2] if dim == 3 else 0.0)])
                    if best is None or e @ e < best[0] @ best[0]:
                        best = (e, sy * 0.25 * box[1])
        if best[0] @ best[0] < (0.5 * box.min()) ** 2:
            near += 1
            assert np.allclose([dx, dy, dz], best[0], atol=1e-12)
            assert ux == pytest.approx(best[1])
    assert near > 100


def test_fold_face_keeps_the_peculiar_velocity():
    geo = _geo(np.array([10.0, 10.0, 10.0]), 0.3, 2.5)
    for y, vx in ((7.0, 1.0), (-12.0, -0.5), (4.9, 0.2)):
        x2, y2, vx2, moved = fold_face(1.0, y, vx, 0.7, geo)
        assert -5.0 <= y2 < 5.0 and y2 == pytest.approx(y - moved * 10.0)
        assert vx2 - 0.3 * y2 == pytest.approx(vx - 0.3 * y)  # c_x is the same for every image
        assert x2 == pytest.approx(1.0 - moved * image_offset(0.7, geo))


NEIGHBOURS = {"cells": {"neighbours": "cells", "cell_size": 2.0}, "list": {"neighbours": "list", "skin": 1.5}}


@pytest.mark.parametrize("mode", ["cells", "list"])
@pytest.mark.parametrize("offset", [0.0, 2.2, -6.1])
def test_predicted_pair_times_are_the_brute_force_minimum(dim, offset, mode):
    n = 300
    s = _sheared_state(dim, n, 0.3, seed=5, rate=0.8, offset=offset)
    sim = edmd.Simulation(s, shear=edmd.Shear(0.8), engine=NEIGHBOURS[mode])
    assert sim.engine.mode == mode
    ev, tag = sim.engine.ev, sim.engine.tag
    times, _dr, _dv = _sheared_pair_times(s.position, s.velocity, s.radius, s.box, 0.8, s.shear_offset)
    predicted = np.empty(n)
    predicted[tag] = ev.pair_t
    partner = np.empty(n, int)
    partner[tag] = tag[ev.pair_j]
    brute = times.min(axis=1)
    crossing = np.empty(n)
    crossing[tag] = sim.engine.ev.aux_t
    # a contact before both partners' next cell crossings (shell exits) is between neighbouring
    # cells (listed partners), through the sliding face too, so it must be the particle's
    # prediction; no prediction is early or wrong; later contacts are found at crossings (rebuilds)
    first = brute < np.minimum(crossing, crossing[times.argmin(axis=1)])
    assert first.sum() > n // 10
    assert np.allclose(predicted[first], brute[first], rtol=1e-10, atol=1e-12)
    assert np.all(predicted >= brute * (1 - 1e-10) - 1e-12)
    ok = predicted < s.box[0] / (0.8 * s.box[1])  # (the reference's images: within a box of sliding)
    assert np.allclose(times[np.flatnonzero(ok), partner[ok]], predicted[ok], rtol=1e-10, atol=1e-12)
    across = np.abs(s.position[:, None, 1] - s.position[None, :, 1]) > 0.5 * s.box[1]
    assert across[np.flatnonzero(ok), partner[ok]].sum() >= 3  # predictions through the sliding face among them


@pytest.mark.parametrize("mode", ["cells", "list"])
@pytest.mark.parametrize("e_n", [1.0, 0.8])
def test_sheared_run_matches_brute_force_beyond_a_whole_box_of_strain(dim, e_n, mode):
    # the images slide by more than L_x during the run: every collision (pairs, times) and the
    # final state (positions, lab velocities, offset) as the explicit-image reference
    n, t_end, rate = (90, 1.6, 1.0) if dim == 2 else (70, 1.2, 1.0)
    s = _sheared_state(dim, n, 0.25, seed=11, rate=rate, offset=1.0)
    assert s.shear_offset == pytest.approx(1.0) and rate * s.box[1] * t_end > s.box[0]
    sim = edmd.Simulation(s, shear=edmd.Shear(rate), e_n=e_n, engine=EngineOptions(neighbours=mode, debug=True))
    assert sim.engine.mode == mode
    sim.engine.enable_log()
    sim.run(until_time=t_end)
    log = sim.engine.take_log()
    pos, vel, ref, offset = run_sheared_reference(s.position, s.velocity, s.radius, s.mass, s.box, t_end, rate, s.shear_offset, e_n)
    ref = np.array(ref)
    assert len(ref) > 1.5 * n
    assert len(log) == len(ref)
    assert np.array_equal(np.sort(log[:, 1:3], axis=1).astype(int), ref[:, 1:].astype(int))
    assert np.abs(log[:, 0] - ref[:, 0]).max() < 1e-9
    final = sim.state
    reduced = (offset + 0.5 * s.box[0]) % s.box[0] - 0.5 * s.box[0]
    assert final.shear_offset == pytest.approx(reduced, abs=1e-9)
    d = final.position - pos
    d -= final.box * np.round(d / final.box)
    assert np.abs(d).max() < 1e-9
    assert np.abs(final.velocity - vel).max() < 1e-9


@pytest.mark.parametrize("mode", ["cells", "list"])
def test_images_keep_every_particle_in_the_box_and_the_peculiar_momentum_zero(dim, mode):
    s = _sheared_state(dim, 200, 0.2, seed=2, rate=2.0, poly=False)
    c = edmd.Shear(2.0).peculiar_velocity(s)
    s = edmd.State(s.position, s.velocity - c.mean(axis=0), s.radius, s.mass, s.box)
    sim = edmd.Simulation(s, shear=edmd.Shear(2.0), e_n=0.9, engine={"neighbours": mode})
    assert sim.engine.mode == mode
    for k in range(1, 21):
        sim.run(until_time=0.5 * k)
        st = sim.state
        st.check()  # every particle inside the box, nothing lost (N fixed) or duplicated
        assert len(np.unique(np.round(st.position, 12), axis=0)) == st.n
        p = st.mass @ edmd.Shear(2.0).peculiar_velocity(st)
        assert np.abs(p).max() < 1e-9 * st.n
        assert np.abs(sim.engine.accumulators_at(sim.time)[L.A_PX : L.A_PX + dim]).max() < 1e-9 * st.n
    assert sim.collisions > 20 * s.n


def test_sheared_state_offset_is_used_for_overlaps_and_distances():
    box = [10.0, 10.0]
    pos = [[0.0, 4.6], [2.0, -4.6]]  # 0.8 apart in y through the face; 2 apart in x, 0 through images offset by -2
    s = edmd.State(pos, np.zeros((2, 2)), 0.5, 1.0, box, shear_offset=5.0, check_overlaps=False)
    assert s.contact_ratio(0, 1) == pytest.approx(np.hypot(3.0, 0.8))  # x: 0 - (2 + 5) -> wrapped to 3
    with pytest.raises(StateError, match="overlap"):
        edmd.State(pos, np.zeros((2, 2)), 0.5, 1.0, box, shear_offset=-2.0)
    edmd.State(pos, np.zeros((2, 2)), 0.5, 1.0, box)  # 2 apart through the plain images: no overlap
    # a box too short along y for three cells: its single row of the overlap check is also the row across
    with pytest.raises(StateError, match="overlap"):
        edmd.State([[0.0, 1.0], [4.0, -1.0]], np.zeros((2, 2)), 0.5, 1.0, [10.0, 2.5], shear_offset=-4.0)
    with pytest.raises(StateError, match="periodic x and y"):
        edmd.State(pos, np.zeros((2, 2)), 0.5, 1.0, box, periodic=[True, False], shear_offset=1.0)


@pytest.mark.parametrize("mode", ["cells", "list"])
def test_pairs_across_the_sliding_face_meet_whichever_image_comes(dim, mode):
    # two particles across the face, receding from each other's nearest image: the images slide and
    # the next one comes round (review of session 12: once predicted with the nearest image only,
    # they passed through each other)
    shear = edmd.Shear(0.1)
    pos = [[0.0, 4.8, 0.0], [4.0, -4.8, 0.0]][:2] if dim == 3 else [[0.0, 4.8], [4.0, -4.8]]
    s = edmd.State([p[:dim] for p in pos], np.zeros((2, dim)), 0.5, 1.0, [10.0] * dim)
    sim = edmd.Simulation(s, shear=shear, engine={"neighbours": mode, "debug": True})
    worst = np.inf
    for k in range(1, 121):
        sim.run(until_time=0.1 * k)
        worst = min(worst, sim.state.contact_ratio(0, 1))
    assert sim.collisions >= 1 and worst > 1.0 - 1e-9


@pytest.mark.parametrize("mode", ["cells", "list"])
def test_a_dilute_sheared_gas_never_overlaps(dim, mode):
    n, eta = (300, 0.01) if dim == 3 else (300, 0.02)
    s = _sheared_state(dim, n, eta, seed=8, rate=0.05, poly=False)
    sim = edmd.Simulation(s, shear=edmd.Shear(0.05), e_n=0.9, engine={"neighbours": mode})
    assert sim.engine.mode == mode
    for k in range(1, 301):
        sim.run(until_time=2.0 * k)
        assert sim.state.overlapping_pair() is None, f"t = {sim.time}"
    assert sim.collisions > 2 * n


@pytest.mark.parametrize("rate", [1.0, -1.0])
def test_a_particle_nearly_at_rest_on_the_face_still_sees_across_it(rate):
    # review of session 13: a head-on collision leaves A on the face with v ~ 1e-20, a horizon of
    # ~1e20 whose window overflowed to no cells at all, and B across the face (at rest, never
    # rescanned) was passed through; the window is now the whole row
    s = edmd.State([[0.0, 7.2 * np.sign(rate)], [1e-20, 6.1 * np.sign(rate)], [-4.0, -7.1 * np.sign(rate)]], [[0.0, -np.sign(rate)], [0.0, 0.0], [0.0, 0.0]], 0.5, 1.0, [15.0, 15.0])
    sim = edmd.Simulation(s, shear=edmd.Shear(rate), engine={"neighbours": "cells", "cell_size": 3.0, "debug": True})
    sim.engine.enable_log()
    sim.run(until_time=0.5)
    pairs = [tuple(sorted(p)) for p in sim.engine.take_log()[:, 1:3].astype(int).tolist()]
    assert pairs[:2] == [(0, 1), (0, 2)]
