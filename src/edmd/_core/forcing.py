r"""White-noise forcing as a global event of the calendar (Williams & MacKintosh, PRE 54, R9 (1996);
van Noije & Ernst, Granular Matter 1, 57 (1998)).

Timers are calendar entries ``N + k`` after the ``N`` particles (``TIMER_*`` in
:mod:`.layout`), as Smallenburg's EDMD keeps pseudo-particles and DynamO "System" events: the
loop pops them like any event, in time order. Tick ``j`` of a timer is at the absolute time
:math:`t_j = t_{\rm start} + j\,\Delta t` (computed by multiplication, so it never drifts and
does not depend on when the engine was last rebuilt).

At a kick, every particle is streamed to :math:`t_j` and its velocity changes by

.. math::
    \Delta\mathbf v_i = \xi_0\sqrt{\Delta t}\,\Big(\mathbf g_i - \frac{\sum_k m_k\mathbf g_k}{\sum_k m_k}\Big),
    \qquad \mathbf g_i \sim \mathcal N(0, \mathbb 1),

so each component has variance :math:`\xi_0^2\Delta t\,(1 - 2m_i/M + \sum_k m_k^2/M^2)`
(:math:`1 - 1/N` for equal masses) and the total momentum does not change (the mass-weighted
mean kick is removed). The random numbers are keyed by (seed, tick, particle in the engine's
internal order) (:mod:`.rng`); the internal order is rebuilt at the same points of a run and of
its restart from a checkpoint, so restarts continue bit for bit. The index of the next tick is
``cnt[C_KICK_NEXT]``, carried across rebuilds and saved in checkpoints: a rebuild at the very
time of a kick must not repeat it.
"""

import math

import numpy as np

from . import layout as L
from .jit import jit, leaf
from .predict import advance
from .wallmotion import release
from .rng import normal_pair, stream
from .stress import book_velocity_change

#: the fourth part of the key of the kicks (bath draws use event counters and 2**40)
KICK = np.uint64(1 << 41)


@leaf
def tick_time(start, interval, tick):
    """Absolute time of tick ``tick`` of a timer started at ``start``: by multiplication, so it never
    drifts (the one formula of the core and of :meth:`edmd.WhiteNoise.tick_time`)."""
    return start + tick * interval


@leaf
def _kick_normals(seed, tick, p):
    z = stream(seed, tick, p, KICK)
    g0, g1 = normal_pair(z, 0)
    g2, _g3 = normal_pair(z, 2)
    return g0, g1, g2


@jit
def white_noise_kick(t, P, mass, count, drive, fp, acc, cnt, geo):
    """Kick every particle at local time ``t`` (see the module doc); books the energy input and
    schedules the next tick (its index is ``cnt[C_KICK_NEXT]``, which checkpoints save). The
    caller re-predicts every particle."""
    n = P.shape[0]
    seed, tick = drive.key[2], cnt[L.C_KICK_NEXT]
    s = fp[L.FP_KICK_XI0] * math.sqrt(fp[L.FP_KICK_INTERVAL])
    mx = my = mz = total = 0.0
    for p in range(n):
        gx, gy, gz = _kick_normals(seed, tick, p)
        mx += mass[p] * gx
        my += mass[p] * gy
        mz += mass[p] * gz
        total += mass[p]
    mean = (mx / total, my / total, mz / total)
    de = 0.0
    for p in range(n):
        advance(P, p, t, geo)
        release(P, p, mass, acc, geo)  # (a rider on the vibrating wall flies on with its kick)
        g = _kick_normals(seed, tick, p)  # drawn again: a pure function of the key
        v0 = (P[p, L.VX], P[p, L.VY], P[p, L.VZ])
        for k in range(3):
            if drive.axes[0, k]:
                dv = s * (g[k] - mean[k])
                v = P[p, L.VX + k]
                de += 0.5 * mass[p] * ((v + dv) * (v + dv) - v * v)
                acc[L.A_PX + k] += mass[p] * dv
                P[p, L.VX + k] = v + dv
        book_velocity_change(acc, mass[p], v0[0], v0[1], v0[2], P[p, L.VX], P[p, L.VY], P[p, L.VZ])
        count[p] += 1
    acc[L.A_KE] += de
    acc[L.A_ENERGY_INPUT] += de
    cnt[L.C_KICK_NEXT] = tick + 1
    drive.timer_t[L.TIMER_KICK] = tick_time(fp[L.FP_KICK_START], fp[L.FP_KICK_INTERVAL], tick + 1) - drive.origin[0]
