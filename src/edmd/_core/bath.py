r"""The Andersen heat bath as single-particle events (H. C. Andersen, J. Chem. Phys. 72, 2384 (1980)).

Each particle meets the bath at the times of its own Poisson process of rate :math:`\nu`
(kind ``AUX_BATH``, in the calendar like any other event; :class:`.bundles.Drive` holds the
next time of each particle). At a bath event the particle's velocity, and its spin when the
rule is rough, are drawn anew from Maxwell–Boltzmann at :math:`k_BT`:

.. math::
    v_\alpha \sim \mathcal N\!\left(0, \frac{k_BT}{m}\right),\qquad
    \omega_\alpha \sim \mathcal N\!\left(0, \frac{k_BT}{I}\right),

and its next bath time is :math:`t + \tau` with :math:`\tau = -\ln(1 - u)/\nu`.

Every number comes from the counter-based generator of :mod:`.rng`, keyed by ``(seed, epoch,
particle, count)``: ``epoch`` is the bit pattern of the time the engine was last loaded, and
``count`` the particle's event counter (which every bath event bumps), so no generator state
exists between events. At each load (start, resync, checkpoint, restart) every particle's
Poisson clock is drawn afresh from the load time, which the memorylessness of the exponential
distribution allows, with the reserved count ``SCHEDULE``: a restarted run draws exactly what
the uninterrupted one drew.
"""

import math

import numpy as np

from . import layout as L
from .jit import jit, leaf
from .rng import normal_pair, stream, uniform
from .stress import book_velocity_change, particle_current

#: the ``count`` of the key of the clock draws at a load (event counters are int32, never this)
SCHEDULE = np.uint64(1 << 40)


@leaf
def _waiting_time(z, rate):
    """Exponential waiting time of rate ``rate`` from the first uniform of stream ``z``."""
    return -math.log(1.0 - uniform(z, 0)) / rate


@jit
def bath_schedule(drive, rate):
    """Draw every particle's first bath time after a load (local time 0)."""
    epoch, seed = drive.key[0], drive.key[1]
    for i in range(drive.bath_t.shape[0]):
        drive.bath_t[i] = _waiting_time(stream(seed, epoch, i, SCHEDULE), rate)


@jit
def bath_event(i, t, P, mass, omega, inertia, count, drive, fp, acc, rough):
    r"""Particle ``i`` (streamed to ``t``) meets the bath: new velocity (and spin if ``rough``), next bath time.

    Books the change of kinetic (and rotational) energy as ``energy_input`` and updates the
    running translational kinetic energy and momentum (``acc``). Only the components that
    ``drive.axes`` marks are drawn (row 0 velocity, row 1 spin): disks keep :math:`v_z = 0`
    exactly and spin about ``z`` only.
    """
    kT = fp[L.FP_BATH_KT]
    z = stream(drive.key[1], drive.key[0], i, count[i])
    s = math.sqrt(kT / mass[i])
    g = normal_pair(z, 1) + normal_pair(z, 3) + normal_pair(z, 5)
    de = 0.0
    turns = omega.shape[0] != 0  # (e_i holds the spin's energy whenever spins are kept)
    particle_current(acc, P, mass, omega, inertia, i, turns, -1.0)
    v0 = (P[i, L.VX], P[i, L.VY], P[i, L.VZ])
    for k in range(3):
        old = P[i, L.VX + k]
        new = s * g[k] if drive.axes[0, k] else 0.0
        de += 0.5 * mass[i] * (new * new - old * old)
        acc[L.A_PX + k] += mass[i] * (new - old)
        P[i, L.VX + k] = new
    acc[L.A_KE] += de
    book_velocity_change(acc, mass[i], v0[0], v0[1], v0[2], P[i, L.VX], P[i, L.VY], P[i, L.VZ])
    if rough:
        w = math.sqrt(kT / inertia[i])
        for k in range(3):
            new = w * g[3 + k] if drive.axes[1, k] else 0.0
            de += 0.5 * inertia[i] * (new * new - omega[i, k] * omega[i, k])
            omega[i, k] = new
    acc[L.A_ENERGY_INPUT] += de
    particle_current(acc, P, mass, omega, inertia, i, turns, 1.0)
    drive.bath_t[i] = t + _waiting_time(z, fp[L.FP_BATH_RATE])
