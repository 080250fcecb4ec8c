r"""Contact networks of (nearly) jammed packings: contacts, rattlers, contact numbers (docs/physics.md §1.7).

A pair is in contact when its relative gap :math:`h_{ij}/\sigma_{ij} = r_{ij}/\sigma_{ij} - 1` is below
``gap``. A packing compressed to a reduced pressure :math:`Z` has gaps of order :math:`1/Z` between the
particles that carry it, so ``gap = 1e-9`` separates contacts from neighbours at :math:`Z = 10^{12}`.
*Rattlers* are particles that do not carry the packing: in :math:`d` dimensions a particle needs at least
:math:`d + 1` contacts, so particles with fewer are removed, repeatedly, with their contacts. A jammed
packing of frictionless spheres is isostatic: the non-rattlers have on average :math:`z = 2d`
contacts (:math:`2d(1 - 1/N') + 2/N'`, for :math:`N'` non-rattlers in a periodic box: :math:`d(N' - 1) + 1`
contacts).
"""

from __future__ import annotations

import numpy as np

from ..state import State, StateError
from ._common import axes, box_tree


def contact_pairs(state: State, gap: float = 1e-9) -> np.ndarray:
    r"""The pairs ``(i, j)``, ``i < j``, whose relative gap :math:`r_{ij}/\sigma_{ij} - 1` is below ``gap``.

    Example:
        >>> import edmd
        >>> s = edmd.lattice(16, 0.7, dim=2, kind="square")   # spacing 1.0593: no contacts
        >>> contact_pairs(s).shape, contact_pairs(s, gap=0.06).shape   # within 6 %: 4 neighbours each
        ((0, 2), (32, 2))
    """
    if not (np.isfinite(gap) and gap > 0):
        raise StateError(f"the contact gap must be a positive number, got {gap!r}")
    box, periodic = state.box, state.periodic
    reach = 2.0 * float(state.radius.max()) * (1.0 + gap)
    if np.any(periodic & (box < 2.0 * reach)):
        raise StateError(f"contacts need periodic box lengths of at least twice the largest contact distance ({2 * reach:g})")
    tree, _ = box_tree(state, reach)
    pairs = tree.query_pairs(reach, output_type="ndarray")
    if pairs.size == 0:
        return np.zeros((0, 2), np.int64)
    touching = state.contact_ratio(pairs[:, 0], pairs[:, 1]) - 1.0 < gap
    pairs = np.sort(pairs[touching].astype(np.int64), axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def rattlers(n: int, pairs: np.ndarray, dim: int) -> np.ndarray:
    r"""Which of ``n`` particles rattle: fewer than :math:`d + 1` contacts among the non-rattlers, found by
    removing such particles (and their contacts) until none is left.

    Example:
        >>> import numpy as np
        >>> four = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]        # 2D: 3 contacts each
        >>> rattlers(6, np.array(four + [[4, 0], [4, 1]]), dim=2).tolist()  # 4 has 2, 5 none
        [False, False, False, False, True, True]
    """
    rattles = np.zeros(n, bool)
    while True:
        kept = pairs[~rattles[pairs[:, 0]] & ~rattles[pairs[:, 1]]]
        count = np.bincount(kept.ravel(), minlength=n)
        new = ~rattles & (count < dim + 1)
        if not new.any():
            return rattles
        rattles |= new


class ContactNetwork:
    r"""Contacts, rattlers and contact numbers of a packing.

    Args:
        gap: the largest relative gap :math:`r_{ij}/\sigma_{ij} - 1` of a contact.

    Attributes (after :meth:`compute`):
        pairs: ``(M, 2)`` contacts among non-rattlers.
        rattlers: ``(N,)`` bools.
        contact_numbers: ``(N,)`` contacts of each particle with non-rattlers (0 for rattlers).
        mean_contact_number: :math:`z`, the mean over non-rattlers.
        isostatic: :math:`2d`.
        rattler_fraction: the fraction of rattlers.

    Example:
        >>> import edmd
        >>> net = ContactNetwork(gap=0.01).compute(edmd.lattice(108, 0.7404))   # fcc at close packing
        >>> net.mean_contact_number, net.rattler_fraction
        (12.0, 0.0)
    """

    def __init__(self, gap: float = 1e-9):
        self.gap = float(gap)

    def compute(self, state: State) -> ContactNetwork:
        """Find the contacts and rattlers of ``state``; returns ``self``."""
        every = contact_pairs(state, self.gap)
        self.dim = state.dim
        self.rattlers = rattlers(state.n, every, state.dim)
        self.pairs = every[~self.rattlers[every[:, 0]] & ~self.rattlers[every[:, 1]]]
        self.contact_numbers = np.bincount(self.pairs.ravel(), minlength=state.n)
        carrying = int((~self.rattlers).sum())
        self.mean_contact_number = 2.0 * len(self.pairs) / carrying if carrying else 0.0
        self.isostatic = 2 * state.dim
        self.rattler_fraction = float(self.rattlers.mean())
        return self

    def plot(self, ax=None):
        """The distribution of contact numbers of the non-rattlers, the isostatic :math:`2d` marked."""
        ax = axes(ax)
        z = self.contact_numbers[~self.rattlers]
        bins = np.arange(z.min(initial=0), z.max(initial=0) + 2) - 0.5
        ax.hist(z, bins=bins, density=True, color="C0", alpha=0.8, label=f"non-rattlers (mean {self.mean_contact_number:.3f})")
        ax.axvline(self.isostatic, color="k", ls="--", label=f"isostatic 2d = {self.isostatic}")
        ax.set_xlabel("contact number z")
        ax.set_ylabel("fraction of particles")
        ax.set_title(f"contacts (gap < {self.gap:g}); rattlers {100 * self.rattler_fraction:.1f} %")
        ax.legend()
        return ax
