"""Thermo output: columns, pressure formula, CSV round trip."""

import math

import numpy as np
import pytest

import edmd
from edmd import Simulation, Thermo, read_thermo
from edmd.files.thermo import COLUMNS, pressure


def test_ideal_gas_pressure_formula(dim):
    # no collisions in the window: P = n T exactly (physics.md §5.3 with zero virial)
    s = edmd.maxwell_boltzmann(edmd.lattice(100, 0.01, dim=dim), 1.3, seed=1)
    p = pressure(s, d_kinetic_integral=s.kinetic_energy() * 2.0, d_virial=0.0, dt=2.0)
    assert p == pytest.approx(s.n / s.volume * 1.3, rel=1e-12)


def test_thermo_rows_and_csv(tmp_path, dim):
    sim = Simulation(edmd.maxwell_boltzmann(edmd.lattice(300, 0.3, dim=dim), 1.0, seed=2))
    th = sim.add(Thermo(0.5, path=tmp_path / "thermo.csv"))
    sim.run(until_time=2.0)
    sim.close()
    table = read_thermo(tmp_path / "thermo.csv")
    for col in ("time", "events", "collisions", "temperature", "pressure", "collision_rate", "kinetic_energy"):
        assert col in table
    assert table["time"].tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert math.isnan(table["pressure"][0]) and np.all(table["pressure"][1:] > 0)
    assert np.allclose(table["temperature"], 1.0, rtol=1e-12)
    assert np.array_equal(table["collisions"], [r["collisions"] for r in th.rows])
    assert table["collision_rate"][-1] == pytest.approx(
        2 * (table["collisions"][-1] - table["collisions"][-2]) / (300 * 0.5), rel=1e-12
    )


def test_pressure_survives_resyncs(dim):
    # the cumulative kinetic-energy integral is carried across maintenance resyncs
    runs = []
    for resync in (1e9, 0.5):
        sim = Simulation(edmd.maxwell_boltzmann(edmd.lattice(300, 0.3, dim=dim), 1.0, seed=3), engine={"resync_every": resync})
        th = sim.add(Thermo(1.0))
        sim.run(until_time=3.0)
        runs.append(th.table()["pressure"][1:])
    assert np.allclose(runs[0], runs[1], rtol=0.05)
    s = edmd.lattice(300, 0.3, dim=dim)
    ideal = s.n / s.volume
    assert np.all(runs[1] > ideal)


def _thermo_run(path, until=1.0):
    sim = Simulation(edmd.maxwell_boltzmann(edmd.lattice(64, 0.2), 1.0, seed=2))
    sim.add(Thermo(0.5, path=path))
    sim.run(until_time=until)
    sim.close()


#: the columns of a 3D run in a periodic box (pressure tensor, energy flux)
RUN_COLUMNS = [*COLUMNS, *(f"pressure_{c}" for c in ("xx", "yy", "zz", "xy", "xz", "yz")), "energy_flux_x", "energy_flux_y", "energy_flux_z"]


def test_thermo_appends_under_its_own_header(tmp_path):
    p = tmp_path / "thermo.csv"
    p.write_text(",".join(RUN_COLUMNS) + "\n")
    _thermo_run(p)
    assert read_thermo(p)["time"].tolist() == [0.0, 0.5, 1.0]


def test_thermo_refuses_a_file_with_other_columns(tmp_path):
    p = tmp_path / "thermo.csv"
    old = [c for c in RUN_COLUMNS if c != "wall_collisions"] + ["old_counter"]
    p.write_text(",".join(old) + "\n" + ",".join("1" for _ in old) + "\n")
    before = p.read_bytes()
    msg = r"thermo\.csv has the thermo columns .* \(only in the file: \['old_counter'\]; only in this run: \['wall_collisions'\]\)"
    with pytest.raises(ValueError, match=msg):
        _thermo_run(p)
    assert p.read_bytes() == before  # nothing appended under the wrong header
    p.write_text(",".join(reversed(RUN_COLUMNS)) + "\n")
    with pytest.raises(ValueError, match="the same columns in another order"):
        _thermo_run(p)


def test_read_thermo_leaves_out_a_row_being_written_and_names_a_broken_one(tmp_path):
    p = tmp_path / "thermo.csv"
    p.write_text("time,collisions\n0.0,0\n0.5,12\n1.0,2")  # the last row still being written
    table = read_thermo(p)
    assert list(table) == ["time", "collisions"] and table["time"].tolist() == [0.0, 0.5] and table["collisions"].tolist() == [0, 12]
    p.write_text("time,collisions\n0.0,0\n0.5\n1.0,30\n")
    with pytest.raises(ValueError, match=r"thermo\.csv, line 3: 1 cells where the header names 2 columns"):
        read_thermo(p)
    p.write_text("time,collisions\n0.0,zero\n")
    with pytest.raises(ValueError, match="not a thermo table of numbers"):
        read_thermo(p)


def test_thermo_does_not_append_a_second_run_to_the_rows_of_a_first(tmp_path):
    p = tmp_path / "thermo.csv"
    _thermo_run(p)
    before = p.read_bytes()
    with pytest.raises(ValueError, match=r"thermo\.csv ends at time 1\.0, and this run's rows start at 0\.0: the rows of two runs would mix"):
        _thermo_run(p)
    assert p.read_bytes() == before
