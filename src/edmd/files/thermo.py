"""Thermodynamic output: temperature, pressure, collision rate per output interval (CSV)."""

from __future__ import annotations

import csv
import io
import math
import os

import numpy as np

from .atomic import fsync_existing, write_atomic
from .._core.layout import TENSOR_AXES
from ..run.observer import Observer, Totals
from ..run.simulation import Simulation
from ..state import State

COLUMNS = (
    "time",
    "events",
    "collisions",
    "kinetic_energy",
    "temperature",
    "rotational_energy",
    "temperature_rot",
    "potential_energy",
    "dissipated_energy",
    "energy_balance",
    "pressure",
    "collision_rate",
    "wall_collisions",
)
AXES = "xyz"

# Columns that are running totals: summaries (the sweep results table) report their final value
# and time-average every other column. Counters added to the table later belong here too.
CUMULATIVE = (
    "time", "events", "collisions", "dissipated_energy", "emd_contacts", "emd_exceptions_a", "emd_exceptions_b",
    "emd_fallbacks", "energy_input", "shear_work",
)  # fmt: skip


def pressure(state: State, d_kinetic_integral: float, d_virial: float, dt: float) -> float:
    r"""Pressure over an interval from the kinetic-energy integral and the collision virial.

    physics.md §5.3:

    .. math::
        P = \frac{1}{dV}\Big[\frac{1}{t_{\rm obs}}\int \sum_i m_i |\mathbf v_i - \mathbf u|^2\,dt
            + \frac{1}{t_{\rm obs}}\sum_{\rm coll}\mathbf r_{ij}\cdot\mathbf J\Big]

    with the mean-flow term :math:`M|\mathbf u|^2` taken from the momentum at the end of the
    interval (conserved in a periodic box without gravity).
    """
    if dt <= 0:
        return math.nan
    p = state.momentum()
    kin = 2.0 * d_kinetic_integral / dt - float(p @ p) / state.total_mass()
    return (kin + d_virial / dt) / (state.dim * state.volume)


def tensor_components(dim: int) -> list[tuple[int, str]]:
    """The stress accumulators' components a ``dim``-dimensional system has: ``(index, "xy")`` pairs
    (:data:`edmd._core.layout.TENSOR` order; 2D ``xx, yy, xy``)."""
    return [(c, AXES[a] + AXES[b]) for c, (a, b) in enumerate(TENSOR_AXES) if max(a, b) < dim]


def pressure_tensor(state: State, d_stress_integral: np.ndarray, dt: float) -> dict[str, float]:
    r"""The pressure tensor over an interval from the increment of :attr:`Totals.stress_integral`.

    physics.md §5.3 (:mod:`edmd._core.stress`):

    .. math::
        \mathsf P = \frac{1}{V}\Big[\frac{1}{t_{\rm obs}}\Big(\int \sum_i m_i\mathbf v_i\otimes\mathbf v_i\,dt
            + \sum_{\rm coll}\tfrac12(\mathbf r_{ij}\otimes\mathbf J + \mathbf J\otimes\mathbf r_{ij})\Big)
            - \frac{\mathbf P_{\rm tot}\otimes\mathbf P_{\rm tot}}{M}\Big],

    the mean flow taken out as in :func:`pressure`, whose value is its trace over :math:`d`.
    Returns ``{"pressure_xx": ..., ...}``: the components ``xx, yy, zz, xy, xz, yz`` (3D) or
    ``xx, yy, xy`` (2D).

    Example:
        >>> import numpy as np, edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(64, 0.01, dim=2), 1.0, seed=1)
        >>> p = pressure_tensor(s, np.array([2.0, 4.0, 0.0, 1.0, 0.0, 0.0]) * s.volume, 2.0)
        >>> {k: round(v, 9) for k, v in p.items()}
        {'pressure_xx': 1.0, 'pressure_yy': 2.0, 'pressure_xy': 0.5}
    """
    p, mass = state.momentum(), state.total_mass()
    out = {}
    for c, name in tensor_components(state.dim):
        a, b = TENSOR_AXES[c]
        flow = float(p[a] * p[b]) / mass
        out[f"pressure_{name}"] = float((d_stress_integral[c] / dt - flow) / state.volume)
    return out


class Thermo(Observer):
    """Thermodynamic table, one row per interval, optionally written to a CSV file.

    Each row holds the instantaneous ``time, events, collisions``, the translational
    ``kinetic_energy`` and ``temperature``, the ``rotational_energy`` and ``temperature_rot``,
    the ``potential_energy`` (gravity's, and a square well's :math:`-\\varepsilon` per captured pair), the cumulative ``dissipated_energy`` and their sum
    ``energy_balance`` (constant to round-off: kinetic + rotational + potential + dissipated),
    and, averaged over the interval that ends there, the ``pressure`` (kinetic + collision
    virial, physics.md §5.3; meaningful in periodic directions), the ``collision_rate`` per
    particle :math:`2\\Delta N_{\\rm coll}/(N\\Delta t)` and, for every axis closed by walls,
    ``wall_pressure_<axis>``: the mean normal force per area on its two walls, and the pressure
    tensor ``pressure_<ab>`` (``xx, yy, zz, xy, xz, yz``; 2D ``xx, yy, xy``; :func:`pressure_tensor`,
    whose trace over :math:`d` is ``pressure``; not in DEM runs or with a vibrating wall), and the
    energy flux ``energy_flux_<a>``: :math:`\\mathbf J_E/V` with
    :math:`\\mathbf J_E = \\sum_i e_i\\mathbf v_i + \\sum_{\\rm coll}\\tfrac12\\mathbf r_{ij}(\\Delta e_i - \\Delta e_j)` (physics.md §5.6;
    not under gravity, with square wells or white noise either). eMD* runs
    (:class:`edmd.physics.emdstar.EMDStar`) add the cumulative counters ``emd_contacts`` (A events),
    ``emd_exceptions_a``, ``emd_exceptions_b`` and ``emd_fallbacks`` (physics.md §4.8); their
    energies and temperatures use committed velocities. Runs with a thermostat, forcing
    (:mod:`edmd.physics.thermostats`) or updaters (:mod:`edmd.run.updaters`) add the cumulative
    ``energy_input``, which ``energy_balance`` subtracts. Sheared runs (:class:`edmd.Shear`) report
    energies, temperatures, the kinetic stress and momenta relative to the flow (peculiar
    velocities) and add the cumulative ``shear_work`` of the sliding boundaries (the viscous heating
    :math:`-\\dot\\gamma V\\int P_{xy}dt`), which ``energy_balance`` subtracts too. The first row has no interval (NaN).
    An existing CSV file is appended to; its header must name the same columns (``ValueError``
    naming the file and the differing columns otherwise).

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(256, 0.1), 1.0, seed=1))
        >>> th = sim.add(Thermo(interval=1.0))
        >>> sim.run(until_time=3.0)
        >>> [round(r["time"], 6) for r in th.rows], round(th.rows[-1]["temperature"], 9)
        ([0.0, 1.0, 2.0, 3.0], 1.0)
    """

    reads_once = True  # (its row is made while it fires)

    def __init__(self, interval: float, path: str | os.PathLike | None = None, start: float | None = None):
        super().__init__(interval, start)
        self.rows: list[dict] = []
        self.path = path
        self._file = None
        self._writer = None
        self._last: Totals | None = None
        self._table: np.ndarray | None = None  # without a file: the rows as float64, grown by doubling (:meth:`_record`)
        self._file_rows = 0  # the rows of the file (an appended-to file's included)
        self._tensor: bool | None = None  # False: continuing a table without the pressure tensor
        self._flux: bool | None = None  # ... without the energy flux

    def observe(self, sim: Simulation, state: State, totals: Totals):
        state = sim.peculiar_state(state)  # (sheared: relative to the flow)
        kinetic, rotational = state.kinetic_energy(), state.rotational_energy()
        potential = state.potential_energy(sim.gravity) + sim.elastic_energy + sim.well_energy  # + soft contacts (DEM), square wells
        row = {
            "time": totals.time,
            "events": totals.events,
            "collisions": totals.collisions,
            "kinetic_energy": kinetic,
            "temperature": state.temperature(),
            "rotational_energy": rotational,
            "temperature_rot": state.rotational_temperature(),
            "potential_energy": potential,
            "dissipated_energy": totals.dissipated,
            "energy_balance": kinetic + rotational + potential + totals.dissipated - totals.energy_input - totals.shear_work,
            "pressure": math.nan,
            "collision_rate": math.nan,
            "wall_collisions": totals.wall_collisions,
        }
        walls = np.flatnonzero(~state.periodic)
        for k in walls:
            row[f"wall_pressure_{AXES[k]}"] = math.nan
        tensor = self._tensor is not False and totals.stress_integral is not None
        if tensor:
            row.update({f"pressure_{name}": math.nan for _c, name in tensor_components(state.dim)})
        flux = self._flux is not False and totals.energy_flux_integral is not None
        if flux:
            row.update({f"energy_flux_{AXES[k]}": math.nan for k in range(state.dim)})
        last = self._last
        if last is not None and totals.time > last.time:
            dt = totals.time - last.time
            row["pressure"] = pressure(state, totals.kinetic_integral - last.kinetic_integral, totals.virial - last.virial, dt)
            row["collision_rate"] = 2.0 * (totals.collisions - last.collisions) / (state.n * dt)
            for k in walls:
                area = state.volume / state.box[k]
                row[f"wall_pressure_{AXES[k]}"] = float((totals.wall_impulse[k] - last.wall_impulse[k]).sum()) / (2.0 * area * dt)
            if tensor and last.stress_integral is not None:
                row.update(pressure_tensor(state, totals.stress_integral - last.stress_integral, dt))
            if flux and last.energy_flux_integral is not None:
                q = (totals.energy_flux_integral - last.energy_flux_integral) / (dt * float(state.volume))
                row.update({f"energy_flux_{AXES[k]}": float(q[k]) for k in range(state.dim)})
        row.update(sim.emd_counters())
        if sim.has_energy_input:
            row["energy_input"] = totals.energy_input
        if sim.shear is not None:
            row["shear_work"] = totals.shear_work
        self._last = totals
        self.rows.append(row)
        if self.path is None:
            self._record(row)
        else:
            self._write(row)

    def _write(self, row):
        if self._file is None:
            new = not os.path.exists(self.path) or os.path.getsize(self.path) == 0
            self._file_rows = 0
            if not new:
                _check_header(self.path, list(row))
                self._file_rows = _check_continues(self.path, row["time"])
            self._file = open(self.path, "a", newline="")
            self._writer = csv.DictWriter(self._file, fieldnames=list(row))
            if new:
                self._writer.writeheader()
        self._writer.writerow(_csv_row(row))
        self._file.flush()
        self._file_rows += 1

    def _record(self, row: dict):
        """Add ``row`` to the float64 table that checkpoints save without a file (grown by
        doubling: a checkpoint after every row would otherwise convert the whole table each time)."""
        k = len(self.rows) - 1
        if self._table is None or k >= len(self._table):
            grown = np.empty((max(16, 2 * k), len(row)))
            if self._table is not None:
                grown[:k] = self._table[:k]
            self._table = grown
        self._table[k] = [float(v) for v in row.values()]

    def checkpoint_data(self) -> dict:
        """Schedule, the totals of the last row and the rows: with a file, how many rows it holds
        and how many are this observer's (the file holds them exactly, forced to disk before every
        checkpoint: saving the table at every checkpoint made runs quadratic in their rows);
        without one, the rows as an exact float64 table."""
        data = super().checkpoint_data()
        columns = self.columns()
        data["columns"] = columns
        data["integer_columns"] = [c for c in columns if self.rows and isinstance(self.rows[0][c], int)]
        data["last"] = None if self._last is None else self._last.to_dict()
        if self.rows and self.path is not None:
            data["row_count"], data["file_rows"] = len(self.rows), self._file_rows
        elif self.rows:
            data["rows"] = self._table[: len(self.rows)]
        return data

    def columns(self) -> list[str]:
        """The table's columns: :data:`COLUMNS` plus one ``wall_pressure_<axis>`` per wall axis (and eMD*
        counters, ``energy_input`` when a thermostat, forcing or updaters put energy in, ``shear_work`` under shear)."""
        return list(self.rows[0]) if self.rows else list(COLUMNS)

    def restore_data(self, data: dict):
        """Continue from a checkpoint; the CSV file is rewritten (atomically) from the saved rows."""
        super().restore_data(data)
        columns, ints = list(data["columns"]), set(data["integer_columns"])
        extra = columns[len(COLUMNS) :]
        if columns[: len(COLUMNS)] != list(COLUMNS) or not all(c.startswith(("wall_pressure_", "pressure_", "energy_flux_", "emd_", "energy_input", "shear_work")) for c in extra):
            raise ValueError(
                f"thermo columns {columns} differ from this version's {list(COLUMNS)} (+ wall pressures, pressure tensor, energy flux, "
                "eMD* counters, energy input, shear work)"
            )
        self.close()
        if "file_rows" in data:  # (the rows are in the file: cut it back to the checkpoint's)
            self.rows = self._cut_file(columns, ints, int(data["file_rows"]), int(data["row_count"]))
        else:
            table = np.asarray(data.get("rows", np.zeros((0, len(columns)))), np.float64)
            self.rows = [{c: int(v) if c in ints else float(v) for c, v in zip(columns, r)} for r in table]
            self._table = table.copy() if len(table) and self.path is None else None
            if self.path is not None:  # (a checkpoint of an older edmd, or no rows yet: an empty file, whose header the first row writes)
                buf = io.StringIO(newline="")
                if self.rows:
                    writer = csv.DictWriter(buf, fieldnames=columns)
                    writer.writeheader()
                    writer.writerows(_csv_row(r) for r in self.rows)
                write_atomic(self.path, buf.getvalue())
            self._file_rows = len(self.rows)
        self._tensor = ("pressure_xx" in columns) if self.rows else None
        self._flux = ("energy_flux_x" in columns) if self.rows else None
        self._last = None if data["last"] is None else Totals.from_dict(data["last"])

    def _cut_file(self, columns: list[str], ints: set[str], file_rows: int, count: int) -> list[dict]:
        """Keep the header and the first ``file_rows`` rows of the file (rewritten atomically: rows
        an interrupted run wrote after the checkpoint, and a row cut mid-write, go); returns the
        last ``count`` of them, this observer's, as rows."""
        with open(self.path, newline="") as f:
            lines = f.read().splitlines(keepends=True)
        complete = len(lines) - 1 - (1 if lines and not lines[-1].endswith(("\n", "\r")) else 0)
        if complete < file_rows:
            raise ValueError(f"{self.path} holds {max(complete, 0)} rows, fewer than the {file_rows} the checkpoint counts")
        if next(csv.reader(lines[:1]), []) != columns:
            raise ValueError(f"{self.path} has other columns than the checkpoint's: {columns}")
        write_atomic(self.path, "".join(lines[: file_rows + 1]))
        self._file_rows = file_rows
        rows = csv.reader(lines[file_rows + 1 - count : file_rows + 1])
        return [{c: int(v) if c in ints else float(v) for c, v in zip(columns, r)} for r in rows]

    def table(self) -> dict[str, np.ndarray]:
        """The rows as a dict of column arrays."""
        return {c: np.array([r[c] for r in self.rows]) for c in self.columns()}

    def sync(self):
        fsync_existing(self.path)

    def close(self):
        if self._file is not None:
            self._file.close()
            self._file = None


def _check_header(path, columns: list[str]):
    """Raise ``ValueError`` naming ``path`` and the differing columns if its header is not ``columns``."""
    with open(path, newline="") as f:
        have = next(csv.reader(f), [])
    if have == columns:
        return
    old, now = [c for c in have if c not in columns], [c for c in columns if c not in have]
    diff = f"only in the file: {old}; only in this run: {now}" if old or now else "the same columns in another order"
    raise ValueError(f"{path} has the thermo columns {have}; this run writes {columns} ({diff}): remove the file or write to another one")


def _check_continues(path, time: float) -> int:
    """Raise ``ValueError`` if the rows of ``path`` reach ``time`` (appending would mix two runs);
    returns how many rows it holds."""
    times = read_thermo(path).get("time", ())
    if len(times) and not times[-1] < time:
        raise ValueError(
            f"{path} ends at time {float(times[-1])!r}, and this run's rows start at {time!r}: the rows of two runs would mix; "
            "remove the file or write to another one"
        )
    return len(times)


def _csv_row(row: dict) -> dict:
    """A thermo row as CSV cells: floats as their shortest exact ``repr``."""
    return {k: repr(float(v)) if isinstance(v, float) else v for k, v in row.items()}


def read_thermo(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read a thermo CSV written by :class:`Thermo` into a dict of column arrays.

    A last line without its newline is a row still being written (a running simulation, or one
    killed mid-write) and is left out; any other row that is not a full row of numbers is an
    error naming the file and its line.
    """
    with open(path, newline="") as f:
        text = f.read()
    lines = text.splitlines(keepends=True)
    if lines and not lines[-1].endswith(("\n", "\r")):
        lines.pop()
    try:
        table = list(csv.reader(lines))
    except csv.Error as exc:
        raise ValueError(f"{path} is not a thermo table: {exc}") from exc
    if len(table) < 2:
        return {}
    header = table[0]
    for k, row in enumerate(table[1:], start=2):
        if len(row) != len(header):
            raise ValueError(f"{path}, line {k}: {len(row)} cells where the header names {len(header)} columns")
    try:
        return {c: np.array([float(row[m]) for row in table[1:]]) for m, c in enumerate(header)}
    except ValueError as exc:
        raise ValueError(f"{path} is not a thermo table of numbers: {exc}") from exc
