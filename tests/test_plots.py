"""Plots: the data on the Axes is the data analysed; `edmd plot` writes real images."""

import json

import numpy as np
import pytest
from matplotlib.collections import EllipseCollection
from matplotlib.image import imread
from typer.testing import CliRunner

import edmd
from edmd.analysis import MSD, RDF, HaffLaw, VelocityDistribution
from edmd.cli import app
from edmd.plots import plot_energy, plot_run, plot_snapshot, plot_temperature, save


def _cooling(tmp_path, dim=3):
    state = edmd.maxwell_boltzmann(edmd.lattice(500, 0.2, dim=dim), 1.0, seed=1)
    sim = edmd.Simulation(state, e_n=0.8)
    th = sim.add(edmd.Thermo(0.5, path=tmp_path / "thermo.csv"))
    sim.add(edmd.Trajectory(tmp_path / "trajectory.gsd", 1.0))
    sim.run(until_time=5.0)
    sim.close()
    return state, th


def test_temperature_plot_shows_the_data_and_haffs_law(tmp_path):
    state, th = _cooling(tmp_path)
    haff = HaffLaw.from_state(state, e_n=0.8)
    ax = plot_temperature(th, haff)
    data, law = ax.get_lines()
    table = th.table()
    assert np.array_equal(data.get_xdata(), table["time"][1:]) and np.array_equal(data.get_ydata(), table["temperature"][1:])
    assert np.allclose(law.get_ydata(), haff(table["time"][1:]), rtol=1e-14)
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert "Haff" in ax.get_legend().get_texts()[-1].get_text()
    plain = plot_temperature(tmp_path / "thermo.csv")  # elastic-style: linear axes, all rows
    assert plain.get_xscale() == "linear" and len(plain.get_lines()[0].get_xdata()) == len(table["time"])


def test_energy_plot_adds_up_and_skips_missing_columns(tmp_path):
    _, th = _cooling(tmp_path)
    table = th.table()
    ax = plot_energy(table)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["kinetic energy", "dissipated energy", "sum (conserved)"]
    total = ax.get_lines()[-1].get_ydata()
    assert np.allclose(total, table["kinetic_energy"] + table["dissipated_energy"])
    assert np.allclose(total, total[0], rtol=1e-9)  # energy balance of smooth inelastic spheres
    table["rotational_energy"] = np.full_like(table["time"], 2.0)  # a column added by rough spheres
    assert len(plot_energy(table).get_lines()) == 4


def test_snapshot_draws_particles_to_scale(dim):
    s = edmd.maxwell_boltzmann(edmd.random_packing(300, 0.3, dim=dim, seed=2, radius={"kind": "uniform", "min": 0.4, "max": 0.6}), 1.0, seed=3, spin=True)
    ax = plot_snapshot(s, color_by="spin")
    (coll,) = [c for c in ax.collections if isinstance(c, EllipseCollection)]
    keep = np.ones(s.n, bool) if dim == 2 else np.abs(s.position[:, 2]) <= s.radius.mean()
    assert 0 < keep.sum() <= s.n
    assert np.array_equal(coll.get_offsets(), s.position[keep, :2])
    spin = s.angular_velocity if dim == 2 else np.linalg.norm(s.angular_velocity, axis=1)
    assert np.array_equal(coll.get_array(), spin[keep])
    assert np.allclose(coll.get_widths(), 2 * s.radius[keep])  # diameters in data units
    assert ax.get_xlim() == (-s.box[0] / 2, s.box[0] / 2) and ax.get_aspect() == 1.0
    with pytest.raises(ValueError, match="color_by"):
        plot_snapshot(s, color_by="size")


def test_analysis_plots_show_their_results(tmp_path):
    s = edmd.maxwell_boltzmann(edmd.lattice(2000, 0.3), 1.0, seed=1)
    vd = VelocityDistribution().compute(s)
    lines = vd.plot().get_lines()
    assert np.array_equal(lines[0].get_ydata(), vd.pdf) and np.array_equal(lines[1].get_ydata(), vd.maxwell)
    g = RDF(bins=30, r_max=2.5).compute(s)
    assert np.array_equal(g.plot().get_lines()[0].get_ydata(), g.rdf)
    frames = [s]
    for t in (1.0, 2.0, 3.0):
        f = s.copy()
        f.position, f.image = s.position, s.image + int(t)  # each particle one box further per frame
        f.time = t
        frames.append(f)
    m = MSD().compute(frames)
    assert np.allclose(m.msd, m.lag_times**2 * np.sum(s.box**2))  # displacement (Lx, Ly, Lz) per unit time
    line = m.plot().get_lines()[0]
    assert np.array_equal(line.get_ydata(), m.msd[1:])
    path = save(line.axes, tmp_path / "msd.png")
    assert imread(path).shape[2] == 4


def _image_is_not_blank(path):
    img = imread(path)
    return img.ndim == 3 and img.shape[0] > 100 and np.ptp(img[..., :3]) > 0.5


def test_plot_run_writes_every_figure(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        "[system]\ndim = 2\nn = 400\npacking_fraction = 0.3\n[collision]\nrule = 'inelastic'\ne_n = 0.9\n"
        "[run]\nuntil_time = 4.0\noutput_interval = 0.5\nprogress = false\n"
    )
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 0, r.output
    names = {"temperature.png", "energy.png", "velocity_distribution.png", "rdf.png", "msd.png", "snapshot.png"}
    assert set(json.loads((out / "summary.json").read_text())["plots"]) == names
    for name in names:
        assert _image_is_not_blank(out / name), name
    (out / "rdf.png").unlink()
    r = CliRunner().invoke(app, ["plot", str(out)])
    assert r.exit_code == 0 and (out / "rdf.png").exists()
    assert {p.name for p in plot_run(out)} == names


def test_plot_run_errors(tmp_path):
    r = CliRunner().invoke(app, ["plot", str(tmp_path / "missing")])
    assert r.exit_code == 2 and "no run directory" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(app, ["plot", str(tmp_path)])
    assert r.exit_code == 2 and "nothing to plot" in r.output
