r"""What a restitution table holds: its matrix of restitution drawn over the box (the paper's Figs. 4 and 5).

One row of panels per damping value, one column per element of the matrix of restitution
(physics.md §4.5): the rotation :math:`\Phi` of the inter-centre vector, the normal restitution
:math:`\hat\varepsilon` including centrifugal effects, the distance ratio
:math:`D = 1 - \Lambda X_c` (with :math:`X_c = c\,\hat\varepsilon`, physics.md §4.7) and the scaled
contact duration :math:`\tau_c = t_c/t_s`, each against the softness :math:`\Lambda_v` of the total
impact speed, one curve per eccentricity :math:`b`. The curves are table lookups
(:meth:`~edmd.physics.tables.RestitutionTable.lookup_many`) in table coordinates
(physics.md §4.7). ``edmd tables plot`` draws them from the command line.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..physics.contact import MODELS, ContactModel
from ..physics.tables import GRAZING, RestitutionTable, TableError, _grazing_inverse, default_table

#: the panels: ``(column of lookup_many, axis label)``, in the order drawn
COMPONENTS = ((0, r"$\Phi$ [rad]"), (3, r"$\hat\varepsilon$"), (1, r"$D = 1 - \Lambda c\,\hat\varepsilon$"), (2, r"$\tau_c = t_c / t_s$"))
#: how the damping coordinate is called, per model
DAMPING_NAMES = {"dashpot": r"\zeta_d", "hertz": r"\delta_v"}


def as_table(source) -> RestitutionTable:
    """A :class:`~edmd.physics.tables.RestitutionTable`: given, read from a ``.npz`` file, or the default of a model.

    Args:
        source: a table, a table file, a model name (``"dashpot"``, ``"hertz"``) or a contact
            model (its default table).

    Example:
        >>> as_table("hertz").model
        'hertz'
    """
    if isinstance(source, RestitutionTable):
        return source
    if isinstance(source, ContactModel):
        return default_table(source.name)
    if isinstance(source, str) and source in MODELS:
        return default_table(source)
    if isinstance(source, (str, os.PathLike)):
        if not Path(source).is_file():
            raise TableError(f"no table file {source} (give a .npz table, or a model: {', '.join(sorted(MODELS))})")
        return RestitutionTable.load(source)
    raise TableError(f"expected a restitution table, a table file or a model name, got {type(source).__name__}")


def _inside(name: str, values, bounds) -> np.ndarray:
    """``values`` as an array, checked to lie in the table's range ``bounds`` of axis ``name``."""
    values = np.atleast_1d(np.asarray(values, float))
    lo, hi = bounds
    bad = values[~((values >= lo) & (values <= hi))]
    if values.size == 0 or bad.size:
        raise TableError(f"{name} values {bad.tolist() or '(none)'} are not in the table's range [{lo:g}, {hi:g}]")
    return values


def plot_table(source, damping=None, b=None, out: str | os.PathLike | None = None, points: int = 101):
    r"""Draw :math:`\Phi`, :math:`\hat\varepsilon`, :math:`D`, :math:`\tau_c` of a table against softness, per damping.

    Args:
        source: a :class:`~edmd.physics.tables.RestitutionTable`, a table file, ``"dashpot"`` or
            ``"hertz"`` (the default tables), or a contact model (see :func:`as_table`).
        damping: the damping coordinates (:math:`\zeta_d` or :math:`\delta_v`), one row of
            panels each (default: the low end, middle and high end of the table's range).
        b: eccentricities, one curve each (default: five over the table's range, evenly spread
            in its eccentricity coordinate, that is denser towards grazing contacts).
        out: write the figure there as PNG too.
        points: softness values per curve, evenly spread over the table's range.

    Returns:
        The matplotlib Figure (Agg-rendered, no pyplot): ``4 * len(damping)`` Axes, row by row;
        in each Axes one line per ``b`` with the softness as x data.

    Example:
        >>> fig = plot_table("dashpot", damping=[0.0, 0.1], b=[0.0, 0.9], points=11)
        >>> len(fig.axes), fig.axes[5].get_lines()[0].get_ydata()[[0, -1]].round(7).tolist()   # e_n at zeta_d = 0.1
        (8, [0.7440794, 0.7440794])
    """
    from matplotlib.figure import Figure

    table = as_table(source)
    box = table.box
    damping = _inside("damping", np.linspace(*box.damping, 3) if damping is None else damping, box.damping)
    b = _inside("eccentricity b", _eccentricities(box.b) if b is None else b, box.b)
    if int(points) < 2:
        raise TableError(f"points must be at least 2, got {points}")
    softness = np.linspace(*box.softness, int(points))
    fig = Figure(figsize=(3.3 * len(COMPONENTS), 2.5 * len(damping) + 0.6), layout="constrained")
    grid = fig.subplots(len(damping), len(COMPONENTS), squeeze=False, sharex=True)
    name = DAMPING_NAMES[table.model]
    for row, u1 in zip(grid, damping):
        for k, bk in enumerate(b):
            values = table.lookup_many(u1, softness, bk)
            colour = _colour(k, len(b))
            for ax, (column, label) in zip(row, COMPONENTS):
                ax.plot(softness, values[:, column], color=colour, label=f"b = {bk:.3g}")
                ax.set_title(f"{label}, ${name}$ = {u1:g}", fontsize="small")
    for ax in grid[-1]:
        ax.set_xlabel(r"softness $\Lambda_v$")
    grid[0, -1].legend(fontsize="x-small")
    fig.suptitle(f"matrix of restitution, {table.model} table: {box.describe()}", fontsize="medium")
    if out is not None:
        from .plots import save

        save(grid[0, 0], out)
    return fig


def _eccentricities(bounds, n: int = 5) -> np.ndarray:
    """``n`` eccentricities from ``bounds``, uniform in the table axis coordinate ``GRAZING * b - ln(1 - b)``, 3 digits."""
    x = GRAZING * np.asarray(bounds) - np.log1p(-np.asarray(bounds))
    b = np.round(_grazing_inverse(np.linspace(x[0], x[1], n)), 3)
    b[[0, -1]] = bounds
    return b


def _colour(k: int, n: int):
    """The ``k``-th of ``n`` colours spread over viridis."""
    from matplotlib import colormaps

    return colormaps["viridis"](k / max(n - 1, 1) * 0.9)


__all__ = ["as_table", "plot_table"]
