r"""eMD*: event-driven molecular dynamics of soft spheres (Müller & Pöschel 2013; physics.md §4.8).

A soft contact (linear dashpot or viscoelastic Hertz, :mod:`edmd.physics.contact`) is mapped to events:

* **A** when a pair reaches :math:`|\mathbf r_{ij}| = \sigma_{ij}` approaching at :math:`t_0`: the
  matrix of restitution :math:`(\Phi, D, t_c, \hat\varepsilon)` of the contact (from a lookup table
  or the two-body solver, physics.md §4.5–§4.7) relocates the pair about its centre of mass, both
  move on with the centre-of-mass velocity :math:`\mathbf V`, and each stores its post-collisional
  increment :math:`\boldsymbol\Delta` (physics.md §4.6):

  .. math::
      \mathbf r_{i,j}^A = \mathbf R \pm \tfrac{m_{j,i}}{M}D\sigma\,\hat{\mathbf n}',\qquad
      \mathbf v_i = \mathbf v_j = \mathbf V,\qquad
      \boldsymbol\Delta_{i,j} = \pm\tfrac{m_{j,i}}{M}\big(\hat\varepsilon v_n\hat{\mathbf n}' + \tfrac{v_t}{D}\hat{\mathbf t}'\big)

* **B** per particle at :math:`t_0 + t_c`: :math:`\mathbf v \leftarrow \mathbf v + \boldsymbol\Delta`. From then
  on positions and velocities equal Newton's for the soft contact; only during the contact the
  pair follows a surrogate path. B events come before A events at equal times.

Exceptions (counted in the thermo output): **a)** the relocated pair would overlap a third
particle or a wall, and **b)** a particle with a pending B meets a third particle or a wall. a) resolves
the contact by the instantaneous rule with the contact law's central :math:`e_n(v_n)` (as
do pairs found overlapping and approaching, and failed solves: ``fallbacks``); b) executes the
pending B now (with ``communication``, also the former partner's) and re-tests the approach.
Walls use the instantaneous rule with the same force law (:math:`\mu = m_i`, :math:`R_{\rm eff} = R_i`),
on the particle's own velocity (a pending contact is completed first, exception b).
Between A and B the relative kinetic energy of the pair is not carried by velocities:
observables use the *committed* velocities :math:`\mathbf v + \boldsymbol\Delta`
(:attr:`edmd.State.committed_velocity`).
"""

from __future__ import annotations

import dataclasses
import functools
import os
from pathlib import Path

import numpy as np

from .._core import layout as L
from .._core import lookup as _lk
from .._core.bundles import EMDStarData
from .contact import ContactModel, Hertz, LinearDashpot
from .tables import RestitutionTable, default_table


class EMDStarError(ValueError):
    """An inconsistent eMD* setting (the message names it)."""


#: the ``tables`` settings that are not paths
TABLE_CHOICES = ("default", "exact")


@dataclasses.dataclass(frozen=True)
class EMDStar:
    r"""The eMD* collision rule for soft, smooth spheres or disks (physics.md §4.8).

    Args:
        contact: the soft contact law, :class:`~edmd.physics.contact.Hertz` (viscoelastic, material
            density on the particles' masses) or :class:`~edmd.physics.contact.LinearDashpot`.
        tables: ``"default"`` (the tables shipped with edmd, the direct solver outside their
            box), ``"exact"`` (the direct solver for every contact, relative tolerance ``rtol``)
            or the path of a table built with ``edmd tables build`` for the same model.
        communication: in exception b), also execute the pending B of the former partner
            ("post-collisional communication"; keeps angular momentum exact).
        rtol: relative tolerance of the direct two-body solver.

    Example:
        >>> import edmd
        >>> rule = EMDStar(edmd.Hertz(young=1e7, poisson=0.3, A=0.0))
        >>> s = edmd.State(position=[[-1.0, 0.0, 0.0], [1.0, 0.3, 0.0]], velocity=[[1.0, 0, 0], [-1.0, 0, 0]],
        ...                radius=0.5, mass=1.0, box=[10.0, 10.0, 10.0])
        >>> sim = edmd.Simulation(s, collision=rule)
        >>> sim.run(until_time=2.0)
        >>> sim.engine.emd_counters()["emd_contacts"], round(sim.state.kinetic_energy(), 12)
        (1, 1.0)
    """

    contact: ContactModel
    tables: str = "default"
    communication: bool = True
    rtol: float = 1e-10

    def __post_init__(self):
        if not isinstance(self.contact, (Hertz, LinearDashpot)):
            raise EMDStarError(f"eMD* needs a soft contact law (edmd.Hertz or edmd.LinearDashpot), got {self.contact!r}")
        if isinstance(self.tables, os.PathLike):
            object.__setattr__(self, "tables", os.fspath(self.tables))
        if not isinstance(self.tables, str):
            raise EMDStarError(f"tables must be 'default', 'exact' or a table file path, got {self.tables!r}")
        if not isinstance(self.communication, bool):
            raise EMDStarError(f"communication must be true or false, got {self.communication!r}")
        if not (isinstance(self.rtol, float) and 1e-14 <= self.rtol <= 1e-4):
            raise EMDStarError(f"rtol must be a float in [1e-14, 1e-4], got {self.rtol!r}")
        self.table()  # fail early: a missing file or a table of another model

    def laws(self):
        """Its instantaneous fallbacks' laws: the contact law's central :math:`e_n(v_n)`, smooth."""
        return (L.NORMAL_SOFT, 1.0), L.SMOOTH

    def pack(self, fp: np.ndarray, ip: np.ndarray):
        """Write eMD*'s switches and its fallback laws into the core's parameter arrays
        (the contact law itself is packed with the walls', :func:`edmd.physics.collide.pack`)."""
        L.pack_laws(self.laws(), fp, ip)
        ip[L.IP_EMD] = 1
        ip[L.IP_EMD_TABLE] = int(self.tables != "exact")
        ip[L.IP_EMD_COMM] = int(self.communication)
        fp[L.FP_EMD_RTOL] = self.rtol

    def table(self) -> RestitutionTable | None:
        """The lookup table used (``None`` for ``tables = "exact"``)."""
        return _load_table(self.tables, self.contact.name)

    def core(self) -> tuple:
        """``(values, tg, ctab, cgeo)`` for the compiled core (placeholders without a table)."""
        tab = self.table()
        return NO_TABLE if tab is None else tab.core()


#: placeholder table arrays of the same types as a real table's (one compiled loop for all runs)
NO_TABLE = (np.zeros(1), (0.0,) * 16, np.zeros((1, 2)), (0.0, 1.0, 0.0, 0.0))


@functools.lru_cache(maxsize=8)
def _load_table(tables: str, model: str) -> RestitutionTable | None:
    if tables == "exact":
        return None
    if tables == "default":
        return default_table(model)
    path = Path(tables)
    if not path.is_file():
        raise EMDStarError(f"tables: no table file {tables!r} (use 'default', 'exact' or a file from `edmd tables build`)")
    try:
        tab = RestitutionTable.load(path)
    except Exception as exc:
        raise EMDStarError(f"tables: cannot read {tables!r}: {exc}") from exc
    if tab.model != model:
        raise EMDStarError(f"tables: {tables!r} is a {tab.model} table, the contact law is {model}")
    return tab


def emd_bundle(n: int, rule: EMDStar | None, pending=None) -> EMDStarData:
    """The ``emd`` bundle of :mod:`edmd._core.emdstar` for ``n`` particles (internal order).

    ``pending``: ``(dv (n, 3), t_b (n,), partner (n,))`` or ``None`` (nothing pending).
    """
    if pending is None:
        pending = (np.zeros((n, 3)), np.full(n, np.inf), np.full(n, -1, np.int32))
    dv, tb, pj = pending
    values, tg, ctab, cgeo = NO_TABLE if rule is None else rule.core()
    values, ctab = np.ascontiguousarray(values, float), np.ascontiguousarray(ctab, float)
    tg, cgeo = tuple(float(x) for x in tg), tuple(float(x) for x in cgeo)
    scratch = (np.zeros(_lk.SCRATCH_SHAPE), np.zeros((13, 3)), np.zeros((9, 3)))
    return EMDStarData(np.ascontiguousarray(dv, float), np.ascontiguousarray(tb, float), np.ascontiguousarray(pj, np.int32), values, tg, ctab, cgeo, *scratch)


__all__ = ["EMDStar", "EMDStarError", "TABLE_CHOICES", "emd_bundle"]
