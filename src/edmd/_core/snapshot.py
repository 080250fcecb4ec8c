"""Non-disturbing observation: stream copies of all particles to one instant."""

import numpy as np
from .jit import jit_alloc

from .images import fold_face
from .predict import flight


#: what :func:`stream_all` makes: positions, velocities, images (a mask)
POSITIONS, VELOCITIES, IMAGES = 1, 2, 4


@jit_alloc
def stream_all(P, image, tag, t, d, geo, which):
    """Positions (wrapped into the box), velocities and images of every particle at time ``t``,
    in the user's order (particle ``i`` of the engine is ``tag[i]``) and ``d`` dimensions;
    ``which`` (a mask of :data:`POSITIONS`, :data:`VELOCITIES`, :data:`IMAGES`) says which are
    made (the others come back with no rows).

    The engine's own arrays are not modified (physics.md §1.1: lazy update, evaluated on demand);
    the copies are made once, in their final order (no intermediate arrays of every particle).
    """
    n = P.shape[0]
    pos = np.empty((n if which & POSITIONS else 0, d))
    vel = np.empty((n if which & VELOCITIES else 0, d))
    img = np.empty((n if which & IMAGES else 0, d), np.int64)
    for i in range(n):
        x, y, z, vx, vy, vz = flight(P, i, t, geo)
        x, y, vx, across = fold_face(x, y, vx, t, geo)  # (sheared box: through the sliding y face)
        r = (x, y, z)
        v = (vx, vy, vz)
        u = tag[i]
        for k in range(d):
            xk = r[k]
            m = image[i, k] + (across if k == 1 else 0)
            length, half = geo[k], geo[3 + k]
            if half < np.inf:
                while xk >= half:
                    xk -= length
                    m += 1
                while xk < -half:
                    xk += length
                    m -= 1
            if which & POSITIONS:
                pos[u, k] = xk
            if which & IMAGES:
                img[u, k] = m
            if which & VELOCITIES:
                vel[u, k] = v[k]
    return pos, vel, img
