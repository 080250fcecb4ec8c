"""Event-time predictors against physics.md §1.2-§1.4 (T1-T3, T13) and brute-force root finding."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edmd._core.predict import INF, contact_time, gap_time, pending_contact_time, sliding_contact_time, sphere_exit_time


def test_t1_pair_time_worked_example():
    # physics.md W1 / T1: r_ij = (3,1,0), g = (-1,0,0), sigma = 2  ->  3 - sqrt(3)
    assert contact_time(3.0, 1.0, 0.0, -1.0, 0.0, 0.0, 2.0) == pytest.approx(3 - math.sqrt(3), rel=1e-15, abs=0)
    assert contact_time(3.0, 1.0, 0.0, -1.0, 0.0, 0.0, 2.0) == 1.2679491924311228


@pytest.mark.parametrize("dx", [3.0, 1.5])  # separated, and overlapping
def test_t2_receding_pairs_never_collide(dx):
    assert contact_time(dx, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0) == INF
    assert contact_time(dx, 0.0, 0.0, 0.0, 1.0, 0.0, 2.0) == INF  # tangential: b = 0


def test_t3_overlapping_and_approaching_collide_now():
    assert contact_time(1.5, 0.0, 0.0, -1.0, 0.0, 0.0, 2.0) == 0.0


def test_miss_gives_no_event():
    assert contact_time(3.0, 2.5, 0.0, -1.0, 0.0, 0.0, 2.0) == INF


def test_near_contact_is_free_of_cancellation():
    # gap 1e-13 closing at speed 1: naive (-b - sqrt(disc))/a loses every digit here
    gap = 1e-13
    t = contact_time(2.0 + gap, 0.0, 0.0, -1.0, 0.0, 0.0, 2.0)
    assert t == pytest.approx(gap, rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(-5, 5), min_size=3, max_size=3),
    st.lists(st.floats(-3, 3), min_size=3, max_size=3),
    st.floats(0.5, 2.0),
    st.one_of(st.just(0), st.integers(-170, 0)),
)
def test_contact_time_solves_the_contact_equation(r, g, sigma, speed_exponent):
    # speeds down to 1e-170 reach the underflow of |g|^2: there the time is infinite or exact
    r, g = np.array(r), np.array(g) * 10.0**speed_exponent
    t = contact_time(*r, *g, sigma)
    if r @ r <= sigma**2 or not np.isfinite(t):
        return
    assert t >= 0
    assert np.linalg.norm(r + g * t) == pytest.approx(sigma, rel=1e-9)
    # and no earlier contact: the distance is above sigma on a fine grid before t
    s = np.linspace(0, t, 50)[:-1]
    assert np.all(np.linalg.norm(r[None] + g[None] * s[:, None], axis=1) >= sigma * (1 - 1e-9))


def test_underflowing_relative_speed_gives_no_event():
    # found by hypothesis: |g|^2 underflows to 0 and b^2 to a denormal, which gave a finite time
    # (~1e162) whose contact missed sigma by 1.65; the exact contact is ~1e162 time units away
    assert contact_time(0.0, 3.0, 0.0, 0.0, -7.6e-163, 0.0, 2.0) == INF
    # a speed 1e-140 is still resolved exactly: the gap 1 closes in 1e140
    assert contact_time(0.0, 3.0, 0.0, 0.0, -1e-140, 0.0, 2.0) == pytest.approx(1e140, rel=1e-12)


def _first_contact_by_sampling(r0, g, sigma, jumps, horizon=6.0, step=2e-4):
    """The first time the separation of a piecewise-straight relative flight (velocity jumps
    ``(time, dv)``) comes within ``sigma``: sampled, then bisected (``inf``: none before ``horizon``)."""

    def separation(t):
        r = r0 + np.multiply.outer(t, g)
        for tb, dv in jumps:
            r = r + np.multiply.outer(np.clip(t - tb, 0.0, None), dv)
        return np.linalg.norm(r, axis=-1) - sigma

    t = np.arange(0.0, horizon, step)
    inside = np.flatnonzero(separation(t) <= 0.0)
    if inside.size == 0:
        return INF
    lo, hi = t[inside[0] - 1], t[inside[0]]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if separation(np.array(mid)) <= 0.0 else (mid, hi)
    return hi


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("order", ["i first", "j first", "same time", "only i", "only j", "none"])
def test_pending_contact_time_follows_the_velocity_jumps(dim, order):
    """physics.md §4.8 (predictions across B events): the relative velocity jumps by +Delta_i at
    t_i and by -Delta_j at t_j; the contact is the first root of the piecewise flight, checked
    against sampling it."""
    rng = np.random.default_rng(11 + dim)
    times = {"i first": (0.4, 1.1), "j first": (1.2, 0.3), "same time": (0.7, 0.7), "only i": (0.6, INF), "only j": (INF, 0.5), "none": (INF, INF)}[order]
    found = 0
    for _ in range(60):
        r0, g, a, b = (np.zeros(3) for _ in range(4))
        r0[:dim] = rng.uniform(-3.0, 3.0, dim)
        g[:dim], a[:dim], b[:dim] = rng.normal(0.0, 0.6, (3, dim))
        g -= r0 * rng.uniform(0.1, 1.0)  # (mostly approaching, so that many pairs meet)
        sigma = rng.uniform(0.5, 1.5)
        if np.linalg.norm(r0) <= sigma * 1.05:
            continue
        jumps = [(tb, dv) for tb, dv in zip(times, (a, -b)) if tb < INF]
        expected = _first_contact_by_sampling(r0, g, sigma, jumps)
        got = pending_contact_time(*r0, *g, sigma, times[0], *a, times[1], *b)
        if expected == INF:
            assert got >= 6.0 - 1e-6
        else:
            assert got == pytest.approx(expected, abs=1e-9)
            found += 1
    assert found >= 15


def test_pending_contact_time_without_jumps_is_contact_time():
    args = (2.5, 0.4, -0.3, -1.0, 0.1, 0.2, 1.0)
    assert pending_contact_time(*args, INF, 1.0, 2.0, 3.0, INF, -1.0, 0.5, 0.0) == contact_time(*args)


def test_sliding_contact_time_is_the_earliest_contact_over_the_images():
    """Across a sliding face the partner's x images (period L_x) slide by: the predictor visits only
    the tubes its motion reaches, in order; the reference tries every image within 400 boxes."""
    rng = np.random.default_rng(7)
    met = 0
    for _ in range(3000):
        d = rng.normal(size=3) * rng.uniform(0.5, 4.0)
        g = rng.normal(size=3) * rng.uniform(0.1, 3.0)
        if rng.random() < 0.2:
            g[1:] = 0.0  # motion along x only
        g[0] += rng.choice([-1.0, 1.0]) * rng.uniform(0.0, 20.0)  # the shear's sliding speed
        sigma, lx = rng.uniform(0.5, 1.5), rng.uniform(3.5, 12.0)
        reference = min(contact_time(d[0] - k * lx, d[1], d[2], *g, sigma) for k in range(-400, 401))
        t = sliding_contact_time(*d, *g, sigma, lx, math.inf)
        if reference < INF:
            assert t == reference
            met += 1
        else:  # (a contact with an image beyond 400 boxes is not expected at these speeds)
            assert t == INF
    assert met > 300


def test_sliding_contact_time_ends_for_slow_and_far_approaches():
    # motion along x only: the next image is met (docstring), and with |g|^2 underflowing never,
    # after the tube ahead (the loop visited images for ever once contact_time gave inf for them)
    assert sliding_contact_time(0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 10.0, INF) == 8.5
    assert sliding_contact_time(0.5, 0.0, 0.0, 1e-163, 0.0, 0.0, 1.0, 10.0, INF) == INF
    # (y, z) just outside the disc, closing at 1e-150 while sliding at 1: the disc is entered
    # ~2e149 later, 2e148 images on, where the images are no longer resolved; an approach at 1e-3
    # starts at the image it reaches (~2e1 boxes on) instead of visiting every one before it
    assert sliding_contact_time(0.5, 1.2, 0.0, 1.0, -1e-150, 0.0, 1.0, 10.0, INF) == INF
    t = sliding_contact_time(0.5, 1.2, 0.0, 1.0, -1e-3, 0.0, 1.0, 10.0, INF)
    k = round((0.5 + t) / 10.0)
    assert t < INF and t == contact_time(0.5 - k * 10.0, 1.2, 0.0, 1.0, -1e-3, 0.0, 1.0)


def test_t13_dropped_ball_and_bounce():
    # physics.md T13: dropped from gap h0 with u = 0 under |G|: first hit sqrt(2 h0/|G|)
    h0, G = 0.7, 9.81
    assert gap_time(h0, 0.0, -G) == pytest.approx(math.sqrt(2 * h0 / G), rel=1e-14)
    # right after an elastic bounce (h0 = 0, u > 0): next hit 2u/|G| later, no spurious zero root
    u = 3.0
    assert gap_time(0.0, u, -G) == pytest.approx(2 * u / G, rel=1e-14)


@pytest.mark.parametrize(
    "h0, u, a, expected",
    [
        (1.0, -2.0, 0.0, 0.5),  # no field
        (1.0, 2.0, 0.0, INF),  # moving away
        (-1e-15, -1.0, 0.0, 0.0),  # round-off overlap, closing
    ],
)
def test_gap_time_without_field(h0, u, a, expected):
    assert gap_time(h0, u, a) == expected


def test_gap_time_pushed_away_from_plane():
    # a > 0: reached only if approaching fast enough: h = 1 - t + t^2/2 * 0.4 has a root
    assert gap_time(1.0, -1.0, 0.4) == pytest.approx((1 - math.sqrt(1 - 0.8)) / 0.4, rel=1e-14)
    assert gap_time(1.0, -1.0, 1.0) == INF  # turns around before reaching it
    assert gap_time(1.0, 1.0, 1.0) == INF


@settings(max_examples=300, deadline=None)
@given(st.floats(0.0, 3.0), st.floats(-3, 3), st.floats(-3, 3).filter(lambda a: a == 0 or abs(a) > 1e-6))
def test_gap_time_is_the_first_closing_root(h0, u, a):
    t = gap_time(h0, u, a)
    h = lambda s: h0 + u * s + 0.5 * a * s * s  # noqa: E731
    if t == INF:
        s = np.linspace(0, 50, 20001)
        assert np.all(h(s) > -1e-9) or h0 == 0.0
        return
    assert abs(h(t)) <= 1e-9 * max(1.0, h0, abs(u) * t, abs(a) * t * t)
    assert u + a * t <= 1e-9  # closing (or grazing) at the event
    s = np.linspace(0, t, 200)[1:-1]
    assert np.all(h(s) >= -1e-9)


def test_sphere_exit_time():
    # from the centre with speed 2: leaves the ball of radius 1 after 0.5
    assert sphere_exit_time(0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 1.0) == 0.5
    # from near the surface moving outwards: tiny, cancellation-free
    t = sphere_exit_time(1.0 - 1e-12, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0)
    assert t == pytest.approx(1e-12, rel=1e-6)
    # moving inwards from x = 0.5: crosses the whole ball, t = 1.5
    assert sphere_exit_time(0.5, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0) == 1.5
    assert sphere_exit_time(0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0) == INF
