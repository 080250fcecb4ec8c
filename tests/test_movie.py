"""`edmd movie`: one movie frame per trajectory frame, coloured by the chosen quantity; clear errors."""

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

import edmd
import edmd.app.movie as movie
from edmd.app.cli import app
from edmd.app.movie import MovieError, colour_values, local_packing_fraction, make_movie, plot_frame
from edmd.files.trajectory import iter_states

runner = CliRunner()


def _run(directory, dim, n, until=2.0):
    state = edmd.maxwell_boltzmann(edmd.random_packing(n, 0.25, dim=dim, seed=3), 1.0, seed=3)
    sim = edmd.Simulation(state, e_n=0.8)
    sim.add(edmd.Trajectory(directory / "trajectory.gsd", 0.5))
    sim.run(until_time=until)
    sim.close()
    return directory


@pytest.fixture(scope="module")
def run2d(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("run2d"), 2, 300)  # frames at t = 0, 0.5, ..., 2


@pytest.fixture(scope="module")
def run3d(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("run3d"), 3, 400, until=1.0)


def _neighbour_count(state, r):
    """Brute force: particles within r (minimum image on periodic axes), itself included."""
    d = state.position[:, None, :] - state.position[None, :, :]
    d = np.where(state.periodic, d - state.box * np.round(d / state.box), d)
    return (np.linalg.norm(d, axis=2) <= r).sum(axis=1)


def test_gif_has_one_frame_per_trajectory_frame(run2d):
    path = make_movie(run2d, fps=4)
    assert path == run2d / "movie.gif"
    with Image.open(path) as gif:
        assert gif.n_frames == 5 and gif.size == (550, 500)
        assert gif.info["duration"] == 250  # 1000 ms / 4 fps
    assert not list(run2d.glob(".*partial*"))
    every_third = make_movie(run2d / "trajectory.gsd", run2d / "short.gif", frames=2)  # frames 0 and 3
    with Image.open(every_third) as gif:
        assert gif.n_frames == 2


def test_every_frame_is_coloured_by_the_chosen_quantity(run2d, monkeypatch):
    drawn = []
    draw = movie._draw

    def spy(ax, state, color_by, particles, slab, centre):
        coll = draw(ax, state, color_by, particles, slab, centre)
        drawn.append((state, particles, coll.get_array().copy(), coll.get_offsets().copy()))
        return coll

    monkeypatch.setattr(movie, "_draw", spy)
    for color_by in ("speed", "density"):
        drawn.clear()
        make_movie(run2d, run2d / f"{color_by}.gif", color_by=color_by, max_particles=120)
        assert [s.time for s, *_ in drawn] == [s.time for s in iter_states(run2d / "trajectory.gsd")]
        same = drawn[0][1]
        assert len(same) == 120 and len(np.unique(same)) == 120  # a subset, the same in every frame
        for state, particles, values, offsets in drawn:
            assert np.array_equal(particles, same)
            assert np.allclose(offsets, state.position[particles])
            assert np.array_equal(values, colour_values(state, color_by)[particles])
    with Image.open(run2d / "speed.gif") as a, Image.open(run2d / "density.gif") as b:
        assert np.asarray(a.convert("RGB")).tolist() != np.asarray(b.convert("RGB")).tolist()


def test_speed_is_in_units_of_the_rms_speed(run2d):
    state = list(iter_states(run2d / "trajectory.gsd"))[-1]  # cooled: T < T0
    coll = plot_frame(state, "speed").collections[0]
    speed = np.linalg.norm(state.velocity, axis=1)
    assert np.allclose(coll.get_array(), speed / np.sqrt(np.mean(speed**2)), rtol=1e-14)
    assert (coll.norm.vmin, coll.norm.vmax) == (0.0, 3.0)


def test_density_is_the_local_packing_fraction(run2d, run3d):
    for run in (run2d, run3d):
        state = list(iter_states(run / "trajectory.gsd"))[-1]
        r = 3.0 * 2.0 * state.radius.mean()  # DENSITY_RADIUS mean diameters
        expected = _neighbour_count(state, r) * np.mean(state.radius**state.dim) / r**state.dim
        assert np.allclose(local_packing_fraction(state), expected, rtol=1e-14)
        # a homogeneous gas: the mean local packing fraction is the packing fraction (the self count adds ~1 / n_R)
        assert abs(expected.mean() - state.packing_fraction) < 0.15 * state.packing_fraction
    walls = edmd.random_packing(300, 0.25, dim=3, periodic=[True, True, False], seed=4)
    r = 1.5
    expected = _neighbour_count(walls, r) * np.mean(walls.radius**3) / r**3
    assert np.allclose(local_packing_fraction(walls, radius=r), expected, rtol=1e-14)
    some = np.array([5, 17, 200])
    assert np.allclose(local_packing_fraction(walls, radius=r, particles=some), expected[some], rtol=1e-14)
    coll = plot_frame(walls, "density").collections[0]
    assert coll.norm.vmax == pytest.approx(np.pi / (3 * np.sqrt(2)))  # fcc close packing


def test_3d_frames_show_the_slab(run3d):
    state = list(iter_states(run3d / "trajectory.gsd"))[0]
    coll = plot_frame(state, "speed", slab=2.0, slab_centre=0.5).collections[0]
    inside = np.abs(state.position[:, 2] - 0.5) <= 1.0
    assert 0 < inside.sum() < state.n
    assert np.allclose(coll.get_offsets(), state.position[inside, :2])
    assert np.array_equal(coll.get_array(), colour_values(state, "speed")[inside])
    with Image.open(make_movie(run3d, color_by="density")) as gif:
        assert gif.n_frames == 3


def test_cli_writes_the_movie(run2d):
    out = run2d / "cli.gif"
    r = runner.invoke(app, ["movie", str(run2d), "--out", str(out), "--color", "density", "--fps", "5"])
    assert r.exit_code == 0, r.output
    with Image.open(out) as gif:
        assert gif.n_frames == 5 and gif.info["duration"] == 200


@pytest.mark.parametrize(
    "args, message",
    [
        (["--color", "spin"], "unknown colouring 'spin'; choose from speed, density"),
        (["--out", "m.avi"], "unknown movie format '.avi'"),
        (["--out", "m"], "unknown movie format '(no extension)'"),
    ],
)
def test_cli_bad_options(run2d, args, message):
    r = runner.invoke(app, ["movie", str(run2d), *args])
    assert r.exit_code == 2 and message in " ".join(r.output.split()), r.output


def test_cli_missing_trajectory(tmp_path):
    r = runner.invoke(app, ["movie", str(tmp_path / "nope")])
    assert r.exit_code == 2 and "does not exist" in r.output
    r = runner.invoke(app, ["movie", str(tmp_path)])  # a directory without trajectory.gsd
    assert r.exit_code == 2 and "no trajectory frames" in r.output


def test_mp4_without_ffmpeg_is_a_clear_error(run2d, monkeypatch):
    from matplotlib import animation

    monkeypatch.setattr(animation.writers, "is_available", lambda name: name != "ffmpeg")
    r = runner.invoke(app, ["movie", str(run2d), "--out", str(run2d / "m.mp4")])
    assert r.exit_code == 2 and "needs ffmpeg" in " ".join(r.output.split())
    with pytest.raises(MovieError, match="needs ffmpeg"):
        make_movie(run2d, run2d / "m.MP4")


@pytest.mark.skipif(not __import__("matplotlib.animation").animation.writers.is_available("ffmpeg"), reason="ffmpeg not installed")
def test_mp4_with_ffmpeg(run2d):
    path = make_movie(run2d, run2d / "m.mp4")
    assert path.stat().st_size > 0


def test_clustering_example_writes_its_figure(tmp_path, monkeypatch):
    """examples/clustering_2d.py (shortened): a run directory `edmd movie` reads, and the showcase PNG."""
    import importlib.util
    from pathlib import Path

    from matplotlib.image import imread

    path = Path(__file__).resolve().parents[1] / "examples" / "clustering_2d.py"
    spec = importlib.util.spec_from_file_location("clustering_2d", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    monkeypatch.setattr(example, "N", 300)
    monkeypatch.setattr(example, "UNTIL", 20.0)
    monkeypatch.setattr(example, "INTERVAL", 10.0)
    monkeypatch.setattr(example, "FIGURE", tmp_path / "showcase.png")
    example.main([str(tmp_path / "run")])
    assert imread(tmp_path / "showcase.png").shape[0] > 500
    with Image.open(make_movie(tmp_path / "run", color_by="density")) as gif:
        assert gif.n_frames == 3
