r"""Counter-based random numbers for events in the core: a draw is a pure function of its key.

Nothing is stored between draws, so a run that is restarted from a checkpoint draws exactly the
numbers the uninterrupted run draws, as long as the keys are the same. The generator is the
SplitMix64 output function (Steele, Lea & Flood, OOPSLA 2014; the finaliser of Java's
``SplittableRandom``) applied to a hash of the key:

.. math::
    z_{k} = \mathrm{mix}\big(h(\mathrm{key}) + (k + 1)\,\gamma\big),\qquad
    u_k = \lfloor z_k / 2^{11}\rfloor\, 2^{-53} \in [0, 1),

with :math:`\gamma = \mathtt{0x9E3779B97F4A7C15}` (the golden-ratio increment), and
:math:`h` folding each part of the key in with ``mix``. Normal deviates come in pairs from
Box–Muller.
"""

import math

import numpy as np

from .jit import leaf

GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_TWO_M53 = 1.0 / 9007199254740992.0


@leaf
def mix(z):
    """SplitMix64's bijective finaliser of a uint64."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@leaf
def stream(seed, epoch, particle, count):
    """The state (uint64) of the stream keyed by four uint64-convertible integers."""
    z = mix(np.uint64(seed) + GAMMA)
    z = mix(z ^ np.uint64(epoch))
    z = mix(z + np.uint64(particle) * GAMMA)
    return mix(z ^ np.uint64(count))


@leaf
def uniform(state, k):
    """The ``k``-th uniform number in ``[0, 1)`` of a stream."""
    return float(mix(state + (np.uint64(k) + np.uint64(1)) * GAMMA) >> _S11) * _TWO_M53


@leaf
def normal_pair(state, k):
    """Two independent standard normal numbers from uniforms ``k`` and ``k + 1`` (Box–Muller)."""
    rad = math.sqrt(-2.0 * math.log(1.0 - uniform(state, k)))
    ang = 2.0 * math.pi * uniform(state, k + 1)
    return rad * math.cos(ang), rad * math.sin(ang)
