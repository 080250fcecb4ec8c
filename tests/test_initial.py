"""Initial states: lattices, random packings, radius distributions, Maxwell-Boltzmann velocities."""

import re

import numpy as np
import pytest

import edmd
from edmd import StateError, lattice, maxwell_boltzmann, radii, random_packing, replicate


@pytest.mark.parametrize("kind_by_dim", [0, 1])
@pytest.mark.parametrize("n", [1, 50, 500])
def test_lattice_packing_fraction_and_no_overlap(dim, kind_by_dim, n):
    kind = {2: ("hex", "square"), 3: ("fcc", "sc")}[dim][kind_by_dim]
    s = lattice(n, 0.3, dim=dim, kind=kind)
    assert s.n == n
    assert s.packing_fraction == pytest.approx(0.3, rel=1e-12)
    assert s.overlapping_pair() is None


def test_perfect_fcc_is_the_requested_lattice():
    s = lattice(4 * 5**3, 0.5, dim=3, kind="fcc")
    # nearest-neighbour distance of fcc with a^3 = 4 v / eta
    a = (4 * (np.pi / 6) / 0.5) ** (1 / 3)
    d = s.position[1:] - s.position[0]
    d -= s.box * np.round(d / s.box)
    assert np.linalg.norm(d, axis=1).min() == pytest.approx(a / np.sqrt(2), rel=1e-12)


@pytest.mark.parametrize("dim, kind, eta", [(3, "fcc", 0.75), (3, "sc", 0.6), (2, "square", 0.8), (2, "hex", 0.92)])
def test_impossible_lattice_packing_is_explained(dim, kind, eta):
    with pytest.raises(StateError, match="cannot be built"):
        lattice(100, eta, dim=dim, kind=kind)


@pytest.mark.parametrize("eta", [0.0, 1.0, -0.1, 1.5])
def test_packing_fraction_out_of_range(dim, eta):
    with pytest.raises(StateError, match="packing fraction must be in"):
        random_packing(10, eta, dim=dim)


def test_random_packing_polydisperse(dim):
    s = random_packing(300, 0.2, dim=dim, radius={"kind": "uniform", "min": 0.3, "max": 0.7}, density=2.0, seed=3)
    assert s.overlapping_pair() is None
    assert s.packing_fraction == pytest.approx(0.2, rel=1e-12)
    vol = 4 / 3 * np.pi * s.radius**3 if dim == 3 else np.pi * s.radius**2
    assert np.allclose(s.mass, 2.0 * vol)
    assert 0.3 <= s.radius.min() and s.radius.max() <= 0.7


def _brute_overlap(s):
    """The deepest relative overlap of any pair (nearest image), by numpy over all pairs."""
    d = s.position[:, None, :] - s.position[None, :, :]
    d -= np.where(s.periodic, s.box * np.round(d / s.box), 0.0)
    depth = 1.0 - np.sqrt((d * d).sum(-1)) / (s.radius[:, None] + s.radius[None, :])
    np.fill_diagonal(depth, -np.inf)
    return depth.max()


@pytest.mark.parametrize("eta", [0.1, 0.4])
def test_random_packing_with_an_intruder(dim, eta):
    """An intruder of size ratio 10 among 2000 (insertion at eta = 0.1; relaxation at 0.4, where
    the intruder's many overlaps at the start need the damped steps): placed without overlaps."""
    n = 2000
    s = random_packing(n, eta, dim=dim, radius={"kind": "discrete", "values": [0.5, 5.0], "fractions": [n - 1, 1]}, seed=4)
    assert s.radius.max() == 5.0 and np.count_nonzero(s.radius == 5.0) == 1
    assert s.packing_fraction == pytest.approx(eta, rel=1e-12)
    assert _brute_overlap(s) <= 0.0


def test_random_packing_too_dense_fails_clearly():
    with pytest.raises(StateError, match="random insertion failed"):
        random_packing(500, 0.6, dim=3, max_attempts=50, method="insert")


def test_reproducible_from_seed(dim):
    a = maxwell_boltzmann(random_packing(100, 0.1, dim=dim, seed=7), 1.0, seed=8)
    b = maxwell_boltzmann(random_packing(100, 0.1, dim=dim, seed=7), 1.0, seed=8)
    c = maxwell_boltzmann(random_packing(100, 0.1, dim=dim, seed=7), 1.0, seed=9)
    assert np.array_equal(a.position, b.position) and np.array_equal(a.velocity, b.velocity)
    assert not np.array_equal(a.velocity, c.velocity)


def test_maxwell_boltzmann(dim):
    s = lattice(4000, 0.2, dim=dim, radius={"kind": "discrete", "values": [0.4, 0.5], "fractions": [1, 1]}, density=1.0)
    s = maxwell_boltzmann(s, 2.5, seed=1, spin=True)
    assert s.temperature() == pytest.approx(2.5, rel=1e-12)
    assert np.abs(s.momentum()).max() < 1e-10
    # equipartition between species: <m v^2> per component equal for small and large
    small = s.radius == 0.4
    e = (s.mass[:, None] * s.velocity**2).mean(axis=1)
    assert e[small].mean() == pytest.approx(e[~small].mean(), rel=0.06)
    dof = 3 if dim == 3 else 1
    w2 = s.angular_velocity**2 if dim == 2 else (s.angular_velocity**2).sum(axis=1)
    assert np.sum(s.inertia * w2) / (dof * s.n) == pytest.approx(2.5, rel=1e-12)


@pytest.mark.parametrize(
    "spec, match",
    [
        ({"kind": "uniform", "min": 0.5}, "needs the key 'max'"),
        ({"kind": "gamma"}, "unknown radius distribution"),
        ({"kind": "uniform", "min": 0.5, "max": 0.4}, "min <= max"),
        ({"kind": "normal", "mean": 1, "std": 0.1, "sd": 1}, "unknown keys"),
        (-1.0, "radius must be positive"),
        (np.full(10, 0.5), "a number or a distribution dict"),  # (was a TypeError from dict())
        ({"kind": "normal", "mean": 0.5, "std": 0.5}, "normal radii need std <= mean / 3"),  # (16 % were clipped to 1e-3 mean)
    ],
)
def test_bad_radius_distributions(spec, match):
    with pytest.raises(StateError, match=match):
        radii(10, spec)


def test_radius_distributions_statistics():
    rng = np.random.default_rng(0)
    r = radii(100000, {"kind": "lognormal", "mean": 0.5, "std": 0.05}, rng)
    assert r.mean() == pytest.approx(0.5, rel=0.01) and r.std() == pytest.approx(0.05, rel=0.03)
    r = radii(100000, {"kind": "normal", "mean": 0.5, "std": 0.05}, rng)
    assert r.mean() == pytest.approx(0.5, rel=0.01) and r.min() >= 0.35


@pytest.mark.parametrize("n", [1.5, "100", True])
def test_particle_number_must_be_a_whole_number(n):
    for make in (edmd.lattice, edmd.random_packing):
        with pytest.raises(edmd.StateError, match="n must be a whole number of particles"):
            make(n, 0.1)


def test_maxwell_boltzmann_refuses_a_temperature_for_one_particle(dim):
    one = edmd.lattice(1, 0.01, dim=dim)
    with pytest.raises(edmd.StateError, match="single particle .* cannot have a temperature"):
        edmd.maxwell_boltzmann(one, 1.0)
    assert np.all(edmd.maxwell_boltzmann(one, 0.0).velocity == 0.0)


def test_a_lattice_between_walls_names_its_own_limit():
    # squeezed to fit between the walls, the sites touch below close packing (0.7405): the message
    # once gave the periodic spacing (1.019 > 1) and limit (0.7405 > 0.7) for a refused 0.7
    with pytest.raises(StateError, match=r"squeezed between the walls\) but their particles need 1 \(they touch near packing fraction (0\.\d+)") as err:
        lattice(256, 0.7, periodic=[False] * 3)
    near = float(re.search(r"near packing fraction (0\.\d+)", str(err.value)).group(1))
    assert 0.55 < near < 0.7
    lattice(256, 0.97 * near, periodic=[False] * 3)  # (builds)


def test_polydisperse_lattice_returns_the_arrangement_it_checked():
    # 3 large (R = 0.5) among 29 small (R = 0.3) fcc sites: sites are 0.8-1.0 apart, so an arrangement
    # is valid iff no two large ones are neighbours. Every seed either gives a valid state or the
    # explanation; the radii used to be shuffled again after the check (raw overlap errors)
    outcomes = set()
    for seed in range(40):
        try:
            s = lattice(32, 0.35, radius={"kind": "discrete", "values": [0.5, 0.3], "fractions": [0.1, 0.9]}, seed=seed)
            assert s.overlapping_pair() is None
            outcomes.add("built")
        except StateError as exc:
            assert "cannot be built on a fcc lattice" in str(exc)
            outcomes.add("explained")
    assert outcomes == {"built", "explained"}


def test_replicate_tiles_a_packing_without_overlaps(dim):
    """The copies of a packing whose pairs touch through the periodic faces: no overlap, the same
    packing fraction, every particle inside the new box, each copy shifted as the docstring says."""
    base = maxwell_boltzmann(random_packing(300, 0.5, dim=dim, seed=4, radius={"kind": "uniform", "min": 0.4, "max": 0.6}), 1.0, seed=5, spin=True)
    counts = [3, 1, 2][:dim]
    s = replicate(base, counts)
    assert s.n == 300 * int(np.prod(counts)) and np.array_equal(s.box, base.box * counts)
    assert abs(s.packing_fraction - base.packing_fraction) < 1e-14
    assert s.overlapping_pair(1e-12) is None
    assert np.all(np.abs(s.position) <= 0.5 * s.box)
    last = s.n - 300  # the last copy, (2, 0, 1) in 3D, (2, 0) in 2D: shifted by a - (c - 1) / 2 base boxes (up to whole new boxes)
    shift = ((s.position[last:] - base.position) / base.box - (np.array([2, 0, 1][:dim]) - 0.5 * (np.array(counts) - 1))) / counts
    assert np.allclose(shift - np.round(shift), 0.0, atol=1e-12)
    for name in ("velocity", "radius", "mass", "inertia", "angular_velocity"):
        assert np.array_equal(getattr(s, name)[last:], getattr(base, name)), name
    assert not np.any(s.image)


def test_replicate_refuses_walls_and_bad_counts(dim):
    walled = random_packing(50, 0.1, dim=dim, seed=1, periodic=[True] * (dim - 1) + [False])
    with pytest.raises(StateError, match="closed by walls"):
        replicate(walled, [1] * (dim - 1) + [2])
    assert replicate(walled, [2] + [1] * (dim - 1)).n == 100
    with pytest.raises(StateError, match=f"replicate needs {dim} whole numbers"):
        replicate(walled, [2.5] * dim)
    with pytest.raises(StateError, match="replicate needs"):
        replicate(walled, [0] * dim)


def test_one_radius_and_mass_are_kept_as_one(dim):
    """Monodisperse packings keep their radius, mass and moment of inertia as one number (no
    memory per particle), through replicate and maxwell_boltzmann; polydisperse ones as arrays."""
    mono = edmd.maxwell_boltzmann(edmd.replicate(edmd.random_packing(100, 0.2, dim=dim, seed=1), [2] * dim), 1.0, seed=2)
    for s in (edmd.lattice(100, 0.3, dim=dim), edmd.random_packing(100, 0.2, dim=dim, seed=1), mono):
        assert all(not any(getattr(s, f).strides) for f in ("radius", "mass", "inertia"))
    poly = edmd.random_packing(100, 0.2, dim=dim, seed=1, radius={"kind": "uniform", "min": 0.4, "max": 0.6})
    assert all(getattr(poly, f).strides == (8,) for f in ("radius", "inertia")) and np.ptp(poly.radius) > 0
    assert not any(poly.mass.strides)  # (one mass: the default 1)
    dense = edmd.random_packing(100, 0.2, dim=dim, seed=1, radius={"kind": "uniform", "min": 0.4, "max": 0.6}, density=1.0)
    assert dense.mass.strides == (8,) and np.ptp(dense.mass) > 0
