r"""Movies of a run: GIF (Pillow) or MP4 (ffmpeg) of a 2D run or of the ``z = 0`` slab of a 3D one.

Particles are drawn to scale as in :func:`edmd.app.plots.plot_snapshot`, coloured by

* ``"speed"``: :math:`|\mathbf v|/v_{\rm rms}`, the speed in units of the frame's root-mean-square
  speed (committed velocities, physics.md §4.8), on a fixed scale ``[0, 3]``, so that a cooling
  gas keeps its contrast while it cools;
* ``"density"``: the local packing fraction (:func:`local_packing_fraction`), a neighbour count
  within a ball of radius :data:`DENSITY_RADIUS` mean diameters, on a fixed scale from 0 to close
  packing: clusters of a cooling granular gas stand out bright, voids dark.

Frames are read one at a time (:func:`~edmd.files.trajectory.iter_states`); large systems are drawn
through a fixed random subset of particles (the density is still counted over all of them).
``edmd movie RUN`` does it from the command line.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..files.atomic import atomic_path
from ..analysis._common import axes, box_tree
from .plots import sample_particles, slab_mask
from ..state import State
from ..files.trajectory import frame_count, iter_states

#: writer of each movie format (matplotlib.animation names)
WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}
#: radius of the density ball, in mean particle diameters
DENSITY_RADIUS = 3.0
#: close packing per dimension (hexagonal disks, fcc spheres): the top of the density scale
CLOSE_PACKING = {2: math.pi / (2.0 * math.sqrt(3.0)), 3: math.pi / (3.0 * math.sqrt(2.0))}
#: colour map and label per colouring
COLOURINGS = {"speed": ("viridis", r"speed / rms speed"), "density": ("inferno", "local packing fraction")}


class MovieError(ValueError):
    """A movie cannot be made: bad colouring, missing trajectory, unknown format, no ffmpeg."""


def local_packing_fraction(state: State, radius: float | None = None, particles=None) -> np.ndarray:
    r"""Local packing fraction at each particle (or at ``particles``, indices) from its neighbour count (itself included).

    :math:`\eta_i = n_i\,\langle r^d\rangle / R^d`: the :math:`n_i` particles whose centres lie
    within :math:`R` of particle :math:`i` (minimum image on periodic axes), each given the mean
    particle volume, over the volume of the ball. :math:`R` defaults to :data:`DENSITY_RADIUS`
    mean diameters and is capped at half the shortest periodic box length; balls reaching
    through a wall are not corrected (particles next to walls read lower). Every particle is
    counted, whichever ``particles`` the fraction is evaluated at.

    Example:
        >>> import edmd
        >>> s = edmd.lattice(400, 0.3, dim=2, kind="square")
        >>> a = float(np.sqrt(np.pi * 0.5**2 / 0.3))        # lattice spacing
        >>> eta = local_packing_fraction(s, radius=2.05 * a)  # 13 sites within 2.05 spacings
        >>> bool(np.allclose(eta, eta[0])), round(float(eta[0] / (13 * 0.5**2 / (2.05 * a) ** 2)), 12)
        (True, 1.0)
    """
    box, periodic = state.box, state.periodic
    r = DENSITY_RADIUS * 2.0 * float(state.radius.mean()) if radius is None else float(radius)
    if periodic.any():
        r = min(r, 0.5 * float(box[periodic].min()))
    tree, points = box_tree(state, r)
    counts = tree.query_ball_point(points if particles is None else points[particles], r, return_length=True)
    return counts * float(np.mean(state.radius**state.dim)) / r**state.dim


def colour_values(state: State, color_by: str, particles=None) -> np.ndarray:
    """The colour value of every particle of ``state`` (or of ``particles``, indices): ``"speed"`` or ``"density"``.

    See the module docstring; the rms speed is that of all particles.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(64, 0.2, dim=2), 1.0)
        >>> round(float(np.sqrt(np.mean(colour_values(s, "speed") ** 2))), 12)
        1.0
    """
    check_colouring(color_by)
    if color_by == "density":
        return local_packing_fraction(state, particles=particles)
    speed = np.linalg.norm(state.committed_velocity, axis=1)
    rms = float(np.sqrt(np.mean(speed**2)))
    speed = speed if particles is None else speed[particles]
    return speed / rms if rms > 0 else speed


def check_colouring(color_by: str) -> str:
    """``color_by`` if it names a colouring (``"speed"``, ``"density"``), else :class:`MovieError`.

    Example:
        >>> check_colouring("density")
        'density'
    """
    if color_by not in COLOURINGS:
        raise MovieError(f"unknown colouring {color_by!r}; choose from {', '.join(COLOURINGS)}")
    return color_by


def _norm(color_by: str, dim: int):
    from matplotlib.colors import Normalize

    return Normalize(0.0, 3.0) if color_by == "speed" else Normalize(0.0, CLOSE_PACKING[dim])


def _draw(ax, state: State, color_by: str, particles: np.ndarray, slab: float | None, centre: float | None):
    """Add the particles of ``state`` (of the index set ``particles``; in 3D those in the slab) to ``ax``."""
    from matplotlib.collections import EllipseCollection

    shown, where = particles, ""
    if state.dim == 3:
        keep, centre, half = slab_mask(state, 2, slab, centre)
        shown = particles[keep[particles]]
        where = f", slab |z - {centre:.4g}| <= {half:.3g}"
    d = 2.0 * state.radius[shown]
    values = colour_values(state, color_by, shown)
    coll = EllipseCollection(d, d, np.zeros_like(d), units="xy", offsets=state.position[shown, :2], offset_transform=ax.transData,
                             array=values, cmap=COLOURINGS[color_by][0], norm=_norm(color_by, state.dim))  # fmt: skip
    ax.add_collection(coll)
    ax.set_title(f"t = {state.time:.6g}{where}", fontsize="small")
    return coll


def plot_frame(state: State, color_by: str = "density", ax=None, slab: float | None = None, slab_centre: float | None = None,
               particles=None):  # fmt: skip
    """One movie frame: the particles drawn to scale, coloured by speed or local density, with a colour bar.

    Args:
        state: a 2D state, or a 3D one (the slab ``|z - slab_centre| <= slab/2`` is drawn).
        color_by: ``"speed"`` or ``"density"``.
        ax: Axes to draw on (default: a new Agg Figure).
        slab: slab thickness of 3D states (default one mean diameter).
        slab_centre: the slab's height (default the median ``z``).
        particles: indices of the particles to draw (default: all).

    Returns:
        The Axes; its one collection holds the drawn particles, its array their colour values.

    Example:
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(64, 0.2, dim=2), 1.0)
        >>> ax = plot_frame(s, "speed")
        >>> bool(np.array_equal(ax.collections[0].get_array(), colour_values(s, "speed")))
        True
    """
    check_colouring(color_by)
    from matplotlib.cm import ScalarMappable

    ax = axes(ax, figsize=(5.5, 5.0))
    particles = np.arange(state.n) if particles is None else np.asarray(particles, np.int64)
    _draw(ax, state, color_by, particles, slab, slab_centre)
    half = 0.5 * state.box[:2]
    ax.set_xlim(-half[0], half[0])
    ax.set_ylim(-half[1], half[1])
    ax.set_aspect("equal")
    cmap, label = COLOURINGS[color_by]
    ax.figure.colorbar(ScalarMappable(_norm(color_by, state.dim), cmap), ax=ax, label=label)
    return ax


def trajectory_file(source: str | os.PathLike) -> Path:
    """The GSD file of ``source``: the file itself, or a run directory's ``trajectory.gsd``; checked to hold frames.

    Example:
        >>> trajectory_file("no-such-run")
        Traceback (most recent call last):
        ...
        edmd.app.movie.MovieError: no trajectory: no-such-run does not exist
    """
    path = Path(source)
    if not path.exists():
        raise MovieError(f"no trajectory: {path} does not exist")
    traj = path / "trajectory.gsd" if path.is_dir() else path
    if frame_count(traj) == 0:
        raise MovieError(f"no trajectory frames in {traj}")
    return traj


def movie_writer(out: Path, fps: int):
    """The matplotlib writer for ``out`` by its extension (``.gif``: Pillow, ``.mp4``: ffmpeg).

    Example:
        >>> type(movie_writer(Path("a.gif"), fps=10)).__name__
        'PillowWriter'
    """
    from matplotlib import animation

    name = WRITERS.get(out.suffix.lower())
    if name is None:
        raise MovieError(f"unknown movie format {out.suffix or '(no extension)'!r} of {out}; use {' or '.join(WRITERS)}")
    if not animation.writers.is_available(name):
        raise MovieError(f"writing {out.suffix} needs ffmpeg on the PATH, which was not found; install it or write a .gif")
    if not (isinstance(fps, int) and fps > 0):
        raise MovieError(f"fps must be a positive integer, got {fps!r}")
    return animation.writers[name](fps=fps)


def make_movie(
    source: str | os.PathLike,
    out: str | os.PathLike | None = None,
    color_by: str = "speed",
    fps: int = 10,
    frames: int | None = None,
    max_particles: int = 20_000,
    slab: float | None = None,
    dpi: int = 100,
) -> Path:
    """Write a movie of a trajectory, one frame per trajectory frame (or every k-th), read one at a time.

    Args:
        source: a run directory (its ``trajectory.gsd``) or a GSD file.
        out: ``.gif`` (always available) or ``.mp4`` (needs ffmpeg); default ``movie.gif`` in
            the run directory, or the GSD file's name with ``.gif``.
        color_by: ``"speed"`` or ``"density"`` (see the module docstring).
        fps: frames per second.
        frames: at most this many frames: every ``ceil(n / frames)``-th of the ``n`` (default: all).
        max_particles: draw at most this many particles, the same random subset in every frame.
        slab: slab thickness for 3D runs (default one mean diameter, around the median ``z`` of
            the first frame).
        dpi: resolution (the frame is 5.5 x 5 inches).

    Returns:
        The path written. A GIF's frames are kept in memory until it is written: for long
        movies of large systems use ``frames`` or ``.mp4`` (streamed to ffmpeg).

    Example:
        >>> import edmd, tempfile, os
        >>> d = tempfile.mkdtemp()
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(64, 0.3, dim=2), 1.0))
        >>> _ = sim.add(edmd.Trajectory(os.path.join(d, "trajectory.gsd"), interval=0.5)); sim.run(until_time=1.0); sim.close()
        >>> make_movie(d, color_by="density").name
        'movie.gif'
    """
    check_colouring(color_by)
    traj = trajectory_file(source)
    out = Path(out) if out is not None else (Path(source) / "movie.gif" if Path(source).is_dir() else traj.with_suffix(".gif"))
    writer = movie_writer(out, fps)
    n = frame_count(traj)
    if frames is not None and not (isinstance(frames, int) and frames > 0):
        raise MovieError(f"frames must be a positive integer, got {frames!r}")
    if not (isinstance(max_particles, int) and max_particles > 0):
        raise MovieError(f"max_particles must be a positive integer, got {max_particles!r}")
    states = iter_states(traj, step=math.ceil(n / frames) if frames else 1, check_overlaps=False)
    first = next(states)
    particles = sample_particles(first.n, max_particles)
    particles = np.arange(first.n) if particles is None else particles
    centre = slab_mask(first, 2, slab, None)[1] if first.dim == 3 else None
    ax = plot_frame(first, color_by, slab=slab, slab_centre=centre, particles=particles)
    with atomic_path(out) as tmp, writer.saving(ax.figure, str(tmp), dpi):
        writer.grab_frame()
        for state in states:
            ax.collections[0].remove()
            _draw(ax, state, color_by, particles, slab, centre)
            writer.grab_frame()
    return out


__all__ = ["MovieError", "check_colouring", "colour_values", "local_packing_fraction", "make_movie", "movie_writer", "plot_frame", "trajectory_file"]
