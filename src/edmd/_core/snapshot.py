"""Non-disturbing observation: stream copies of all particles to one instant."""

import numpy as np
from .jit import jit_alloc

from .predict import flight


@jit_alloc
def stream_all(P, image, t, geo):
    """Positions (wrapped into the box), velocities and images of every particle at time ``t``.

    The engine's own arrays are not modified (physics.md §1.1: lazy update, evaluated on demand).
    """
    n = P.shape[0]
    pos = np.empty((n, 3))
    vel = np.empty((n, 3))
    img = np.empty((n, 3), np.int64)
    for i in range(n):
        x, y, z, vx, vy, vz = flight(P, i, t, geo)
        r = (x, y, z)
        for k in range(3):
            xk = r[k]
            m = image[i, k]
            length, half = geo[k], geo[3 + k]
            if half < np.inf:
                while xk >= half:
                    xk -= length
                    m += 1
                while xk < -half:
                    xk += length
                    m -= 1
            pos[i, k] = xk
            img[i, k] = m
        vel[i, 0] = vx
        vel[i, 1] = vy
        vel[i, 2] = vz
    return pos, vel, img
