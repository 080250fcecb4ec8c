r"""Lookup tables of the matrix of restitution (physics.md §4.7).

The matrix of restitution :math:`(\Phi, D, \tau_c, \hat\varepsilon)` of a contact depends on three
numbers (physics.md §4.7), which span a rectangular box for any physical range of materials,
sizes and impact speeds:

========== ======================================== ==========================================
coordinate dashpot                                  viscoelastic (Hertz)
========== ======================================== ==========================================
damping    :math:`\zeta_d = \gamma/(2\sqrt{k\mu})`    :math:`\delta_v = \tfrac32A\kappa^{2/5}v^{1/5}`
softness   :math:`\Lambda_v = v/(\omega_0\sigma)`      :math:`\Lambda_v = (v^2/\kappa)^{2/5}/\sigma`
b          :math:`v_t/v` (eccentricity)               same
========== ======================================== ==========================================

with the *total* impact speed :math:`v`. A table holds three normalised, :math:`O(1)` outputs on
a tensor grid (see :mod:`edmd._core.lookup`), interpolated in compiled code by degree-5
Lagrange polynomials; :math:`D = 1 - \Lambda\,c\,\hat\varepsilon` follows exactly. The softness
axis reaches down to :math:`\Lambda_v = 0` (the hard-sphere limit), so slow impacts never leave
the table; the box is usually quoted in :math:`\log_{10}\Lambda_v`.

Tables are built in parallel (:func:`build_table`, ``edmd tables build``), stored as ``.npz``
with their model, box, grid, interpolation degree and format version, and checked against the
direct solver (:func:`check_table`). Default tables for both models covering the parameter
ranges of physics.md §6 ship with the package (:func:`default_table`).

Example:
    >>> from edmd.physics.tables import default_table
    >>> tab = default_table("dashpot")
    >>> r = tab.lookup(0.1, 0.01 / (1 - 0.81) ** 0.5, 0.9)     # physics.md §4.10(c) row
    >>> round(r.Phi, 6), round(r.eps_hat, 6)
    (0.059619, 0.750013)
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import datetime
import functools
import math
import os
import time
import zipfile
from importlib import resources
from pathlib import Path

import numpy as np

from .._core import lookup as _lk
from ..cores import usable_cores
from .._core.contact import MODEL_HERTZ
from .._core.twobody import solve_scaled
from .contact import MODELS
from .twobody import Restitution, model_code

#: version of the table file format (bumped on incompatible changes)
FORMAT_VERSION = 1
AXES = ("damping", "softness", "b")
#: interpolation degree of the default tables
DEGREE = 5
#: the softness axis is uniform in ln(Lambda_v + SOFTNESS_SHIFT * Lambda_v,max)
SOFTNESS_SHIFT = 0.15
#: the eccentricity axis is uniform in GRAZING * b - ln(1 - b)
GRAZING = 2.0
#: grid of the central (head-on) Hertz values over s = sqrt(delta)
CENTRAL_NODES, CENTRAL_DEGREE = 401, 7
#: relative tolerance of the direct solves at the nodes
NODE_RTOL = 1e-13


class TableError(ValueError):
    """A table problem: bad box, point outside the box, unreadable or incompatible file."""


@dataclasses.dataclass(frozen=True)
class Box:
    r"""A rectangular parameter box: damping, softness :math:`\Lambda_v` and eccentricity ranges.

    Example:
        >>> box = Box.parse("damping=0:0.3,log10_softness=-6:-1", model="dashpot")
        >>> box.softness, box.b
        ((1e-06, 0.1), (0.0, 0.99))
    """

    damping: tuple[float, float]
    softness: tuple[float, float]
    b: tuple[float, float]

    def __post_init__(self):
        for name in AXES:
            lo, hi = (float(x) for x in getattr(self, name))
            if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo < hi):
                raise TableError(f"box range {name} = [{lo}, {hi}] must satisfy 0 <= low < high")
            object.__setattr__(self, name, (lo, hi))
        if self.softness[1] > 0.5:
            raise TableError(f"softness up to {self.softness[1]} is beyond the scaled solver's range (<= 0.5)")
        if self.b[1] > 0.999:
            raise TableError(f"eccentricity b up to {self.b[1]} is too close to grazing (<= 0.999; larger b: hard-sphere rule)")

    @classmethod
    def parse(cls, text: str, model: str) -> Box:
        """Parse ``"damping=LO:HI,softness=LO:HI,b=LO:HI"`` (``log10_softness=LO:HI`` also works); missing keys keep the model's default."""
        default = DEFAULT_BOXES[_check_model(model)]
        ranges = {name: getattr(default, name) for name in AXES}
        for item in filter(None, (p.strip() for p in text.split(","))):
            key, sep, value = item.partition("=")
            key = key.strip()
            lo, sep2, hi = value.partition(":")
            try:
                lo, hi = float(lo), float(hi)
            except ValueError:
                raise TableError(f"range {item!r} must look like key=LOW:HIGH") from None
            if not sep or not sep2:
                raise TableError(f"range {item!r} must look like key=LOW:HIGH")
            if key == "log10_softness":
                key, lo, hi = "softness", 10.0**lo, 10.0**hi
            if key not in AXES:
                raise TableError(f"unknown range {key!r}; use damping, softness (or log10_softness) and b")
            ranges[key] = (lo, hi)
        return cls(**ranges)

    def as_array(self) -> np.ndarray:
        return np.array([self.damping, self.softness, self.b], float)

    def contains(self, u1: float, lam_v: float, b: float) -> bool:
        return all(lo <= x <= hi for x, (lo, hi) in zip((u1, lam_v, b), (self.damping, self.softness, self.b)))

    def describe(self) -> str:
        lo, hi = self.softness
        log = f"log10 softness [{math.log10(lo):.3g}, {math.log10(hi):.3g}]" if lo > 0 else f"softness [0, {hi:g}] (log10 up to {math.log10(hi):.3g})"
        return f"damping [{self.damping[0]:g}, {self.damping[1]:g}], {log}, b [{self.b[0]:g}, {self.b[1]:g}]"


#: physics.md §6: dashpot zeta_d <= 0.5, Lambda_v <= 0.2 (0.25: the §4.10 checks reach 0.23); viscoelastic delta <~ 1, Lambda_v <= 0.33
DEFAULT_BOXES = {
    "dashpot": Box((0.0, 0.5), (0.0, 0.25), (0.0, 0.99)),
    "hertz": Box((0.0, 1.0), (0.0, 0.35), (0.0, 0.99)),
}
#: grid points per axis of the default tables (max relative error ~1e-7, see benchmarks/README.md)
DEFAULT_SHAPES = {"dashpot": (21, 49, 57), "hertz": (29, 53, 65)}


def _check_model(model) -> str:
    name = model if isinstance(model, str) else getattr(model, "name", None)
    if name not in MODELS:
        raise TableError(f"unknown contact model {model!r}; choose from {sorted(MODELS)}")
    return name


def _grazing_inverse(x: np.ndarray) -> np.ndarray:
    """Solve ``GRAZING * b - ln(1 - b) = x`` for ``b`` (monotonic; Newton from a safe start)."""
    b = np.where(x < 1.0, x / (GRAZING + 1.0), 1.0 - np.exp(-x + GRAZING))
    for _ in range(60):
        f = GRAZING * b - np.log1p(-b) - x
        b = np.clip(b - f / (GRAZING + 1.0 / (1.0 - b)), 0.0, 1.0 - 1e-15)
    return b


def axis_geometry(box: Box, shape) -> tuple[tuple, list[np.ndarray]]:
    """The compiled-core geometry tuple of a table and its node coordinates per axis."""
    n0, n1, n2 = (int(n) for n in shape)
    if min(n0, n1, n2) < DEGREE + 1:
        raise TableError(f"every axis needs at least {DEGREE + 1} nodes, got shape {tuple(shape)}")
    lo, hi = box.damping
    u1 = np.linspace(lo, hi, n0)
    shift = SOFTNESS_SHIFT * box.softness[1]
    x1 = np.linspace(math.log(box.softness[0] + shift), math.log(box.softness[1] + shift), n1)
    lam_v = np.exp(x1) - shift
    lam_v[0], lam_v[-1] = box.softness
    x2 = np.linspace(GRAZING * box.b[0] - math.log1p(-box.b[0]), GRAZING * box.b[1] - math.log1p(-box.b[1]), n2)
    b = _grazing_inverse(x2)
    b[0], b[-1] = box.b
    tg = (
        _lk.AX_LINEAR, 0.0, lo, (hi - lo) / (n0 - 1), n0,
        _lk.AX_LOGSHIFT, shift, x1[0], (x1[-1] - x1[0]) / (n1 - 1), n1,
        _lk.AX_GRAZING, GRAZING, x2[0], (x2[-1] - x2[0]) / (n2 - 1), n2,
        DEGREE,
    )  # fmt: skip
    return tuple(float(t) for t in tg), [u1, lam_v, b]


def _central_table(code: int, damping_max: float):
    """Head-on ``(tau_c0, e_n)`` of the Hertz law over ``s = sqrt(delta)`` in ``[0, sqrt(damping_max)]``."""
    if code != MODEL_HERTZ:
        return np.zeros((0, 2)), (0.0, 1.0, 0.0, 0.0)
    s_max = math.sqrt(damping_max)
    s = np.linspace(0.0, s_max, CENTRAL_NODES)
    out = np.zeros((CENTRAL_NODES, 2))
    K = np.zeros((13, 3))
    for i, si in enumerate(s):
        r = solve_scaled(code, si * si, 0.0, 0.0, NODE_RTOL, K)
        out[i] = r[2], r[3]
    return out, (0.0, s_max / (CENTRAL_NODES - 1), float(CENTRAL_NODES), float(CENTRAL_DEGREE))


def _node_slab(code: int, u1s: np.ndarray, lam_vs: np.ndarray, bs: np.ndarray, rtol: float) -> np.ndarray:
    """Normalised node values of one slab of the grid (runs in a worker process)."""
    out = np.zeros((len(u1s), len(lam_vs), len(bs), _lk.N_OUT))
    _lk.node_values(code, np.asarray(u1s, float), np.asarray(lam_vs, float), np.asarray(bs, float), rtol, out, np.zeros((13, 3)))
    return out


class RestitutionTable:
    """An interpolation table of the matrix of restitution of one contact model.

    Build one with :func:`build_table`, read one with :meth:`load` or :func:`default_table`.

    Attributes:
        model: ``"dashpot"`` or ``"hertz"``.
        box: the parameter :class:`Box`.
        shape: nodes per axis.
        values: ``(n0, n1, n2, 3)`` normalised outputs at the nodes.
        meta: provenance (format version, edmd version, date, solver tolerance, build time).

    Example:
        >>> tab = build_table("hertz", Box((0, 0.2), (0, 0.01), (0, 0.5)), shape=(6, 6, 6), workers=1)
        >>> tab.contains(0.1, 0.005, 0.3), tab.contains(0.3, 0.005, 0.3)
        (True, False)
    """

    def __init__(self, model: str, box: Box, values: np.ndarray, central=None, meta: dict | None = None):
        self.model = _check_model(model)
        self.code = model_code(self.model)
        self.box = box
        values = np.ascontiguousarray(values, dtype=np.float64)
        if values.ndim != 4 or values.shape[3] != _lk.N_OUT:
            raise TableError(f"table values must have shape (n0, n1, n2, {_lk.N_OUT}), got {values.shape}")
        self.values = values
        self.shape = values.shape[:3]
        self.geometry, self.nodes = axis_geometry(box, self.shape)
        if central is None:
            central = _central_table(self.code, box.damping[1])
        self.central, self.central_geometry = central
        self.meta = dict(meta or {})
        self._flat = self.values.reshape(-1)
        self._W = np.zeros(_lk.SCRATCH_SHAPE)

    # ------------------------------------------------------------------ compiled access
    def core(self):
        """``(values_flat, geometry, central, central_geometry)``: what compiled callers pass to
        :func:`edmd._core.lookup.lookup` and :func:`edmd._core.lookup.matrix_of_restitution`."""
        return self._flat, self.geometry, self.central, self.central_geometry

    # ------------------------------------------------------------------ lookups
    def contains(self, u1: float, lam_v: float, b: float) -> bool:
        """Whether the table coordinates lie in the box."""
        return self.box.contains(u1, lam_v, b)

    def lookup(self, u1: float, lam_v: float, b: float, outside: str = "error") -> Restitution:
        r"""Matrix of restitution at table coordinates ``(u1, lam_v, b)`` (physics.md §4.7).

        Args:
            u1: damping coordinate (:math:`\zeta_d` or :math:`\delta_v`).
            lam_v: softness :math:`\Lambda_v`.
            b: eccentricity.
            outside: ``"error"`` (raise :class:`TableError` outside the box) or ``"solve"``
                (use the direct solver there).

        Returns:
            A :class:`~edmd.physics.twobody.Restitution` in scaled units (``t_s = l_s = 1``).
        """
        if outside not in ("error", "solve"):
            raise TableError(f"outside must be 'error' or 'solve', got {outside!r}")
        u1, lam_v, b = float(u1), float(lam_v), float(b)
        r = _lk.lookup(self.code, self._flat, self.geometry, self.central, self.central_geometry, u1, lam_v, b, self._W)
        if math.isnan(r[2]):
            if outside == "error" or not (u1 >= 0 and lam_v >= 0 and 0 <= b < 1):
                raise TableError(self._outside_message(u1, lam_v, b))
            c, lam, tan_a = _lk.solver_parameters(self.code, u1, lam_v, b)
            r = solve_scaled(self.code, c, lam, tan_a, 1e-12, np.zeros((13, 3)))
        return Restitution(float(r[0]), float(r[1]), float(r[2]), float(r[3]), float(r[4]))

    def lookup_many(self, u1, lam_v, b) -> np.ndarray:
        """Vectorised lookup: ``(k, 4)`` array of ``(Phi, D, tau_c, eps_hat)``; NaN rows outside the box."""
        u1, lam_v, b = (np.ascontiguousarray(np.broadcast_to(np.asarray(x, float), np.broadcast(u1, lam_v, b).shape)).ravel() for x in (u1, lam_v, b))
        out = np.zeros((u1.size, 6))
        _lk.lookup_many(self.code, self._flat, self.geometry, self.central, self.central_geometry, u1, lam_v, b, out, self._W)
        return out[:, :4]

    def _outside_message(self, u1, lam_v, b) -> str:
        bad = [f"{name} = {x:.6g} not in [{lo:g}, {hi:g}]" for name, x, (lo, hi) in zip(AXES, (u1, lam_v, b), (self.box.damping, self.box.softness, self.box.b)) if not lo <= x <= hi]
        return (
            f"impact outside the {self.model} table's box ({'; '.join(bad) or 'invalid coordinates'}); "
            "use outside='solve' for the direct solver, or build a larger table with `edmd tables build`"
        )

    # ------------------------------------------------------------------ files
    def save(self, path: str | os.PathLike):
        """Write the table as ``.npz`` (values, box, grid geometry, central table, model, version)."""
        meta = {**self.meta, "format_version": FORMAT_VERSION}
        np.savez(
            Path(path),
            values=self.values,
            box=self.box.as_array(),
            geometry=np.array(self.geometry),
            central=self.central,
            central_geometry=np.array(self.central_geometry),
            model=np.array(self.model),
            meta=np.array(repr(sorted(meta.items()))),
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> RestitutionTable:
        """Read a table written by :meth:`save`; checks the format version and the grid."""
        path = Path(path)
        if not path.is_file():
            raise TableError(f"no restitution table file {path}")
        try:
            with np.load(path, allow_pickle=False) as f:
                data = {k: f[k] for k in f.files}
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:  # never pass on numpy's pickle advice
            raise TableError(f"{path} is corrupt or not a restitution table (.npz written by `edmd tables build`): {type(exc).__name__}") from None
        missing = {"values", "box", "geometry", "central", "central_geometry", "model", "meta"} - set(data)
        if missing:
            raise TableError(f"{path} is not a restitution table (missing {sorted(missing)})")
        import ast

        try:
            meta = dict(ast.literal_eval(str(data["meta"])))
        except (ValueError, SyntaxError, TypeError):
            raise TableError(f"{path}: the table's metadata is damaged") from None
        if meta.get("format_version") != FORMAT_VERSION:
            raise TableError(f"{path} has table format version {meta.get('format_version')}, this edmd reads version {FORMAT_VERSION}")
        box = Box(*(tuple(row) for row in data["box"]))
        central = (data["central"], tuple(float(x) for x in data["central_geometry"]))
        tab = cls(str(data["model"]), box, data["values"], central, meta)
        if not np.allclose(np.array(tab.geometry), data["geometry"], rtol=1e-14, atol=0):
            raise TableError(f"{path}: stored grid geometry does not match its box and shape")
        return tab

    def __repr__(self):
        return f"RestitutionTable({self.model!r}, shape={self.shape}, {self.box.describe()})"


def build_table(
    model,
    box: Box | str | None = None,
    shape=None,
    workers: int | None = None,
    executor: concurrent.futures.Executor | None = None,
    progress: bool = False,
) -> RestitutionTable:
    """Compute a table by direct solves at every node, spread over processes.

    Args:
        model: ``"dashpot"``, ``"hertz"`` or a contact model.
        box: a :class:`Box`, a range string for :meth:`Box.parse`, or ``None`` (the model's default).
        shape: nodes per axis (default :data:`DEFAULT_SHAPES`).
        workers: processes of the default executor (default: the cores this process may use,
            :func:`edmd.cores.usable_cores`; 1 = in this process).
        executor: any :class:`concurrent.futures.Executor` (e.g. a Dask client's executor);
            overrides ``workers``.
        progress: show a rich progress bar.

    Example:
        >>> tab = build_table("dashpot", "damping=0:0.2,softness=0:0.01,b=0:0.5", shape=(7, 7, 7), workers=1)
        >>> tab.shape, round(tab.lookup(0.1, 0.005, 0.25).eps_hat, 4)
        ((7, 7, 7), 0.7441)
    """
    name = _check_model(model)
    code = model_code(name)
    box = DEFAULT_BOXES[name] if box is None else (Box.parse(box, name) if isinstance(box, str) else box)
    shape = tuple(int(n) for n in (DEFAULT_SHAPES[name] if shape is None else shape))
    if len(shape) != 3:
        raise TableError(f"shape must have three numbers, got {shape}")
    _tg, (u1, lam_v, b) = axis_geometry(box, shape)
    values = np.zeros((*shape, _lk.N_OUT))
    started = time.perf_counter()
    own = None
    workers = workers or usable_cores()
    if executor is None and workers > 1:
        own = executor = concurrent.futures.ProcessPoolExecutor(max_workers=workers)
    bar = _bar(name, shape[0]) if progress else None
    try:
        if executor is None:
            for i in range(shape[0]):
                values[i : i + 1] = _node_slab(code, u1[i : i + 1], lam_v, b, NODE_RTOL)
                if bar:
                    bar[0].advance(bar[1])
        else:
            futures = {executor.submit(_node_slab, code, u1[i : i + 1], lam_v, b, NODE_RTOL): i for i in range(shape[0])}
            for fut in concurrent.futures.as_completed(futures):
                i = futures[fut]
                values[i : i + 1] = fut.result()
                if bar:
                    bar[0].advance(bar[1])
    finally:
        if own is not None:
            own.shutdown()
        if bar:
            bar[0].stop()
    if not np.all(np.isfinite(values)):
        raise TableError("some table nodes failed to integrate (non-finite values)")
    from .. import __version__

    meta = {
        "edmd_version": __version__,
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "node_rtol": NODE_RTOL,
        "degree": DEGREE,
        "build_seconds": round(time.perf_counter() - started, 3),
    }
    return RestitutionTable(name, box, values, meta=meta)


def _bar(name, total):
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    bar = Progress(TextColumn(f"[bold]{name} table"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn())
    task = bar.add_task("slabs", total=total)
    bar.start()
    return bar, task


def check_table(table: RestitutionTable, points: int = 10_000, seed: int = 0, sampling: str = "log") -> dict:
    """Largest relative errors of a table against the direct solver at random points of its box.

    Points are uniform in damping and eccentricity and, with ``sampling="log"``, log-uniform in
    softness over ``[max(low, 1e-6), high]`` (the spec's box in :math:`\\log_{10}\\Lambda_v`), or
    uniform with ``"linear"``. Errors are relative, of :math:`\\Phi`, :math:`1 - D`,
    :math:`\\tau_c` and :math:`\\hat\\varepsilon` (:math:`\\Phi` and :math:`1-D` where nonzero).

    Returns:
        ``{"Phi": e, "1-D": e, "tau_c": e, "eps_hat": e, "max": e, "worst_point": (u1, lam_v, b), "points": n}``.

    Example:
        >>> check_table(default_table("hertz"), points=200)["max"] < 1e-6
        True
    """
    if sampling not in ("log", "linear"):
        raise TableError(f"sampling must be 'log' or 'linear', got {sampling!r}")
    rng = np.random.default_rng(seed)
    box = table.box
    u1 = rng.uniform(*box.damping, points)
    lo, hi = box.softness
    if sampling == "log":
        lam_v = 10.0 ** rng.uniform(math.log10(max(lo, 1e-6 * hi)), math.log10(hi), points)
    else:
        lam_v = rng.uniform(lo, hi, points)
    b = rng.uniform(*box.b, points)
    tab = np.zeros((points, 6))
    _lk.lookup_many(table.code, table._flat, table.geometry, table.central, table.central_geometry, u1, lam_v, b, tab, table._W)
    ref = np.zeros((points, 6))
    _lk.direct_many(table.code, u1, lam_v, b, NODE_RTOL, ref, np.zeros((13, 3)))
    c = np.array([_lk.solver_parameters(table.code, *p)[:2] for p in zip(u1, lam_v, b)])
    one_minus_d = (ref[:, 4] * c[:, 1], tab[:, 4] * c[:, 1])
    errors = {}
    worst = np.zeros(points)
    for key, exact, got in [("Phi", ref[:, 0], tab[:, 0]), ("1-D", *one_minus_d), ("tau_c", ref[:, 2], tab[:, 2]), ("eps_hat", ref[:, 3], tab[:, 3])]:
        nz = exact != 0
        rel = np.zeros(points)
        rel[nz] = np.abs(got[nz] - exact[nz]) / np.abs(exact[nz])
        rel[~nz] = np.abs(got[~nz])
        errors[key] = float(rel.max())
        worst = np.maximum(worst, rel)
    k = int(np.argmax(worst))
    errors.update(max=float(worst[k]), worst_point=(float(u1[k]), float(lam_v[k]), float(b[k])), points=points, sampling=sampling)
    return errors


#: placeholder pair table: its species mass is NaN, so no pair matches (:func:`edmd._core.lookup.pair_restitution`)
NO_PAIR_TABLE = (np.zeros(_lk.N_OUT), np.full((1, _lk.PAIR_GRID), np.nan))
#: most species (distinct masses and radii) whose pairs get pair tables: ``s (s + 1) / 2`` tables
PAIR_SPECIES = 3
#: nodes of a pair table's speed axis per cell of the three-dimensional table that its curve crosses
PAIR_NODES_PER_CELL = 2
#: a pair table's b axis goes on beyond its table's (same map and spacing) up to this eccentricity
#: (1 - b^2 ~ 1e-3 of the contacts of a gas lie beyond)
PAIR_B_MAX = 1.0 - 5e-4


def _pair_b_axis(table: RestitutionTable) -> tuple[tuple, np.ndarray]:
    """A pair table's b axis: ``table``'s nodes and more at its spacing up to :data:`PAIR_B_MAX`."""
    _kind, a, x0, h, _n = table.geometry[10:15]
    n = int(math.floor((GRAZING * PAIR_B_MAX - math.log1p(-PAIR_B_MAX) - x0) / h)) + 1
    bs = _grazing_inverse(x0 + h * np.arange(n))
    bs[: len(table.nodes[2])] = table.nodes[2]
    return (_lk.AX_GRAZING, a, x0, h, n), bs


@functools.lru_cache(maxsize=32)
def pair_table(table: RestitutionTable, code: int, a: float, b: float, m1: float, r1: float, m2: float, r2: float) -> tuple[np.ndarray, np.ndarray]:
    r"""The matrix of restitution of the contacts of two species as a table over impact speed and eccentricity (physics.md §4.7).

    For spheres (or disks) of masses and radii ``(m1, r1)`` and ``(m2, r2)`` (the same for one
    species) under one contact law (``code``, constants ``(a, b)``), the damping and softness
    coordinates of ``table`` are functions of the impact speed alone: :math:`\delta_v\propto v^{1/5}`,
    :math:`\Lambda_v\propto v^{4/5}` (Hertz), or a constant :math:`\zeta_d` and :math:`\Lambda_v\propto v`
    (dashpot). Along that curve through ``table``'s box the map is tabulated on a two-dimensional
    grid (speed axis: :math:`\delta_v`, linear, or :math:`\Lambda_v`, mapped like ``table``'s softness
    axis; b axis: ``table``'s, carried on towards grazing contacts, :data:`PAIR_B_MAX`) by direct
    solves at the nodes, :data:`PAIR_NODES_PER_CELL` speed nodes per cell of ``table`` crossed.
    :func:`edmd._core.lookup.pair_restitution` interpolates it at a quarter of the cost of a
    three-dimensional lookup; impacts beyond the curve's part inside the box fall back as before.

    Returns ``(values, grid)`` for the compiled core (``grid``: one row), :data:`NO_PAIR_TABLE`
    where there is none (elastic contacts, whose three-dimensional lookup is exact, or a curve
    outside the box). :func:`pair_tables` joins the tables of several pairs of species.

    Example:
        >>> import numpy as np
        >>> from edmd._core import lookup as lk
        >>> tab = default_table("hertz")
        >>> pv, pg = pair_table(tab, tab.code, 1e4, 0.01, 1.0, 0.5, 1.0, 0.5)
        >>> out = np.zeros((1, 4))
        >>> lk.pair_restitution_many(tab.code, 1e4, 0.01, 1.0, 1.0, 0.5, 0.5, np.array([0.3]), np.array([0.1]), pv, pg, out, np.zeros(lk.SCRATCH_SHAPE))
        >>> mu, reff, sigma = 0.5, 0.25, 1.0
        >>> exact = tab.lookup(*lk.table_coordinates(tab.code, 1e4, 0.01, mu, reff, sigma, 0.1 ** 0.5), 0.1 / 0.1 ** 0.5)
        >>> bool(abs(out[0, 3] - exact.eps_hat) < 1e-9)
        True
    """
    if b == 0.0:
        return NO_PAIR_TABLE
    sigma = r1 + r2  # (as the compiled lookup computes them)
    mu = m1 * m2 / (m1 + m2)
    reff = r1 * r2 / sigma
    u1_1, lam_1 = _lk.table_coordinates(code, a, b, mu, reff, sigma, 1.0)  # at v = 1
    tg = table.geometry
    (d0, d1), (s0, s1) = table.box.damping, table.box.softness
    shift = tg[6]
    if code == MODEL_HERTZ:  # u1 = u1_1 v^(1/5), lam_v = lam_1 v^(4/5): the speed axis is u1 (linear)
        lo, hi = max(d0, u1_1 * (s0 / lam_1) ** 0.25), min(d1, u1_1 * (s1 / lam_1) ** 0.25)
        crossed = (hi - lo) / tg[3] + (math.log(lam_1 * (hi / u1_1) ** 4 + shift) - math.log(lam_1 * (lo / u1_1) ** 4 + shift)) / tg[8]
        speed = (_lk.AX_LINEAR, 0.0, lo)
    else:  # u1 = zeta_d for every speed, lam_v = lam_1 v: the speed axis is lam_v (mapped as the softness axis)
        if not d0 <= u1_1 <= d1:
            return NO_PAIR_TABLE
        lo, hi = math.log(s0 + shift), math.log(s1 + shift)
        crossed = (hi - lo) / tg[8]
        speed = (_lk.AX_LOGSHIFT, shift, lo)
    if not hi > lo:
        return NO_PAIR_TABLE
    n = max(int(math.ceil(PAIR_NODES_PER_CELL * crossed)) + 1, DEGREE + 1)
    x = np.linspace(lo, hi, n)
    if code == MODEL_HERTZ:
        u1s, lvs = x, lam_1 * (x / u1_1) ** 4
    else:
        u1s, lvs = np.full(n, u1_1), np.clip(np.exp(x) - shift, s0, s1)
    b_axis, bs = _pair_b_axis(table)
    values = np.zeros((n, len(bs), _lk.N_OUT))
    _lk.pair_node_values(code, u1s, lvs, bs, NODE_RTOL, values, np.zeros((13, 3)))
    grid = np.array([[m1, r1, m2, r2, a, b, *speed, (hi - lo) / (n - 1), n, *b_axis, 0.0]], float)
    return values.reshape(-1), grid


def pair_tables(table: RestitutionTable, code: int, a: float, b: float, species) -> tuple[np.ndarray, np.ndarray]:
    """The pair tables (:func:`pair_table`) of every pair of ``species`` (``(mass, radius)`` each, at
    most :data:`PAIR_SPECIES`), joined for :func:`edmd._core.lookup.pair_restitution`.

    Example:
        >>> tab = default_table("dashpot")
        >>> pv, pg = pair_tables(tab, tab.code, 1e4, 3.0, [(1.0, 0.5), (2.0, 0.6)])
        >>> pg.shape[0], pg[1, :4].tolist()
        (3, [1.0, 0.5, 2.0, 0.6])
    """
    species = list(species)
    if len(species) > PAIR_SPECIES:
        raise TableError(f"pair tables cover at most {PAIR_SPECIES} species, got {len(species)}")
    made = [pair_table(table, code, a, b, *species[i], *species[j]) for i in range(len(species)) for j in range(i, len(species))]
    made = [t for t in made if t is not NO_PAIR_TABLE]
    if not made:
        return NO_PAIR_TABLE
    grid = np.concatenate([g for _v, g in made])
    grid[:, _lk.PG_OFFSET] = np.cumsum([0] + [v.size for v, _g in made[:-1]])
    return np.concatenate([v for v, _g in made]), grid


@functools.lru_cache(maxsize=None)
def default_table(model) -> RestitutionTable:
    """The table shipped with edmd for ``model`` (``"dashpot"`` or ``"hertz"``), box :data:`DEFAULT_BOXES`.

    Example:
        >>> default_table("hertz").shape
        (29, 53, 65)
    """
    name = _check_model(model)
    path = resources.files("edmd") / "data" / f"restitution_{name}.npz"
    with resources.as_file(path) as p:
        if not p.exists():
            raise TableError(f"the default {name} table is missing from the installation ({p}); build it with `edmd tables build --model {name}`")
        return RestitutionTable.load(p)


__all__ = ["Box", "DEFAULT_BOXES", "NO_PAIR_TABLE", "PAIR_SPECIES", "RestitutionTable", "TableError", "build_table", "check_table", "default_table", "pair_table", "pair_tables"]
