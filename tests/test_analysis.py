"""Analysis against analytic references (tolerances are justified next to each test)."""

import math

import numpy as np
import pytest

import edmd
from edmd import State
from edmd.analysis import (
    MSD,
    RDF,
    CollisionStatistics,
    HaffLaw,
    Pressure,
    Temperature,
    VelocityDistribution,
    compressibility_factor,
    contact_value,
    maxwell_speed_pdf,
    sonine_a2,
)


def _ideal_gas(dim, n, box, seed):
    """Uncorrelated uniform points (overlaps allowed: an ideal gas of points)."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-0.5, 0.5, (n, dim)) * box
    return State(position=pos, velocity=np.zeros((n, dim)), radius=1e-3, mass=1.0, box=[box] * dim, check_overlaps=False)


def _equilibrium(dim, n, eta, seed=3, **kw):
    s = edmd.maxwell_boltzmann(edmd.random_packing(n, eta, dim=dim, seed=seed), 1.0, seed=seed + 1)
    sim = edmd.Simulation(s, **kw)
    sim.run(max_events=30 * n)
    return sim


# ---------------------------------------------------------------------------- g(r)
def test_rdf_of_an_ideal_gas_is_one(dim):
    """Uniform points on a torus: the pair count in a shell has mean lambda_k = N(N-1)/2 * V_k/V and,
    since E[I_ij I_ik] = p^2 exactly on a torus, binomial variance ~lambda_k. So g_k - 1 has standard
    deviation 1/sqrt(lambda_k): every bin within 5 sigma (50 bins: false alarm ~3e-5), and the
    pooled mean over all bins within 4 sigma of 1."""
    n, box, frames = 1500, 12.0, 4
    states = [_ideal_gas(dim, n, box, seed) for seed in range(frames)]
    g = RDF(bins=50, r_max=5.0).compute(states)
    shells = np.diff(g.bin_edges ** dim) * (4 / 3 * math.pi if dim == 3 else math.pi)
    lam = frames * n * (n - 1) / 2 * shells / box**dim
    sigma = 1 / np.sqrt(lam)
    assert np.all(np.abs(g.rdf - 1) < 5 * sigma), np.max(np.abs(g.rdf - 1) / sigma)
    pooled = np.sum(g.rdf * lam) / lam.sum()
    assert abs(pooled - 1) < 4 / math.sqrt(lam.sum())
    # accumulating frame by frame is the same average
    h = RDF(bins=50, r_max=5.0)
    for s in states:
        h.compute(s, reset=False)
    assert h.frames == frames and np.allclose(h.rdf, g.rdf, rtol=1e-12)


def test_rdf_of_an_ideal_gas_between_walls_is_one(dim):
    """Uniform centres in the volume they can reach in a box closed by walls on every axis but x:
    the pair-distance weights (1 - |x_k|/L_k) make g = 1 on average (the bulk normalisation gave
    0.74-0.81 at r = 4-5 in this 12-diameter box). Over 30 seeds the mean of g over 1.5 < r < 5 scatters
    by 0.5-0.7 % (a finite box is not a torus: pair counts are not binomial): 3.5 % is 5 sigma;
    the outer bins alone (4 < r < 5, ~30 % of the pairs) get 5 %."""
    n, box, radius = 1500, 12.0, 0.5
    periodic = [True] + [False] * (dim - 1)
    reach = np.where(periodic, box, box - 2 * radius)
    rng = np.random.default_rng(4)
    states = [State(position=rng.uniform(-0.5, 0.5, (n, dim)) * reach, velocity=np.zeros((n, dim)), radius=radius, mass=1.0,
                    box=[box] * dim, periodic=periodic, check_overlaps=False) for _ in range(4)]  # fmt: skip
    g = RDF(bins=50, r_max=5.0).compute(iter(states))  # a generator of frames works too
    assert g.frames == 4
    assert abs(g.rdf[g.bin_centers > 1.5].mean() - 1) < 0.035
    assert abs(g.rdf[g.bin_centers > 4.0].mean() - 1) < 0.05
    closed = State(position=np.zeros((1, dim)), velocity=np.zeros((1, dim)), radius=radius, mass=1.0, box=[4.0] * dim, periodic=[False] * dim)
    with pytest.raises(ValueError, match="between walls"):
        RDF(r_max=3.5).compute(closed)


def test_rdf_agrees_with_freud(dim):
    freud = pytest.importorskip("freud")
    s = _ideal_gas(dim, 800, 10.0, 7)
    ours = RDF(bins=40, r_max=4.0).compute(s)
    box = freud.box.Box.from_box(s.freud_box)
    theirs = freud.density.RDF(bins=40, r_max=4.0, normalization_mode="exact").compute((box, s.points))
    # freud bins single-precision distances: a pair within ~1e-6 of a bin edge may change bins
    assert np.allclose(ours.rdf, theirs.rdf, atol=2e-3)


def test_sheared_rdf_agrees_with_freud_through_the_tilted_box(dim):
    # a sheared state's freud_box is the triclinic box of its sliding images: freud's g(r) is ours
    freud = pytest.importorskip("freud")
    shear = edmd.Shear(0.5)
    sim = edmd.Simulation(shear.with_profile(edmd.maxwell_boltzmann(edmd.random_packing(800, 0.2, dim=dim, seed=3), 1.0, seed=4)), shear=shear)
    sim.run(until_time=2.3)
    s = sim.state
    assert abs(s.shear_offset) > 1.0
    ours = RDF(bins=40, r_max=4.0).compute(s)
    tilted = freud.density.RDF(bins=40, r_max=4.0, normalization_mode="exact").compute((freud.box.Box.from_box(s.freud_box), s.points))
    plain = freud.density.RDF(bins=40, r_max=4.0, normalization_mode="exact").compute((freud.box.Box.from_box(s.box.tolist()), s.points))
    assert np.allclose(ours.rdf, tilted.rdf, atol=4e-3)  # (freud's single-precision bins, as above)
    assert np.abs(ours.rdf - plain.rdf).max() > 0.02  # (plain images give another g(r): the test can tell)


def test_rdf_input_errors():
    s = _ideal_gas(3, 10, 4.0, 1)
    with pytest.raises(ValueError, match="exceeds half the shortest periodic box length"):
        RDF(r_max=3.0).compute(s)
    with pytest.raises(TypeError, match="expected a State"):
        RDF().compute(42)


@pytest.mark.parametrize("dim, eta", [(3, 0.3), (2, 0.4)], ids=["3d", "2d"])
def test_contact_value_is_consistent_with_the_pressure(dim, eta):
    """Z = 1 + 2^(d-1) eta g(sigma+) (physics.md §5.2) with Z from the collision virial and g(sigma+)
    extrapolated from g(r). 40 frames of 2000 particles put ~7000 (3D) pairs in each 0.01 sigma bin
    at contact (1.2 % each); the quadratic extrapolation over 15 bins gives g(sigma+) to ~1 %, the
    pressure is known to ~0.5 %: 3 % is about three standard deviations."""
    n = 2000
    sim = _equilibrium(dim, n, eta)
    th = sim.add(edmd.Thermo(0.2))
    frames = []
    sim.add(edmd.Callback(lambda s, tot: frames.append(s), interval=0.2))
    sim.run(until_time=sim.time + 8.0)
    g = RDF(bins=200, r_max=2.0).compute(frames)
    z_g = compressibility_factor(eta, dim, g.contact_value(sigma=1.0))
    z_p = Pressure().compute(th, state=frames[0]).compressibility
    assert z_g == pytest.approx(z_p, rel=0.03)
    assert z_p == pytest.approx(compressibility_factor(eta, dim), rel=0.02)


def test_contact_value_needs_enough_bins():
    g = RDF(bins=10, r_max=2.0).compute(_ideal_gas(3, 100, 6.0, 2))
    with pytest.raises(ValueError, match="bins lie in"):
        g.contact_value(sigma=1.0)


# ---------------------------------------------------------------------------- velocities
def test_sonine_a2_of_a_maxwellian_is_zero(dim):
    """For N independent Maxwellian speeds a2 has standard deviation sqrt(8/(d(d+2)N)) (delta method
    on the chi^2_d moments: Var(c^2) = 2d, Var(c^4) = 8d(d+2)(d+3), Cov = 4d(d+2)): 4 sigma."""
    s = edmd.maxwell_boltzmann(edmd.lattice(20000, 0.1, dim=dim), kT=2.5, seed=11)
    vd = VelocityDistribution(bins=40).compute(s)
    assert vd.a2_error == pytest.approx(math.sqrt(8 / (dim * (dim + 2) * vd.samples)))
    assert abs(vd.a2) < 4 * vd.a2_error
    assert vd.temperature == pytest.approx(2.5, rel=1e-12)
    # the histogram is a density and follows Maxwell within Poisson noise
    width = np.diff(vd.bin_edges)
    assert np.sum(vd.pdf * width) == pytest.approx(1.0, abs=1e-4)
    expected = vd.maxwell * width * vd.samples
    big = expected > 100
    assert np.all(np.abs(vd.pdf * width * vd.samples - expected)[big] < 5 * np.sqrt(expected[big]) + 0.05 * expected[big])


def test_sonine_a2_of_a_single_speed_is_exact(dim):
    # <c^4>/<c^2>^2 = 1 for one speed: a2 = d/(d+2) - 1 = -2/(d+2)
    assert sonine_a2(np.full(7, 3.3), dim) == pytest.approx(-2 / (dim + 2), abs=1e-14)


def test_maxwell_reference_is_normalised(dim):
    c = np.linspace(0, 12, 200001)
    assert np.trapezoid(maxwell_speed_pdf(c, dim), c) == pytest.approx(1.0, abs=1e-9)
    mean_c2 = np.trapezoid(c**2 * maxwell_speed_pdf(c, dim), c)
    assert mean_c2 == pytest.approx(dim, abs=1e-8)


def test_temperatures(dim):
    s = edmd.maxwell_boltzmann(edmd.lattice(300, 0.2, dim=dim), kT=0.7, seed=2, spin=True)
    t = Temperature().compute(s)
    assert t.translational == pytest.approx(0.7, rel=1e-12)
    assert t.rotational == pytest.approx(0.7, rel=1e-12)
    assert t.rotational_energy == pytest.approx(0.5 * (3 if dim == 3 else 1) * 300 * 0.7, rel=1e-12)


# ---------------------------------------------------------------------------- MSD
def test_msd_of_free_flight_is_v2_t2(tmp_path, dim):
    """Particles on separate lanes (y spacing > sigma) with a common transverse velocity never collide;
    they cross the periodic box many times, so the unwrapping with images is exercised.
    MSD(t) = <|v|^2> t^2 up to round-off."""
    n, box = 8, 10.0
    rng = np.random.default_rng(3)
    pos = np.zeros((n, dim))
    pos[:, 0] = rng.uniform(-5, 5, n)
    pos[:, 1] = -box / 2 + (np.arange(n) + 0.5) * box / n
    vel = np.zeros((n, dim))
    vel[:, 0] = rng.normal(0, 2, n)
    vel[:, 1:] = [0.7, 0.3][: dim - 1]
    s = State(position=pos, velocity=vel, radius=0.5, mass=1.0, box=[box] * dim)
    sim = edmd.Simulation(s)
    sim.add(edmd.Trajectory(tmp_path / "t.gsd", interval=2.0))
    sim.run(until_time=60.0)
    sim.close()
    assert sim.collisions == 0
    assert np.abs(sim.state.image).max() >= 10
    v2 = np.mean(np.sum(vel**2, axis=1))
    for mode in ("window", "direct"):
        m = MSD(mode).compute(tmp_path / "t.gsd")
        assert np.allclose(m.msd, v2 * m.lag_times**2, rtol=1e-9, atol=1e-9), mode


def test_msd_reads_frames_one_at_a_time():
    """A 'direct' MSD keeps only the first frame's positions: at most two States (the one being read
    and the one just dropped) are alive while it consumes a stream of frames."""
    import gc
    import weakref

    s = edmd.maxwell_boltzmann(edmd.lattice(64, 0.1), 1.0, seed=1)
    alive, most = [], []

    def frames():
        for k in range(20):
            f = s.copy()
            f.position, f.time = s.position, float(k)
            f.image = s.image + k
            alive.append(weakref.ref(f))
            gc.collect()
            most.append(sum(r() is not None for r in alive))
            yield f
            del f

    m = MSD("direct").compute(frames())
    assert max(most) <= 2
    assert np.allclose(m.msd, m.lag_times**2 * np.sum(s.box**2))


def test_msd_diffusion_coefficient_of_a_random_walk(dim):
    """Gaussian steps of variance 2 D dt per axis: MSD = 2 d D t. With 2000 walkers and 60 frames the
    relative error of D (measured over 20 seeds) is 2.5 % for the default fit over the second half of
    the lags (few independent time origins) and 0.8 % over lags 1-10: 10 % and 4 % (4-5 sigma)."""
    rng = np.random.default_rng(5)
    n, frames, dt, d_true, box = 2000, 60, 0.5, 0.3, 20.0
    walk = np.cumsum(rng.normal(0, math.sqrt(2 * d_true * dt), (frames, n, dim)), axis=0)
    states = []
    for k, r in enumerate(walk):
        image = np.floor((r + box / 2) / box).astype(np.int64)
        states.append(State(position=r - image * box, velocity=np.zeros((n, dim)), radius=1e-3, mass=1.0,
                            box=[box] * dim, time=k * dt, image=image, check_overlaps=False))  # fmt: skip
    m = MSD().compute(states)
    assert m.diffusion_coefficient == pytest.approx(d_true, rel=0.10)
    assert m.fit(dt, 10 * dt) == pytest.approx(d_true, rel=0.04)
    states[3].time += 0.1
    with pytest.raises(ValueError, match="equally spaced"):
        MSD().compute(states)
    with pytest.raises(ValueError, match="at least two frames"):
        MSD().compute(states[:1])


# ---------------------------------------------------------------------------- collisions, pressure, Haff
def test_collision_statistics_of_an_equilibrium_fluid(dim):
    """In equilibrium positions and velocities are independent, so the collision kernel is exactly
    |g.n| f(v1) f(v2): impact angles follow sin(2 theta) (3D) / cos(theta) (2D) and the mean normal
    impact speed is sqrt(pi T/m). With ~6e4 collisions the sample means have relative errors of
    ~0.3 %: 2 % tolerance (recollisions correlate successive collisions a little)."""
    n = 1000
    sim = _equilibrium(dim, n, 0.25)
    th = sim.add(edmd.Thermo(1.0))
    sim.engine.enable_log(capacity=4096)
    t0 = sim.time
    sim.run(until_time=t0 + (15.0 if dim == 3 else 70.0))
    cs = CollisionStatistics().compute(sim.engine.take_log(), n=n, duration=sim.time - t0)
    assert cs.collisions > 50_000
    assert cs.collisions == sim.collisions - th.rows[0]["collisions"]
    rate = np.mean(th.table()["collision_rate"][1:])
    assert cs.collision_rate == pytest.approx(rate, rel=1e-9)
    assert cs.mean_free_time == pytest.approx(1 / rate, rel=1e-9)
    mean_angle = math.pi / 4 if dim == 3 else math.pi / 2 - 1
    assert np.mean(cs.impact_angles) == pytest.approx(mean_angle, rel=0.02)
    assert np.mean(cs.impact_speeds) == pytest.approx(math.sqrt(math.pi), rel=0.02)
    assert np.sum(cs.angle_pdf * np.diff(cs.angle_edges)) == pytest.approx(1.0)
    assert cs.free_times.size > 0 and np.all(cs.free_times >= 0)


def test_collision_statistics_errors():
    with pytest.raises(ValueError, match="empty"):
        CollisionStatistics().compute(np.zeros((0, 5)), n=10)
    with pytest.raises(ValueError, match="rows"):
        CollisionStatistics().compute(np.zeros((3, 4)), n=10)


def test_haff_reference_numbers_w7():
    # physics.md §5.4 W7
    h3 = HaffLaw(e_n=0.9, dim=3, density=0.190986, sigma=1.0, kT0=1.0, eta=0.1)
    assert h3.tau0 == pytest.approx(17.896383, rel=2e-6)
    h2 = HaffLaw(e_n=0.9, dim=2, density=0.381972, sigma=1.0, kT0=1.0, eta=0.3)
    assert h2.tau0 == pytest.approx(8.769430, rel=2e-6)
    assert h3(h3.tau0) == pytest.approx(0.25)
    assert contact_value(0.1, 3) == pytest.approx(1.303155, abs=1e-6)
    with pytest.raises(ValueError, match="needs a positive initial temperature kT0, got 0.0"):
        HaffLaw(e_n=0.9, dim=3, density=0.19, sigma=1.0, kT0=0.0, eta=0.1)


def test_haff_law_describes_a_cooling_gas():
    """3D, N = 2000, eta = 0.1, e_n = 0.9 from an equilibrated elastic fluid, over T/T0 = 1 -> 0.25.
    physics.md §5.4 found agreement within 1-2 % for N = 1000 (noise, velocity correlations, a2):
    3 % tolerance."""
    n = 2000
    hot = _equilibrium(3, n, 0.1).state
    sim = edmd.Simulation(hot, e_n=0.9)
    th = sim.add(edmd.Thermo(2.0))
    haff = HaffLaw.from_state(hot, e_n=0.9)
    sim.run(until_time=hot.time + haff.tau0)
    table = th.table()
    assert table["temperature"][-1] < 0.3
    assert np.allclose(table["temperature"], haff(table["time"]), rtol=0.03)


def test_pressure_from_thermo_files(tmp_path):
    sim = _equilibrium(3, 500, 0.2)
    sim.add(edmd.Thermo(0.5, path=tmp_path / "thermo.csv"))
    sim.run(until_time=sim.time + 10.0)
    sim.close()
    s = sim.state
    p = Pressure(t_min=0.0).compute(tmp_path / "thermo.csv", state=s)
    assert p.time.size == 20 and np.isfinite(p.error)
    assert p.compressibility == pytest.approx(p.mean / (s.n / s.volume * p.temperature))
    assert math.isnan(Pressure().compute(tmp_path / "thermo.csv").compressibility)
    with pytest.raises(ValueError, match="no thermo rows"):
        Pressure(t_min=1e9).compute(tmp_path / "thermo.csv")


def test_pair_histogram_sees_the_sliding_images():
    # a sheared state (Lees-Edwards images offset along x): every pair's distance through the
    # nearest sliding image, as a brute-force count over all pairs; the plain images would see overlaps
    from edmd.analysis.structure import pair_histogram

    shear = edmd.Shear(1.0)
    s = edmd.maxwell_boltzmann(edmd.random_packing(600, 0.3, seed=1), 1.0, seed=2)
    sim = edmd.Simulation(shear.with_profile(s), shear=shear)
    sim.run(until_time=1.7)
    st = sim.state
    assert abs(st.shear_offset) > 1.0
    p, box, off = st.points, np.asarray(st.box, float), st.shear_offset
    d = p[:, None, :] - p[None, :, :]
    sy = np.rint(d[..., 1] / box[1])
    d[..., 1] -= sy * box[1]
    d[..., 0] -= sy * off
    d[..., 0] -= box[0] * np.rint(d[..., 0] / box[0])
    d[..., 2] -= box[2] * np.rint(d[..., 2] / box[2])
    r = np.sqrt((d**2).sum(-1))[np.triu_indices(st.n, 1)]
    reference = np.histogram(r[r < 3.0], bins=30, range=(0.0, 3.0))[0]
    assert np.array_equal(pair_histogram(p, box, np.ones(3, np.bool_), 3.0, 30, off), reference)
    assert reference[:10].sum() == 0  # (no overlaps through the sliding images)
    assert pair_histogram(p, box, np.ones(3, np.bool_), 3.0, 30, 0.0)[:10].sum() > 0
