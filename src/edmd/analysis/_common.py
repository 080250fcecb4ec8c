"""Shared helpers of the analysis classes: inputs, reference functions, axes."""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Iterator

import numpy as np

from ..state import State, StateError


def each_state(system) -> Iterator[State]:
    """One State, an iterable of States, or a GSD file (every frame), one State at a time.

    Frames of a GSD file are read as they are needed, so a long trajectory never sits in memory.

    Example:
        >>> import edmd
        >>> [s.n for s in each_state([edmd.lattice(8, 0.1), edmd.lattice(27, 0.1)])]
        [8, 27]
    """
    if isinstance(system, State):
        yield system
        return
    if isinstance(system, (str, os.PathLike)):
        from ..files.trajectory import iter_states

        source = iter_states(system, check_overlaps=False)
    elif isinstance(system, Iterable):
        source = system
    else:
        raise TypeError(f"expected a State, States or a GSD file, got {type(system).__name__}")
    count = 0
    for state in source:
        if not isinstance(state, State):
            raise TypeError(f"expected States, got {type(state).__name__}")
        count += 1
        yield state
    if count == 0:
        raise StateError("no frames to analyse")


def contact_value(eta: float, dim: int) -> float:
    r"""Contact value :math:`\chi` of the pair correlation: Carnahan–Starling (3D), Henderson (2D).

    physics.md §5.2: :math:`\chi_{3D}=\frac{1-\eta/2}{(1-\eta)^3}`,
    :math:`\chi_{2D}=\frac{1-7\eta/16}{(1-\eta)^2}`.

    Example:
        >>> round(contact_value(0.3, 3), 6), round(contact_value(0.5, 2), 6)
        (2.478134, 3.125)
    """
    if not 0 <= eta < 1:
        raise ValueError(f"packing fraction must be in [0, 1), got {eta}")
    if dim == 3:
        return (1 - eta / 2) / (1 - eta) ** 3
    if dim == 2:
        return (1 - 7 * eta / 16) / (1 - eta) ** 2
    raise ValueError(f"dim must be 2 or 3, got {dim}")


def compressibility_factor(eta: float, dim: int, g_contact: float | None = None) -> float:
    r"""Hard-sphere equation of state :math:`Z = P/(nT) = 1 + 2^{d-1}\eta\,g(\sigma^+)` (physics.md §5.2).

    ``g_contact`` defaults to :func:`contact_value` (Carnahan–Starling / Henderson).

    Example:
        >>> round(compressibility_factor(0.3, 3), 6)
        3.973761
    """
    g = contact_value(eta, dim) if g_contact is None else g_contact
    return 1.0 + 2 ** (dim - 1) * eta * g


def box_tree(state: State, reach: float):
    """A scipy k-d tree of ``state``'s positions, shifted into ``[0, L)`` and wrapped on its periodic
    axes (a closed axis is padded: no image within ``reach``), and those points.

    Example:
        >>> import edmd
        >>> tree, points = box_tree(edmd.lattice(27, 0.3), reach=1.0)
        >>> bool(points.min() >= 0.0), len(tree.query_pairs(0.1))
        (True, 0)
    """
    from scipy.spatial import cKDTree

    box, periodic = state.box, state.periodic
    points = state.position + 0.5 * box
    points = np.where(periodic, np.mod(points, box), points)
    points = np.where(periodic & (points >= box), 0.0, points)  # mod may round up to L
    return cKDTree(points, boxsize=np.where(periodic, box, box + 2.0 * reach)), points


def axes(ax=None, figsize=(5.0, 3.8)):
    """``ax``, or the Axes of a new Agg-rendered Figure (no pyplot state involved)."""
    if ax is not None:
        return ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    return fig.add_subplot()


def maxwell_speed_pdf(c, dim: int):
    r"""Maxwell distribution of the reduced speed :math:`c = |\mathbf v - \mathbf u|\sqrt{m/T}`.

    .. math:: f(c) = \frac{c^{d-1} e^{-c^2/2}}{2^{d/2-1}\,\Gamma(d/2)}

    Example:
        >>> round(float(maxwell_speed_pdf(1.0, 2)), 6)
        0.606531
    """
    import numpy as np

    c = np.asarray(c, float)
    return c ** (dim - 1) * np.exp(-0.5 * c * c) / (2 ** (dim / 2 - 1) * math.gamma(dim / 2))
