"""Non-disturbing observation: stream copies of all particles to one instant, or sum over them there."""

import math

import numpy as np
from .jit import jit, jit_alloc, leaf

from .images import fold_face
from .layout import R, T, VX, VY, VZ, X, Y, Z
from .predict import flight


#: what :func:`stream_all` makes: positions, velocities, images (a mask)
POSITIONS, VELOCITIES, IMAGES = 1, 2, 4


@leaf
def _wrapped(x, m, length, half):
    """``x`` wrapped into ``[-half, half)`` along a periodic axis (``half = inf``: a walled axis,
    left as it is) and the image count ``m`` moved along with it."""
    if half < np.inf:
        while x >= half:
            x -= length
            m += 1
        while x < -half:
            x += length
            m -= 1
    return x, m


@leaf
def streamed(P, image, i, t, geo):
    """Particle ``i`` at local time ``t``: its position wrapped into the box, its velocity and its
    image counts (physics.md §1.1, free flight; a sheared box folds it through the sliding y face)."""
    x, y, z, vx, vy, vz = flight(P, i, t, geo)
    x, y, vx, across = fold_face(x, y, vx, t, geo)
    x, mx = _wrapped(x, np.int64(image[i, 0]), geo[0], geo[3])
    y, my = _wrapped(y, np.int64(image[i, 1]) + across, geo[1], geo[4])
    z, mz = _wrapped(z, np.int64(image[i, 2]), geo[2], geo[5])
    return x, y, z, vx, vy, vz, mx, my, mz


@jit_alloc
def stream_all(P, image, tag, t, d, geo, which):
    """Positions (wrapped into the box), velocities and (int32) images of every particle at time ``t``,
    in the user's order (particle ``i`` of the engine is ``tag[i]``) and ``d`` dimensions;
    ``which`` (a mask of :data:`POSITIONS`, :data:`VELOCITIES`, :data:`IMAGES`) says which are
    made (the others come back with no rows).

    The engine's own arrays are not modified (physics.md §1.1: lazy update, evaluated on demand);
    the copies are made once, in their final order (no intermediate arrays of every particle).
    """
    n = P.shape[0]
    pos = np.empty((n if which & POSITIONS else 0, d))
    vel = np.empty((n if which & VELOCITIES else 0, d))
    img = np.empty((n if which & IMAGES else 0, d), np.int32)  # (the engine's counters' type)
    for i in range(n):
        x, y, z, vx, vy, vz, mx, my, mz = streamed(P, image, i, t, geo)
        r = (x, y, z)
        v = (vx, vy, vz)
        m = (mx, my, mz)
        u = tag[i]
        for k in range(d):
            if which & POSITIONS:
                pos[u, k] = r[k]
            if which & IMAGES:
                img[u, k] = m[k]
            if which & VELOCITIES:
                vel[u, k] = v[k]
    return pos, vel, img


@jit
def stream_rows(P, image, t, d, geo, reach, lo):
    """Stream every row to local time ``t`` in place: the positions, velocities and images that
    :func:`stream_all` makes, in the engine's order, each row's own time set to ``t`` (a resync
    that rebuilds from the engine's own arrays, :meth:`edmd.run.engine.Engine.resync`).

    Returns the first particle whose position or velocity is not finite or which lies outside
    the box (:meth:`edmd.state.State.check`'s test: ``x - reach[k] r < -lo[k]`` or
    ``x + reach[k] r > lo[k]``, ``reach`` 0 along periodic axes and 1 along walled ones), else -1.
    """
    bad = -1
    for i in range(P.shape[0]):
        x, y, z, vx, vy, vz, mx, my, mz = streamed(P, image, i, t, geo)
        P[i, X], P[i, Y], P[i, VX], P[i, VY], P[i, T] = x, y, vx, vy, t
        image[i, 0], image[i, 1] = mx, my
        if d == 3:
            P[i, Z], P[i, VZ], image[i, 2] = z, vz, mz
        if bad < 0:
            r = P[i, R]
            ok = math.isfinite(x) and math.isfinite(y) and math.isfinite(z) and math.isfinite(vx) and math.isfinite(vy) and math.isfinite(vz)
            at = (x, y, z)
            for k in range(d):
                ok = ok and not (at[k] - reach[k] * r < -lo[k] or at[k] + reach[k] * r > lo[k])
            if not ok:
                bad = i
    return bad


#: the entries of :func:`particle_sums`: total mass, momentum (x, y, z), twice the kinetic energy
#: relative to a velocity ``u``, twice the rotational energy, and :math:`\sum_i m_i\,\mathbf g\cdot\mathbf r_i`
S_MASS, S_PX, S_PY, S_PZ, S_TWICE_KINETIC, S_TWICE_SPIN, S_MASS_HEIGHT, N_SUMS = range(8)


@leaf
def _add(s, c, k, x):
    """``s[k] += x``, its rounding error added to ``c[k]`` (Neumaier's compensated sum)."""
    a = s[k]
    b = a + x
    c[k] += (a - b) + x if abs(a) >= abs(x) else (x - b) + a
    s[k] = b


@jit
def particle_sums(P, mass, image, pending, omega, inertia, t, d, geo, u, flow, g, s, c):
    r"""The sums over particles at local time ``t`` that a thermo row needs, in one pass over the
    engine's rows (no array of every particle; the order of the particles does not matter), into
    ``s`` (:data:`N_SUMS` entries; ``c``: as many of scratch).

    With :math:`\mathbf c_i` the committed velocity (physics.md §4.8: the pending eMD* increment
    ``pending[i]`` added; ``pending`` of no rows without eMD*) relative to the flow
    :math:`\dot\gamma y_i\hat{\mathbf x}` (``flow`` :math:`=\dot\gamma`, 0 without shear;
    physics.md §5.8):

    .. math::
        M = \sum_i m_i,\quad \mathbf p = \sum_i m_i\mathbf c_i,\quad
        \sum_i m_i|\mathbf c_i - \mathbf u|^2,\quad \sum_i I_i|\boldsymbol\omega_i|^2,\quad
        \sum_i m_i\,\mathbf g\cdot(\mathbf r_i + \mathbf n_i\mathbf L)

    (spins: ``omega`` and ``inertia`` of no rows when nothing turns; 2D: :math:`\omega_z`;
    positions unwrapped by their image counts :math:`\mathbf n_i`, read only when
    :math:`\mathbf g \ne 0`). Each sum is compensated (Neumaier), so it is exact to a few units
    of round-off at any :math:`N`.
    """
    s[:] = 0.0
    c[:] = 0.0
    gravity = g[0] != 0.0 or g[1] != 0.0 or g[2] != 0.0
    for i in range(P.shape[0]):
        m = mass[i]
        x, y, z, vx, vy, vz, mx, my, mz = streamed(P, image, i, t, geo)
        if pending.shape[0]:
            vx += pending[i, 0]
            vy += pending[i, 1]
            vz += pending[i, 2]
        vx -= flow * y
        v = (vx, vy, vz)
        w2 = 0.0
        for k in range(d):
            _add(s, c, S_PX + k, m * v[k])
            w2 += (v[k] - u[k]) ** 2
        _add(s, c, S_MASS, m)
        _add(s, c, S_TWICE_KINETIC, m * w2)
        if omega.shape[0]:
            spin = omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2 if d == 3 else omega[i, 2] ** 2
            _add(s, c, S_TWICE_SPIN, inertia[i] * spin)
        if gravity:
            r = (x + mx * geo[0], y + my * geo[1], z + mz * geo[2])
            h = 0.0
            for k in range(d):
                h += g[k] * r[k]
            _add(s, c, S_MASS_HEIGHT, m * h)
    for k in range(N_SUMS):
        s[k] += c[k]
