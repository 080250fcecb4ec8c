"""Plots: the data on the Axes is the data analysed; `edmd plot` writes real images."""

import json
import tomllib
import warnings

import numpy as np
import pytest
from matplotlib.collections import EllipseCollection
from matplotlib.image import imread
from typer.testing import CliRunner

import edmd
import edmd.app.plots as plots
from edmd.analysis import MSD, RDF, HaffLaw, VelocityDistribution, compressibility_factor
from edmd.app.cli import app
from edmd.app.config import load_config, parse_config
from edmd.app.plots import plot_energy, plot_run, plot_snapshot, plot_temperature, run_figures, save
from edmd.app.runner import run_directory
from edmd.files.thermo import read_thermo
from edmd.files.trajectory import iter_states, read_state, write_state

EXAMPLES = __import__("pathlib").Path(__file__).resolve().parents[1] / "examples"


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
    ax = plot_snapshot(s, color_by="spin", slab_centre=0.0)
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
    figures = run_figures(out)
    for name, fig in figures.items():  # every title names the run and its key parameters
        assert all(part in fig.get_suptitle() for part in ("run:", "N = 400", "2D", "eta = 0.3", "inelastic", "e_n = 0.9")), name
    assert "from the first frame" in _legend(figures["msd"])  # a cooling gas is not stationary
    (out / "rdf.png").unlink()
    r = CliRunner().invoke(app, ["plot", str(out)])
    assert r.exit_code == 0 and (out / "rdf.png").exists()
    assert {p.name for p in plot_run(out)} == names


def test_a_granular_gas_at_rest_plots_without_haffs_law(tmp_path):
    """kT = 0: Haff's time scale is infinite (the figures crashed with a ZeroDivisionError)."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        "[system]\ndim = 2\nn = 64\npacking_fraction = 0.3\nkT = 0.0\n[collision]\nrule = 'inelastic'\ne_n = 0.9\n"
        "[run]\nuntil_time = 1.0\noutput_interval = 0.5\nprogress = false\n"
    )
    r = CliRunner().invoke(app, ["run", str(cfg), "--out", str(tmp_path / "run")])
    assert r.exit_code == 0, r.output
    assert _image_is_not_blank(tmp_path / "run" / "temperature.png")


def test_plot_run_errors(tmp_path):
    r = CliRunner().invoke(app, ["plot", str(tmp_path / "missing")])
    assert r.exit_code == 2 and "no run directory" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(app, ["plot", str(tmp_path)])
    assert r.exit_code == 2 and "nothing to plot" in r.output


def _legend(fig, k=0):
    return " | ".join(t.get_text() for t in fig.axes[k].get_legend().get_texts())


def _run(tmp_path, text, name="run"):
    """Run a configuration (TOML text) into a directory; returns the directory and its figures."""
    cfg = parse_config(tomllib.loads(text + "\n[run]\nprogress = false\n" if "[run]" not in text else text + "\nprogress = false\n"))
    out = tmp_path / name
    run_directory(cfg, out)
    return out, run_figures(out)


def _ellipses(fig):
    (coll,) = [c for ax in fig.axes for c in ax.collections if isinstance(c, EllipseCollection)]
    return coll


def test_gravity_run_snapshot_is_a_side_view_of_the_particles(tmp_path):
    """Beads resting on the floor of a tall box (z closed, g along -z): the old top view cut the slab
    at z = 0, half a box above them, and drew nothing. The side view (x, z) shows every bead within
    the slab across y; g(r) is left out (the density is not uniform under gravity)."""
    grid = np.stack(np.meshgrid(np.arange(-4.2, 4.3, 1.2), np.arange(-4.2, 4.3, 1.2)), -1).reshape(-1, 2)
    pos = np.column_stack([grid, np.full(len(grid), -12.0 + 0.5 + 1e-3)])
    floor = edmd.maxwell_boltzmann(edmd.State(position=pos, velocity=np.zeros_like(pos), radius=0.5, mass=1.0, box=[12.0, 12.0, 24.0],
                                              periodic=[True, True, False]), 0.01, seed=1)  # fmt: skip
    write_state(tmp_path / "floor.gsd", floor)
    out, figures = _run(tmp_path, f"[system]\nfrom_file = '{tmp_path / 'floor.gsd'}'\ngravity = [0.0, 0.0, -1.0]\n"
                                  "[walls]\naxes = ['z']\n[run]\nuntil_time = 0.5\noutput_interval = 0.25")  # fmt: skip
    final = read_state(out / "trajectory.gsd", check_overlaps=False)
    assert np.all(final.position[:, 2] < -10)  # still on the floor
    coll, ax = _ellipses(figures["snapshot"]), figures["snapshot"].axes[0]
    y = final.position[:, 1]
    in_slab = np.abs(y - np.sort(y)[y.size // 2]) <= 0.5  # the slab through the median bead
    assert in_slab.sum() >= 8 and np.array_equal(coll.get_offsets(), final.position[in_slab][:, [0, 2]])
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x", "z") and ax.get_ylim() == (-12.0, 12.0)
    assert "rdf" not in figures
    assert "g = (0, 0, -1)" in figures["snapshot"].get_suptitle()


def test_single_particle_run_plots_its_height_not_a_temperature(tmp_path):
    """The bouncing ball (N = 1): its temperature is round-off noise; the height above the floor,
    z + L/2 - R, and its energies are what the run is about."""
    cfg = load_config(EXAMPLES / "bouncing_ball.toml")
    cfg.run.until_time, cfg.run.progress = 0.3, False
    run_directory(cfg, tmp_path)
    figures = run_figures(tmp_path)
    assert set(figures) == {"height", "energy", "snapshot"}
    ylabels = [ax.get_ylabel() for fig in figures.values() for ax in fig.axes]
    assert not any("temperature" in y for y in ylabels)
    states = list(iter_states(tmp_path / "trajectory.gsd", check_overlaps=False))
    height = figures["height"].axes[0].get_lines()[0]
    assert np.allclose(height.get_ydata(), [s.position[0, 2] + s.box[2] / 2 - s.radius[0] for s in states], rtol=1e-12)
    assert np.array_equal(height.get_xdata(), [s.time for s in states])
    assert height.get_ydata()[0] == pytest.approx(states[0].box[2] / 2 - states[0].radius[0])  # dropped from the centre
    assert min(height.get_ydata()) < 0.1 * height.get_ydata()[0]  # and it reached the floor
    assert len(_ellipses(figures["snapshot"]).get_offsets()) == 1
    assert "N = 1," in figures["height"].get_suptitle()


def test_vibrated_bed_plots_its_profiles(tmp_path):
    """A bed on a vibrating wall: density, temperature and mean velocity along the vibration
    axis over the second half of the run, densest near the floor."""
    cfg = load_config(EXAMPLES / "vibrated_bed_2d.toml")
    cfg.run.until_time, cfg.run.progress = 20.0, False
    run_directory(cfg, tmp_path)
    figures = run_figures(tmp_path)
    assert "profile_y" in figures and "temperature" not in figures
    density = figures["profile_y"].axes[0].get_lines()[0]
    y, n = density.get_xdata(), density.get_ydata()
    assert [ax.get_ylabel() for ax in figures["profile_y"].axes] == ["number density", "granular temperature", "mean v_y"]
    assert y[np.nanargmax(n)] < y.min() + 0.25 * (y.max() - y.min())


def test_elastic_run_compares_the_pressure_with_the_equation_of_state(tmp_path):
    """Elastic hard spheres, eta = 0.3: Z = P/(nT) against Carnahan-Starling Z = 3.97376. For 500
    spheres the mean of the rows after t = 1 (4 time units) scatters by ~1-2 % (test_analysis: 0.5 %
    for 2000 spheres over 8 units): 5 %."""
    out, figures = _run(tmp_path, "[system]\nn = 500\npacking_fraction = 0.3\n[run]\nuntil_time = 5.0\noutput_interval = 0.25")
    assert "temperature" not in figures
    ax_p, ax_z = figures["pressure"].axes
    data, eos = ax_z.get_lines()
    z_cs = compressibility_factor(0.3, 3)
    assert np.allclose(eos.get_ydata(), z_cs, rtol=1e-12) and "Carnahan" in eos.get_label()
    table = read_thermo(out / "thermo.csv")
    n = 500 / read_state(out / "trajectory.gsd", 0).volume
    assert np.allclose(data.get_ydata(), table["pressure"] / (n * table["temperature"]), equal_nan=True)
    assert np.nanmean(data.get_ydata()[table["time"] > 1]) == pytest.approx(z_cs, rel=0.05)
    assert np.allclose(ax_p.get_lines()[1].get_ydata(), n * table["temperature"] * z_cs)
    assert "all time origins" in _legend(figures["msd"])  # stationary: averaged over time origins


def test_elastic_run_between_walls_has_g_of_r_near_one(tmp_path):
    """A closed box (walls on every axis, 1000 spheres, eta = 0.2, ~13 diameters wide): g(r) at
    3-5 diameters levelled off near 0.67 with the bulk normalisation. With the accessible
    volume it is ~0.91: the layers at the walls hold ~5 % more particles than their share
    (a real effect of this small box), so the tolerance is 0.15."""
    out, figures = _run(tmp_path, "[system]\nn = 1000\npacking_fraction = 0.2\n[walls]\naxes = ['x', 'y', 'z']\n"
                                  "[run]\nuntil_time = 4.0\noutput_interval = 0.5")  # fmt: skip
    line = figures["rdf"].axes[0].get_lines()[0]
    r, g = line.get_xdata(), line.get_ydata()
    assert abs(g[(r > 3) & (r < 5)].mean() - 1) < 0.15
    assert "P (on the walls)" in _legend(figures["pressure"])


def test_rough_run_plots_both_temperatures_and_their_ratio(tmp_path):
    out, figures = _run(tmp_path, "[system]\ndim = 2\nn = 400\npacking_fraction = 0.2\n[collision]\nrule = 'rough'\ne_n = 0.9\n"
                                  "beta = 0.0\n[run]\nuntil_time = 6.0\noutput_interval = 1.0")  # fmt: skip
    ax_t, ax_r = figures["temperature"].axes
    table = read_thermo(out / "thermo.csv")
    tr, rot = ax_t.get_lines()
    assert ax_t.get_xscale() == ax_t.get_yscale() == "log"
    assert np.array_equal(tr.get_xdata(), table["time"][1:]) and np.array_equal(rot.get_ydata(), table["temperature_rot"][1:])
    assert np.allclose(ax_r.get_lines()[0].get_ydata(), table["temperature_rot"][1:] / table["temperature"][1:])
    assert "from the first frame" in _legend(figures["msd"])  # cooling: no average over time origins
    assert "rough, e_n = 0.9, beta = 0" in figures["temperature"].get_suptitle()


def test_viscoelastic_run_shows_the_t_to_the_minus_five_thirds_law(tmp_path):
    out, figures = _run(tmp_path, "[system]\nn = 300\npacking_fraction = 0.1\n[collision]\nrule = 'viscoelastic'\nyoung = 1e4\n"
                                  "poisson = 0.3\nA = 0.01\n[run]\nuntil_time = 8.0\noutput_interval = 1.0")  # fmt: skip
    ax = figures["temperature"].axes[0]
    data, law = ax.get_lines()
    x, y = law.get_xdata(), law.get_ydata()
    assert np.allclose(np.diff(np.log(y)) / np.diff(np.log(x)), -5 / 3)  # slope -5/3 on log-log axes
    assert y[-1] == pytest.approx(data.get_ydata()[-1]) and "5/3" in law.get_label()


def test_emdstar_run_plots_exception_rates(tmp_path):
    out, figures = _run(tmp_path, "[system]\nn = 216\npacking_fraction = 0.2\ninit = 'lattice'\n[collision]\nrule = 'emdstar'\n"
                                  "contact = 'dashpot'\nk = 1e4\ne_n = 0.9\n[run]\nuntil_time = 1.0\noutput_interval = 0.2")  # fmt: skip
    assert "temperature" not in figures
    table = read_thermo(out / "thermo.csv")
    some = table["emd_contacts"] > 0
    assert some.sum() >= 3
    for line, col in zip(figures["emd_exceptions"].axes[0].get_lines(), ("emd_exceptions_a", "emd_exceptions_b", "emd_fallbacks"), strict=True):
        assert np.allclose(line.get_ydata(), table[col][some] / table["emd_contacts"][some])


def test_signed_spin_uses_a_diverging_colour_map_centred_on_zero():
    s = edmd.maxwell_boltzmann(edmd.lattice(200, 0.3, dim=2), 1.0, seed=1, spin=True)
    coll = _ellipses(plot_snapshot(s, "spin").figure)
    top = np.abs(s.angular_velocity).max()
    assert coll.get_cmap().name == "RdBu_r" and (coll.norm.vmin, coll.norm.vmax) == (-top, top)
    s3 = edmd.maxwell_boltzmann(edmd.lattice(200, 0.3), 1.0, seed=1, spin=True)  # |omega| >= 0 in 3D: sequential
    assert _ellipses(plot_snapshot(s3, "spin").figure).get_cmap().name == "viridis"


def test_large_runs_are_subsampled_for_plots(tmp_path, monkeypatch):
    _cooling(tmp_path, dim=2)
    (tmp_path / "config.toml").write_text("[collision]\nrule = 'inelastic'\ne_n = 0.8\n")
    monkeypatch.setattr(plots, "MAX_PARTICLES", 100)
    seen = []
    compute = VelocityDistribution.compute
    monkeypatch.setattr(VelocityDistribution, "compute", lambda self, states: seen.extend(s.n for s in states) or compute(self, states))
    figures = run_figures(tmp_path)
    assert seen == [100] * 5  # the last 5 frames, 100 of 500 particles each
    assert len(_ellipses(figures["snapshot"]).get_offsets()) == 100 and "100 of 500 shown" in figures["snapshot"].axes[0].get_title()


def test_pressure_of_a_gas_at_rest_has_no_compressibility_factor_and_no_warning():
    """At T = 0 (a bed at rest, a start at kT = 0) Z = P/(nT) is undefined: no points, no
    division warning (it used to print "invalid value encountered in divide")."""
    table = {"time": np.arange(3.0), "temperature": np.array([0.0, 0.0, 1.0]), "pressure": np.array([0.0, 0.0, 2.0])}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, ax_z = plots.plot_pressure(table, edmd.lattice(64, 0.3))
    z = ax_z.get_lines()[0].get_ydata()
    assert np.isnan(z[:2]).all() and z[2] == pytest.approx(2.0 / (64 / edmd.lattice(64, 0.3).volume))
