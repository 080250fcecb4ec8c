r"""Square wells (docs/physics.md §2.5): a pair interaction with several event kinds and per-pair state.

A pair of hard cores at distance :math:`\sigma_{ij}` attracts inside :math:`\lambda\sigma_{ij}`
(``reach`` :math:`=\lambda`) with depth :math:`\varepsilon`. Whether a pair is inside its well is
state, not geometry (at the edge, round-off could decide either way): the *capture map*
``pairs.captured[i, :pairs.captured_n[i]]`` lists the partners inside ``i``'s well. It is symmetric,
independent of the neighbour lists (it survives their rebuilds) and saved with the state
(``State.captured_pairs``). A pair's next event has a kind (``pairs.kind``, ``PAIR_*``):

* outside, approaching: **capture** when :math:`r = \lambda\sigma`;
* inside, approaching: **core** collision when :math:`r = \sigma` (the collision rule);
* inside, moving apart (or missing the core): reaching the **edge** from inside, where the pair
  is released if :math:`\tfrac12\mu g_n^2 > \varepsilon`, else bounced back into the well.

The capture map holds at most ``K`` partners: hard cores of radius :math:`\ge R_{\min}` inside a
ball of radius :math:`(2\lambda + 1)R_{\max}`, so ``K`` :math:`\le ((2\lambda+1)R_{\max}/R_{\min})^d`
(:meth:`edmd.SquareWell.capacity`).
"""

import math

import numpy as np

from . import layout as L
from .collide import contact_normal, pair_impulse
from .jit import hot, jit, leaf
from .predict import DISC_RESOLVED, INF, contact_time, relative_to, separation


@leaf
def well_reach(fp):
    """:math:`\\lambda`: the well's edge in units of the contact distance (1 without a well)."""
    return 1.0 + fp[L.FP_WELL_WIDTH]


@leaf
def is_captured(pairs, i, j):
    """Whether ``j`` is inside the well of ``i``."""
    for s in range(pairs.captured_n[i]):
        if pairs.captured[i, s] == j:
            return True
    return False


@leaf
def _link(pairs, i, j):
    s = pairs.captured_n[i]
    pairs.captured[i, s] = j
    pairs.captured_n[i] = s + 1


@leaf
def _unlink(pairs, i, j):
    last = pairs.captured_n[i] - 1
    for s in range(last + 1):
        if pairs.captured[i, s] == j:
            pairs.captured[i, s] = pairs.captured[i, last]
            pairs.captured_n[i] = last
            return


@leaf
def edge_exit_time(dx, dy, dz, gx, gy, gz, edge):
    r"""Time until a captured pair at separation ``d`` with relative velocity ``g`` reaches the edge from inside.

    The larger root of :math:`|\mathbf d + \mathbf g t| = \lambda\sigma`, cancellation-free. A pair at
    or (by round-off) beyond the edge that moves inwards, as right after its capture or bounce,
    crosses the well first (taken as starting on the edge, so that a grazing pair still advances
    the clock); one that moves outwards leaves now (``0``). A pair inside that moves outwards so
    slowly that :math:`|\mathbf g|^2` underflows (:math:`\lesssim 10^{-290}`) never leaves (``inf``), not now.
    """
    a = gx * gx + gy * gy + gz * gz
    b = dx * gx + dy * gy + dz * gz
    c = dx * dx + dy * dy + dz * dz - edge * edge
    if a == 0.0:
        return INF
    if b > 0.0:
        if c >= 0.0:  # beyond the edge by round-off, moving out: leave now
            return 0.0
        disc = b * b - a * c  # (>= b^2 > 0: below DISC_RESOLVED only where |g|^2 underflowed)
        if disc <= DISC_RESOLVED:
            return INF
        return -c / (b + math.sqrt(disc))
    c = min(c, 0.0)
    return (math.sqrt(b * b - a * c) - b) / a


@hot
def closer_well(xi, yi, zi, vxi, vyi, vzi, ri, P, pairs, i, j, t, geo, reach, best, bj, bk):
    """The earlier of the current best ``(dt, partner, kind)`` and the next event of the pair ``(i, j)``."""
    dx, dy, dz, gx, gy, gz = relative_to(xi, yi, zi, vxi, vyi, vzi, P, j, t, geo)
    sigma = ri + P[j, L.R]
    if is_captured(pairs, i, j):
        dt = contact_time(dx, dy, dz, gx, gy, gz, sigma)
        kind = L.PAIR_CORE
        if dt == INF:  # moving apart, or missing the core: the edge, from inside
            dt = edge_exit_time(dx, dy, dz, gx, gy, gz, reach * sigma)
            kind = L.PAIR_EDGE
    else:
        dt = contact_time(dx, dy, dz, gx, gy, gz, reach * sigma)
        kind = L.PAIR_CAPTURE
    if dt < best:
        return dt, j, kind
    return best, bj, bk


@jit
def well_event(i, j, kind, P, mass, omega, inertia, pairs, geo, fp, acc, cnt):
    r"""Capture, release or bounce of the pair ``(i, j)`` at the edge of its well (streamed to the event).

    With :math:`g_n = (\mathbf v_i - \mathbf v_j)\cdot\hat{\mathbf n}` (:math:`\hat{\mathbf n}` from
    ``j`` to ``i``) and :math:`\mu` the reduced mass, energy conservation across the step of the
    potential gives the new normal speed (docs/physics.md §2.5):

    .. math::
        \text{capture: } g_n' = -\sqrt{g_n^2 + 2\varepsilon/\mu},\qquad
        \text{release: } g_n' = \sqrt{g_n^2 - 2\varepsilon/\mu}\ \ (g_n^2 > 2\varepsilon/\mu),\qquad
        \text{bounce: } g_n' = -|g_n|,

    applied as the impulse :math:`J = \mu(g_n' - g_n)` along :math:`\hat{\mathbf n}` (the tangential
    velocities and the momentum are unchanged). The impulse enters the virial like a collision's,
    and the kinetic energy changes by exactly :math:`\pm\varepsilon` (0 for a bounce).
    """
    nx, ny, nz, r, _uj = contact_normal(P, i, j, geo)  # (never sheared)
    gn = (P[i, L.VX] - P[j, L.VX]) * nx + (P[i, L.VY] - P[j, L.VY]) * ny + (P[i, L.VZ] - P[j, L.VZ]) * nz
    mi, mj = mass[i], mass[j]
    mu = mi * mj / (mi + mj)
    depth = fp[L.FP_WELL_DEPTH]
    barrier = 2.0 * depth / mu
    if kind == L.PAIR_CAPTURE:
        new = -math.sqrt(gn * gn + barrier)
        _link(pairs, i, j)
        _link(pairs, j, i)
        acc[L.A_KE] += depth
        cnt[L.C_WELL_IN] += 1
    elif gn * gn > barrier:
        new = math.sqrt(gn * gn - barrier)
        _unlink(pairs, i, j)
        _unlink(pairs, j, i)
        acc[L.A_KE] -= depth
        cnt[L.C_WELL_OUT] += 1
    else:
        new = -abs(gn)
        cnt[L.C_WELL_BOUNCE] += 1
    jn = mu * (new - gn)
    pair_impulse(P, mass, omega, inertia, i, j, jn, nx, ny, nz, r, acc)


@jit
def capture_by_distance(P, pairs, lists, geo, reach, t):
    """Capture every listed pair closer than the well's edge at time ``t`` (for a state that
    carries no capture map)."""
    pairs.captured_n[:] = 0
    nbl, nbl_n = lists.members, lists.size
    for i in range(P.shape[0]):
        for s in range(nbl_n[i]):
            j = nbl[i, s]
            if j > i:
                dx, dy, dz, _gx, _gy, _gz = separation(P, i, j, t, geo)
                edge = reach * (P[i, L.R] + P[j, L.R])
                if dx * dx + dy * dy + dz * dz < edge * edge:
                    _link(pairs, i, j)
                    _link(pairs, j, i)


def captured_pairs(pairs) -> np.ndarray:
    """The capture map as ``(M, 2)`` internal indices, each pair once (``i < j``)."""
    filled = np.arange(pairs.captured.shape[1])[None, :] < pairs.captured_n[:, None]
    rows, cols = np.nonzero(filled)[0], pairs.captured[filled]
    keep = rows < cols
    return np.stack([rows[keep], cols[keep]], axis=1).astype(np.int64)


def load_captured(pairs, captured: np.ndarray):
    """Fill the capture map from ``(M, 2)`` internal indices (each pair once; at most ``K`` per particle)."""
    both = np.concatenate([captured, captured[:, ::-1]]).astype(np.int64)
    both = both[np.lexsort((both[:, 1], both[:, 0]))]
    counts = np.bincount(both[:, 0], minlength=len(pairs.captured_n))
    slot = np.arange(len(both)) - (np.cumsum(counts) - counts)[both[:, 0]]
    pairs.captured[both[:, 0], slot] = both[:, 1]
    pairs.captured_n[:] = counts
