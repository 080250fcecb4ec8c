"""Trajectories in GSD 5, double precision (readable by HOOMD-blue, OVITO, freud, MDAnalysis).

Standard chunks: positions, velocities, diameters, masses, moments of inertia, images, box,
dimensions. Under ``log/``: the continuous ``time``, the ``events`` and ``collisions`` counters,
the exact double-precision box (``log/configuration/box``; GSD stores the standard box in
single precision), the periodic flags and ``log/particles/angular_velocity``.
"""

from __future__ import annotations

import os

import gsd.hoomd
import numpy as np

from .simulation import Observer, Simulation, Totals
from .state import State, StateError


def state_to_frame(state: State, totals: Totals | None = None) -> gsd.hoomd.Frame:
    """A GSD frame holding every field of ``state`` (and the counters of ``totals``)."""
    n, d = state.n, state.dim
    f = gsd.hoomd.Frame()
    f.configuration.dimensions = d
    box = np.zeros(6)
    box[:d] = state.box
    f.configuration.box = box
    f.particles.N = n
    f.particles.position = state.points
    vel = np.zeros((n, 3))
    vel[:, :d] = state.velocity
    f.particles.velocity = vel
    f.particles.diameter = 2.0 * state.radius
    f.particles.mass = state.mass.copy()
    inertia = np.zeros((n, 3))
    if d == 3:
        inertia[:] = state.inertia[:, None]
    else:
        inertia[:, 2] = state.inertia
    f.particles.moment_inertia = inertia
    image = np.zeros((n, 3), np.int32)
    image[:, :d] = state.image
    f.particles.image = image
    f.log["time"] = np.array([state.time], np.float64)
    f.log["configuration/box"] = state.box.astype(np.float64)
    f.log["configuration/periodic"] = state.periodic.astype(np.uint8)
    f.log["particles/angular_velocity"] = np.asarray(state.angular_velocity, np.float64)
    f.log["particles/radius"] = state.radius.astype(np.float64)
    if totals is not None:
        f.log["events"] = np.array([totals.events], np.int64)
        f.log["collisions"] = np.array([totals.collisions], np.int64)
    return f


def frame_to_state(frame: gsd.hoomd.Frame, check_overlaps: bool = True) -> State:
    """Rebuild a :class:`State` from a GSD frame (exact for frames written by edmd).

    Frames from other programs work too: the box then comes from the (single precision)
    configuration chunk, radii from diameters (default 1), masses default to 1.
    ``check_overlaps=False`` accepts overlapping particles (soft-sphere frames, :mod:`edmd.dem`).
    """
    d = int(frame.configuration.dimensions or 3)
    n = int(frame.particles.N)
    if n == 0:
        raise StateError("the GSD frame holds no particles")
    log = frame.log
    box = np.asarray(log.get("configuration/box", np.asarray(frame.configuration.box[:d], np.float64)), np.float64)
    pos = np.asarray(frame.particles.position, np.float64)[:, :d]
    vel = frame.particles.velocity
    vel = np.zeros((n, d)) if vel is None else np.asarray(vel, np.float64)[:, :d]
    if "particles/radius" in log:
        radius = np.asarray(log["particles/radius"], np.float64)
    else:
        diam = frame.particles.diameter
        radius = 0.5 * (np.ones(n) if diam is None else np.asarray(diam, np.float64))
    mass = frame.particles.mass
    mass = np.ones(n) if mass is None else np.asarray(mass, np.float64)
    inertia = frame.particles.moment_inertia
    if inertia is not None and np.any(np.asarray(inertia) > 0):
        inertia = np.asarray(inertia, np.float64)[:, 2 if d == 2 else 0]
    else:
        inertia = None
    image = frame.particles.image
    image = np.zeros((n, d), np.int64) if image is None else np.asarray(image, np.int64)[:, :d]
    spin = log.get("particles/angular_velocity")
    periodic = log.get("configuration/periodic")
    time = float(log["time"][0]) if "time" in log else 0.0
    return State(
        position=pos,
        velocity=vel,
        radius=radius,
        mass=mass,
        box=box,
        time=time,
        angular_velocity=None if spin is None else np.asarray(spin, np.float64),
        inertia=inertia,
        image=image,
        periodic=None if periodic is None else np.asarray(periodic, bool),
        check_overlaps=check_overlaps,
    )


def read_state(path: str | os.PathLike, frame: int = -1, check_overlaps: bool = True) -> State:
    """The :class:`State` stored in frame ``frame`` of a GSD file (default: the last).

    ``check_overlaps=False`` reads frames of soft particles in contact (:mod:`edmd.dem`).

    Example:
        >>> import edmd, tempfile, os
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(32, 0.2), 1.0)
        >>> p = os.path.join(tempfile.mkdtemp(), "s.gsd")
        >>> write_state(p, s)
        >>> bool(np.array_equal(read_state(p).velocity, s.velocity))
        True
    """
    try:
        with gsd.hoomd.open(str(path), "r") as traj:
            if len(traj) == 0:
                raise StateError(f"{path} holds no frames")
            return frame_to_state(traj[frame], check_overlaps)
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        if isinstance(exc, StateError):
            raise
        raise StateError(f"cannot read a state from {path}: {exc}") from exc


def write_state(path: str | os.PathLike, state: State, totals: Totals | None = None):
    """Write ``state`` as the only frame of a new GSD file."""
    with gsd.hoomd.open(str(path), "w", precision="double") as traj:
        traj.append(state_to_frame(state, totals))


class Trajectory(Observer):
    """Append a GSD frame (double precision) at every interval.

    Example:
        >>> import edmd, tempfile, os, gsd.hoomd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(64, 0.2), 1.0))
        >>> p = os.path.join(tempfile.mkdtemp(), "traj.gsd")
        >>> _ = sim.add(Trajectory(p, interval=0.5))
        >>> sim.run(until_time=1.0); sim.close()
        >>> len(gsd.hoomd.open(p))
        3
    """

    def __init__(self, path: str | os.PathLike, interval: float, start: float | None = None, mode: str = "w"):
        super().__init__(interval, start)
        self.path = str(path)
        self._file = gsd.hoomd.open(self.path, mode, precision="double")

    def observe(self, sim: Simulation, state: State, totals: Totals):
        self._file.append(state_to_frame(state, totals))
        self._file.flush()

    def close(self):
        if self._file is not None:
            self._file.close()
            self._file = None
