"""Export one frame as extended XYZ (ASE, OVITO) or CSV.

Both formats write every number with 17 significant digits (``%.17g``: a float64 read back is
the same float64). Files are written atomically.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .atomic import atomic_path
from ..state import State, StateError
from .trajectory import read_state


def _spin3(state: State) -> np.ndarray:
    """Angular velocities as ``(N, 3)`` (2D: ``(0, 0, omega_z)``)."""
    if state.dim == 3:
        return state.angular_velocity
    w = np.zeros((state.n, 3))
    w[:, 2] = state.angular_velocity
    return w


def _xyz_cell(state: State) -> tuple[np.ndarray, np.ndarray]:
    """Cell lengths and the shift into the cell ``[0, L)`` (2D: a slab one diameter thick)."""
    lengths = np.zeros(3)
    lengths[: state.dim] = state.box
    shift = np.zeros(3)
    shift[: state.dim] = 0.5 * state.box
    if state.dim == 2:
        lengths[2] = 2.0 * float(state.radius.max())
        shift[2] = 0.5 * lengths[2]
    return lengths, shift


def write_xyz(path: str | os.PathLike, state: State):
    """Write ``state`` as one extended-XYZ frame (ASE's ``extxyz``, read by OVITO).

    Columns: ``species`` (``X``, ASE's dummy element), ``pos``, ``velo`` (OVITO's velocity),
    ``momenta`` (``m v``, ASE's: ``Atoms.get_velocities()`` divides them by ``masses``),
    ``radius``, ``mass`` (OVITO's) and ``masses`` (ASE's ``get_masses()``), ``moment_inertia``,
    ``angular_velocity`` (3 components; ``(0, 0, omega_z)`` in 2D) and ``image``; the comment
    line holds ``Lattice``, ``pbc`` and ``Time``. Neither reader converts units: the numbers are
    edmd's reduced units. Positions are shifted by ``+L/2`` into the cell ``[0, L)`` that ASE and
    OVITO expect (edmd's box is ``[-L/2, L/2)``). 2D states become a slab one particle diameter
    thick (``pbc`` false along ``z``).

    Example:
        >>> import edmd, tempfile, os
        >>> p = os.path.join(tempfile.mkdtemp(), "frame.xyz")
        >>> write_xyz(p, edmd.lattice(4, 0.1, dim=2))
        >>> open(p).read().splitlines()[0]
        '4'
    """
    lengths, shift = _xyz_cell(state)
    pos = state.points + shift
    vel = np.zeros((state.n, 3))
    vel[:, : state.dim] = state.velocity
    image = np.zeros((state.n, 3))
    image[:, : state.dim] = state.image
    m = state.mass
    cols = np.column_stack([pos, vel, m[:, None] * vel, state.radius, m, m, state.inertia, _spin3(state), image])
    lattice = " ".join(f"{x:.17g}" for x in np.diag(lengths).ravel())
    pbc = " ".join("T" if k < state.dim and state.periodic[k] else "F" for k in range(3))
    header = (
        f'Lattice="{lattice}" Properties=species:S:1:pos:R:3:velo:R:3:momenta:R:3:radius:R:1:mass:R:1:masses:R:1:'
        f'moment_inertia:R:1:angular_velocity:R:3:image:I:3 Time={state.time:.17g} pbc="{pbc}"'
    )
    fmt = "X " + " ".join(["%.17g"] * 16) + " %d %d %d"
    with atomic_path(path) as tmp:
        np.savetxt(tmp, cols, fmt=fmt, header=f"{state.n}\n{header}", comments="")


def csv_columns(dim: int) -> list[str]:
    """Column names of :func:`write_csv` for dimension ``dim``."""
    axes = "xyz"[:dim]
    spin = ["omega_x", "omega_y", "omega_z"] if dim == 3 else ["omega_z"]
    return ["id", *axes, *(f"v{a}" for a in axes), "radius", "mass", "inertia", *spin, *(f"image_{a}" for a in axes)]


def write_csv(path: str | os.PathLike, state: State):
    """Write the particles of ``state`` as a CSV table, one row per particle (edmd's coordinates).

    Columns (:func:`csv_columns`): ``id, x, y[, z], vx, vy[, vz], radius, mass, inertia``,
    the angular velocity (``omega_x, omega_y, omega_z`` in 3D, ``omega_z`` in 2D) and the
    periodic images. Positions are in edmd's box ``[-L/2, L/2)``; the box and time are not part
    of the table (they are in the GSD file).

    Example:
        >>> import edmd, tempfile, os
        >>> p = os.path.join(tempfile.mkdtemp(), "frame.csv")
        >>> write_csv(p, edmd.lattice(4, 0.1, dim=2))
        >>> open(p).readline().strip()
        'id,x,y,vx,vy,radius,mass,inertia,omega_z,image_x,image_y'
    """
    spin = state.angular_velocity.reshape(state.n, -1)
    cols = np.column_stack([np.arange(state.n), state.position, state.velocity, state.radius, state.mass, state.inertia, spin, state.image])
    d = state.dim
    n_float = 2 * d + 3 + spin.shape[1]
    fmt = ",".join(["%d"] + ["%.17g"] * n_float + ["%d"] * d)
    with atomic_path(path) as tmp:
        np.savetxt(tmp, cols, fmt=fmt, header=",".join(csv_columns(d)), comments="")


WRITERS = {".xyz": write_xyz, ".extxyz": write_xyz, ".csv": write_csv}


def export_frame(source: str | os.PathLike, output: str | os.PathLike, frame: int = -1) -> State:
    """Export frame ``frame`` of a GSD file (or of a run directory's ``trajectory.gsd``).

    The format follows the suffix of ``output``: ``.xyz``/``.extxyz`` (extended XYZ) or ``.csv``.
    Returns the exported State.
    """
    source, output = Path(source), Path(output)
    writer = WRITERS.get(output.suffix.lower())
    if writer is None:
        raise ValueError(f"cannot export to {output.name}: use a .xyz, .extxyz or .csv file name")
    if source.is_dir():
        source = source / "trajectory.gsd"
    if not source.is_file():
        raise StateError(f"no GSD file {source}")
    state = read_state(source, frame, check_overlaps=False)
    writer(output, state)
    return state
