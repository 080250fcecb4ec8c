"""State validation: bad input gets a clear error naming the problem."""

import numpy as np
import pytest

import edmd
from edmd import State, StateError


def two(dim, d=1.5, **kw):
    pos = np.zeros((2, dim))
    pos[1, 0] = d
    args = dict(position=pos, velocity=np.zeros((2, dim)), radius=[0.5, 0.5], mass=[1.0, 1.0], box=[10.0] * dim)
    args.update(kw)
    return State(**args)


def test_valid_state(dim):
    s = two(dim)
    assert (s.n, s.dim) == (2, dim)
    assert s.angular_velocity.shape == ((2, 3) if dim == 3 else (2,))
    assert s.inertia == pytest.approx((0.4 if dim == 3 else 0.5) * 0.25)


def test_overlap_names_the_pair(dim):
    with pytest.raises(StateError, match="particles 0 and 1 overlap"):
        two(dim, d=0.9)


def test_overlap_across_the_periodic_boundary(dim):
    pos = np.zeros((2, dim))
    pos[0, 0], pos[1, 0] = -4.8, 4.9
    with pytest.raises(StateError, match="particles 0 and 1 overlap"):
        State(position=pos, velocity=pos * 0, radius=0.5, mass=1.0, box=[10.0] * dim)


@pytest.mark.parametrize("partner", ["small", "big"])
def test_overlap_with_a_big_particle_is_found(dim, partner):
    """Two intruders of size ratio 10 among 3000 (taken out of the overlap search's cells): a
    small one, or the other big, put deep inside one of them is named as the deepest overlap."""
    n = 3000
    s = edmd.random_packing(n, 0.05, dim=dim, radius={"kind": "discrete", "values": [0.5, 5.0], "fractions": [n - 2, 2]}, seed=2)
    b, other = np.flatnonzero(s.radius == 5.0)
    j = other if partner == "big" else (b + 7) % n
    pos = s.position.copy()
    pos[j] = pos[b]
    pos[j, 0] += 0.2 * (s.radius[b] + s.radius[j])
    pos[j, 0] -= s.box[0] * np.round(pos[j, 0] / s.box[0])
    with pytest.raises(StateError, match=f"particles {min(b, j)} and {max(b, j)} overlap"):
        State(position=pos, velocity=pos * 0, radius=s.radius, mass=1.0, box=s.box)


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("radius", [0.5, -0.1], "radius must be positive: particle 1"),
        ("radius", [0.5, 0.0], "radius must be positive"),
        ("mass", [1.0, 0.0], "mass must be positive: particle 1"),
        ("box", None, "box"),
    ],
)
def test_non_positive_values(dim, field, value, match):
    if field == "box":
        value = [10.0] * (dim - 1) + [-1.0]
    with pytest.raises(StateError, match=match):
        two(dim, **{field: value})


def test_nan_is_rejected(dim):
    v = np.zeros((2, dim))
    v[1, 0] = np.nan
    with pytest.raises(StateError, match=r"velocity is not finite .* index \(1, 0\)"):
        two(dim, velocity=v)


def test_outside_box(dim):
    pos = np.zeros((2, dim))
    pos[1, 0] = 7.0
    with pytest.raises(StateError, match="particle 1 .* outside the box"):
        two(dim, position=pos)


def test_shape_errors(dim):
    with pytest.raises(StateError, match="velocity must have shape"):
        two(dim, velocity=np.zeros((3, dim)))
    with pytest.raises(StateError, match="position must have shape"):
        State(position=np.zeros((2, 4)), velocity=np.zeros((2, 4)), radius=1, mass=1, box=[1, 1, 1, 1])


def test_observables(dim):
    v = np.zeros((2, dim))
    v[0, 0], v[1, 0] = 1.0, 3.0  # mean flow 2: peculiar speeds -1, +1
    s = two(dim, velocity=v)
    assert s.kinetic_energy() == pytest.approx(5.0)
    assert s.temperature() == pytest.approx(2.0 / (dim * 2))
    assert s.momentum()[0] == 4.0
    assert s.packing_fraction == pytest.approx(2 * (np.pi / 4 if dim == 2 else np.pi / 6) / 10.0**dim)


def test_copy_is_deep(dim):
    s = two(dim)
    c = s.copy()
    c.position[0, 0] = 0.1
    assert s.position[0, 0] == 0.0


def test_unwrapped_positions(dim):
    s = two(dim, image=np.array([[1] + [0] * (dim - 1), [0] * dim]))
    assert s.unwrapped_position[0, 0] == 10.0
    assert isinstance(edmd.State, type)


def test_a_particle_larger_than_the_periodic_box_is_refused(dim):
    box = [4.0] * dim
    one = dict(position=np.zeros((1, dim)), velocity=np.zeros((1, dim)), mass=[1.0], box=box)
    with pytest.raises(StateError, match=r"particle 0 \(diameter 6.0\) does not fit the periodic box length 4.0 .* own periodic image"):
        State(radius=[3.0], **one)
    with pytest.raises(StateError, match="own periodic image"):
        State(radius=[2.0], **one)  # touching its own image
    assert State(radius=[1.9], **one).n == 1
    walled = dict(one, periodic=[False] * dim)
    with pytest.raises(StateError, match="lies outside the box"):
        State(radius=[3.0], **walled)


@pytest.mark.parametrize("rule", ["hard", "emdstar"])
def test_engine_snapshot_equals_the_checked_state(dim, rule):
    """Snapshots skip the State's checks (State.trusted): they must be exactly the State that
    the checked constructor makes of the same arrays, field by field, dtypes included."""
    import dataclasses

    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.1, dim=dim, seed=5), 1.0, seed=6, spin=True)
    from edmd.physics.emdstar import EMDStar

    collision = EMDStar(edmd.Hertz(young=1e5, poisson=0.3, A=1e-4)) if rule == "emdstar" else edmd.collide.Rough(0.9, -0.5)
    sim = edmd.Simulation(s, collision=collision)
    sim.run(max_events=3000)
    snap = sim.state
    checked = State(**{f.name: getattr(snap, f.name) for f in dataclasses.fields(State)}, check_overlaps=False)
    for f in dataclasses.fields(State):
        a, b = getattr(snap, f.name), getattr(checked, f.name)
        if isinstance(b, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b), f.name
        else:
            assert a == b, f.name
    if rule == "emdstar":
        assert np.any(snap.pending_partner >= 0)


def test_default_fields_take_no_memory_and_stay_read_only(dim):
    """Spins, images, TC times and pending contacts left at their default are broadcast constants
    (no memory per particle); writing into one fails loudly, assigning a new array works, and a
    copy keeps them constant."""
    s = two(dim)
    for name, value in [("angular_velocity", 0.0), ("image", 0), ("last_collision", -np.inf), ("pending_velocity", 0.0), ("pending_until", np.inf), ("pending_partner", -1)]:
        arr = getattr(s, name)
        assert not any(arr.strides) and not arr.flags.writeable and np.all(arr == value), name
    with pytest.raises(ValueError, match="read-only"):
        s.image[0, 0] = 1
    c = s.copy()
    assert not any(c.angular_velocity.strides) and not c.has_pending
    c.image = np.ones((2, dim), np.int64)
    assert c.unwrapped_position[0, 0] == 10.0 and s.image[0, 0] == 0
    assert s._committed() is s.velocity and s.committed_velocity is not s.velocity  # (inside: no copy; outside: a new array)


def test_a_filled_field_is_checked(dim):
    bad = np.broadcast_to(np.nan, (2, 3) if dim == 3 else (2,))
    with pytest.raises(StateError, match="angular_velocity is not finite"):
        two(dim, angular_velocity=bad)


def test_check_names_a_non_finite_velocity_of_a_trusted_state(dim):
    s = two(dim)
    v = s.velocity.copy()
    v[1, 0] = np.nan
    t = State.trusted(**{**{k: getattr(s, k) for k in ("position", "radius", "mass", "box", "time", "angular_velocity", "inertia", "image", "periodic", "last_collision")}, "velocity": v})
    with pytest.raises(StateError, match=r"velocity is not finite \(NaN or inf\) at particle 1"):
        t.check()


def test_check_names_a_nan_spin_of_a_trusted_state(dim):
    s = two(dim)
    w = np.zeros((2, 3) if dim == 3 else 2)
    w[0] = np.nan
    fields = {k: getattr(s, k) for k in ("position", "velocity", "radius", "mass", "box", "time", "inertia", "image", "periodic", "last_collision")}
    with pytest.raises(StateError, match="angular_velocity is not finite .* at particle 0"):
        State.trusted(**fields, angular_velocity=w).check()
    with pytest.raises(StateError, match="last_collision of particle 1 is inf"):
        State.trusted(**{**fields, "last_collision": np.array([0.0, np.inf])}, angular_velocity=np.zeros_like(w)).check()


def test_one_radius_mass_or_moment_takes_no_memory_and_the_arrays_values_bit_for_bit(dim):
    """Radii, masses and moments of inertia given as one number (or a broadcast constant) are kept
    as one (8 bytes per particle each at 1e6, benchmarks/README.md "Memory"), read-only, with the
    values and the default moments that arrays of them give; arrays stay writable copies."""
    pos = edmd.lattice(64, 0.2, dim=dim).position
    one = State(position=pos, velocity=np.zeros_like(pos), radius=0.5, mass=np.broadcast_to(2.0, (64,)), box=edmd.lattice(64, 0.2, dim=dim).box)
    each = State(position=pos, velocity=np.zeros_like(pos), radius=np.full(64, 0.5), mass=np.full(64, 2.0), box=one.box)
    for name in ("radius", "mass", "inertia"):
        a, b = getattr(one, name), getattr(each, name)
        assert a.shape == b.shape == (64,) and a.tobytes() == b.tobytes(), name
        assert not any(a.strides) and not a.flags.writeable and b.strides == (8,) and b.flags.writeable, name
    with pytest.raises(ValueError, match="read-only"):
        one.radius[0] = 0.6
    assert not any(one.copy().radius.strides) and one.kinetic_energy() == each.kinetic_energy() and one.packing_fraction == each.packing_fraction
    with pytest.raises(StateError, match="radius must be positive: particle 0 has radius -0.5"):
        State(position=pos, velocity=np.zeros_like(pos), radius=-0.5, mass=1.0, box=one.box)
    with pytest.raises(StateError, match="mass is not finite"):
        State(position=pos, velocity=np.zeros_like(pos), radius=0.5, mass=[np.nan], box=one.box)


def test_radii_of_another_length_name_the_field():
    with pytest.raises(StateError, match=r"radius must be one number or 2 numbers \(one per particle\), got shape \(3,\)"):
        State(position=[[0.0, 0.0], [2.0, 0.0]], velocity=[[0.0, 0.0], [0.0, 0.0]], radius=[0.5, 0.5, 0.5], mass=1.0, box=[5.0, 5.0])


# ---------------------------------------------------------------------------- views
@pytest.mark.parametrize("rule", ["smooth", "emdstar"])
def test_a_view_reads_what_a_copy_holds_each_field_made_when_read(dim, rule):
    import dataclasses

    from edmd.physics.emdstar import EMDStar
    from edmd.state import PARTICLE_FIELDS, StateView

    s = edmd.maxwell_boltzmann(edmd.lattice(200, 0.3, dim=dim), 1.0, seed=4, spin=rule == "smooth")
    kw = {"collision": EMDStar(edmd.LinearDashpot(k=500.0, gamma=8.0))} if rule == "emdstar" else {"e_n": 0.9}
    sim = edmd.Simulation(s, **kw)
    sim.run(max_events=3000)
    view, copy = sim.state_view(), sim.state
    assert isinstance(view, StateView) and view.n == 200 and view.dim == dim and view.time == copy.time
    for name in PARTICLE_FIELDS:
        assert np.array_equal(getattr(view, name), getattr(copy, name)), name
    assert view.position is not view.position  # (made at every read, never kept)
    # the view's sums come from one compensated pass over the engine's rows (test_snapshot.py):
    # numpy's pairwise sums of the copy agree to round-off, relative to the sums of |terms|
    scale = float(np.sum(copy.mass[:, None] * np.abs(copy.committed_velocity)))
    for method in ("kinetic_energy", "temperature", "rotational_energy", "momentum", "total_mass"):
        assert np.allclose(getattr(view, method)(), getattr(copy, method)(), rtol=1e-13, atol=1e-14 * scale), method
    again = view.copy()
    assert type(again) is State and np.array_equal(again.velocity, copy.velocity)
    assert again.image.dtype == copy.image.dtype == np.int64  # (a view's own are the engine's int32)
    replaced = dataclasses.replace(view, velocity=np.zeros((200, dim)), check_overlaps=False)
    assert type(replaced) is State and not replaced.velocity.any() and np.array_equal(replaced.position, copy.position)
    sim.run(max_events=10)
    with pytest.raises(RuntimeError, match="out of date"):
        view.velocity


def test_potential_energy_without_gravity_reads_no_positions():
    s = edmd.lattice(8, 0.1)
    s.position = None  # (it would fail if read)
    assert str(s.potential_energy(None)) == "-0.0" and str(s.potential_energy([0.0, 0.0, 0.0])) == "-0.0"
