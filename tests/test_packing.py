"""Contact networks (edmd.analysis.packing): contacts by relative gap, rattlers, contact numbers."""

import itertools

import numpy as np
import pytest

import edmd
from edmd.analysis import ContactNetwork, contact_pairs, rattlers
from edmd.state import State, StateError

#: (lattice, close-packing fraction, coordination number) per dimension
CLOSE_PACKED = {3: ("fcc", np.pi / np.sqrt(18.0), 12), 2: ("hex", np.pi / np.sqrt(12.0), 6)}


def brute_force_contacts(state: State, gap: float) -> set:
    """Every pair by the minimum image (the boxes here are at least twice the contact distance)."""
    found = set()
    for i, j in itertools.combinations(range(state.n), 2):
        d = state.position[i] - state.position[j]
        d -= np.where(state.periodic, state.box * np.round(d / state.box), 0.0)
        if np.linalg.norm(d) / (state.radius[i] + state.radius[j]) - 1.0 < gap:
            found.add((i, j))
    return found


def test_a_close_packed_lattice_is_fully_coordinated(dim):
    kind, eta, z = CLOSE_PACKED[dim]
    lattice = edmd.lattice(108 if dim == 3 else 120, eta * (1 - 1e-12), dim=dim, kind=kind)
    net = ContactNetwork(gap=1e-9).compute(lattice)
    assert net.mean_contact_number == z and np.all(net.contact_numbers == z)
    assert net.rattler_fraction == 0.0 and net.isostatic == 2 * dim
    assert len(ContactNetwork(gap=1e-9).compute(edmd.lattice(108 if dim == 3 else 120, 0.9 * eta, dim=dim, kind=kind)).pairs) == 0


def test_contacts_match_a_brute_force_search_across_the_boundaries(dim, rng):
    """A polydisperse random state with walls on one axis: contacts by the gap relative to each pair's sigma."""
    periodic = [True] * dim
    periodic[0] = False
    state = edmd.random_packing(150, 0.3, dim=dim, seed=4, periodic=periodic, radius={"kind": "uniform", "min": 0.3, "max": 0.7})
    for gap in (0.02, 0.1, 0.3):
        assert set(map(tuple, contact_pairs(state, gap).tolist())) == brute_force_contacts(state, gap)


def test_rattlers_are_removed_until_every_particle_left_has_d_plus_one_contacts(dim):
    """A chain hanging from a rigid cluster falls off link by link."""
    core = list(itertools.combinations(range(dim + 2), 2))  # d + 2 particles all in contact: d + 1 contacts each
    tail = [(0, dim + 2), (dim + 2, dim + 3), (dim + 3, dim + 4)]
    mask = rattlers(dim + 6, np.array(core + tail), dim)
    assert mask.tolist() == [False] * (dim + 2) + [True] * 4
    assert rattlers(dim + 2, np.array(core[1:]), dim).all()  # one contact less: the cluster falls apart


def test_the_mean_contact_number_counts_non_rattlers_only():
    """2D: a hexagonal patch (a centre with 6 contacts, a ring of 6 with 3 each) and one disk
    touching the ring once, a rattler whose contact leaves the counts: z = (6 + 6 x 3)/7."""
    angles = np.arange(6) * np.pi / 3
    ring = np.c_[np.cos(angles), np.sin(angles)]
    pos = np.vstack([[0.0, 0.0], ring, [2.0, 0.0]])
    state = State(position=pos, velocity=np.zeros_like(pos), radius=np.full(8, 0.5), mass=np.ones(8), box=np.array([10.0, 10.0]))
    net = ContactNetwork(gap=1e-9).compute(state)
    assert net.rattlers.tolist() == [False] * 7 + [True]
    assert net.contact_numbers.tolist() == [6] + [3] * 6 + [0]
    assert len(net.pairs) == 12 and net.mean_contact_number == pytest.approx(24 / 7, rel=1e-15)
    assert net.rattler_fraction == 1 / 8


def test_bad_gaps_and_small_boxes_are_named():
    state = edmd.lattice(27, 0.3)
    with pytest.raises(StateError, match="gap"):
        contact_pairs(state, gap=-1.0)
    with pytest.raises(StateError, match="twice the largest contact distance"):
        contact_pairs(edmd.lattice(8, 0.5), gap=1e-9)


def test_the_contact_number_plot():
    kind, eta, _ = CLOSE_PACKED[3]
    net = ContactNetwork(gap=1e-6).compute(edmd.lattice(108, eta * (1 - 1e-9), kind=kind))
    ax = net.plot()
    assert ax.get_xlabel() == "contact number z" and len(ax.patches) >= 1
