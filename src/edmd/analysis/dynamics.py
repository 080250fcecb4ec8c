"""Mean-squared displacement from unwrapped positions, and the diffusion coefficient."""

from __future__ import annotations

import numpy as np

from ._common import axes, each_state


def _autocorrelation(x: np.ndarray) -> np.ndarray:
    """:math:`\\frac{1}{F-m}\\sum_i x_i x_{i+m}` along axis 0 for every column (FFT, zero padded)."""
    f = x.shape[0]
    spec = np.fft.rfft(x, n=2 * f, axis=0)
    acf = np.fft.irfft(spec * spec.conj(), axis=0)[:f]
    return acf / (f - np.arange(f))[:, None]


def msd_window(r: np.ndarray) -> np.ndarray:
    r"""Time-origin averaged MSD of positions ``r`` of shape ``(F, N, d)`` at lags ``0..F-1``.

    .. math:: \mathrm{MSD}(m) = \frac{1}{N(F-m)}\sum_{i}\sum_{t=0}^{F-1-m}|\mathbf r_i(t+m)-\mathbf r_i(t)|^2

    computed in :math:`O(F\log F)` per particle as :math:`S_1(m) - 2S_2(m)` (the FFT algorithm of
    Calandrini et al., also used by freud).
    """
    f, n, _ = r.shape
    sq = np.einsum("fnd,fnd->fn", r, r)
    padded = np.vstack([sq, np.zeros((1, n))])
    q = 2.0 * sq.sum(axis=0)
    s1 = np.empty((f, n))
    for m in range(f):
        q = q - padded[m - 1] - padded[f - m]
        s1[m] = q / (f - m)
    s2 = sum(_autocorrelation(r[:, :, k]) for k in range(r.shape[2]))
    return (s1 - 2.0 * s2).mean(axis=1)


class MSD:
    r"""Mean-squared displacement :math:`\langle|\mathbf r(t+\tau)-\mathbf r(t)|^2\rangle` and diffusion coefficient.

    Positions are unwrapped with the periodic images (:attr:`edmd.State.unwrapped_position`),
    so particles may cross the box any number of times between frames.

    Args:
        mode: ``"window"`` averages over all time origins (frames must be equally spaced);
            ``"direct"`` measures from the first frame only.

    Attributes:
        lag_times: :math:`\tau` of each entry (0 first).
        msd: the mean-squared displacement.
        diffusion_coefficient: :math:`D` from the fit :math:`\mathrm{MSD} = 2dD\tau + c` over
            the second half of the lags (see :meth:`fit` for another window).

    Example (free flight, no collisions: MSD = <v^2> t^2):
        >>> import edmd
        >>> s = edmd.maxwell_boltzmann(edmd.lattice(4, 0.001), 1.0, seed=1)
        >>> frames = [s]
        >>> for t in (1.0, 2.0):
        ...     f = s.copy(); f.position = s.position + t * s.velocity; f.time = t; frames.append(f)
        >>> m = MSD().compute(frames)
        >>> bool(np.allclose(m.msd, np.mean(np.sum(s.velocity**2, axis=1)) * m.lag_times**2))
        True
    """

    def __init__(self, mode: str = "window"):
        if mode not in ("window", "direct"):
            raise ValueError(f"mode must be 'window' or 'direct', got {mode!r}")
        self.mode = mode

    def compute(self, system) -> MSD:
        """From several States (a time series) or a GSD file, read frame by frame; returns ``self``.

        Mode ``"direct"`` keeps only the first frame's positions; ``"window"`` keeps every
        frame's (unwrapped positions only, not the States).
        """
        times, first, msd, kept = [], None, [], []
        for s in each_state(system):
            r = s.unwrapped_position
            first = r if first is None else first
            times.append(s.time)
            if self.mode == "direct":
                msd.append(float(np.sum((r - first) ** 2, axis=1).mean()))
            else:
                kept.append(r)
        if len(times) < 2:
            raise ValueError("the MSD needs at least two frames")
        times = np.array(times)
        self.lag_times = times - times[0]
        if self.mode == "direct":
            self.msd = np.array(msd)
        else:
            steps = np.diff(times)
            if not np.allclose(steps, steps[0], rtol=1e-9, atol=0.0):
                raise ValueError("mode 'window' needs equally spaced frames; use mode='direct'")
            self.lag_times = steps[0] * np.arange(len(times))
            self.msd = msd_window(np.stack(kept))
        self.dim = s.dim
        half = len(self.lag_times) // 2
        self.diffusion_coefficient = self.fit(self.lag_times[max(half, 1)], self.lag_times[-1]) if len(times) > 2 else np.nan
        return self

    def fit(self, t_min: float, t_max: float) -> float:
        r""":math:`D` from a straight-line fit :math:`\mathrm{MSD} = 2dD\tau + c` for :math:`t_{\min}\le\tau\le t_{\max}`."""
        use = (self.lag_times >= t_min) & (self.lag_times <= t_max)
        if use.sum() < 2:
            raise ValueError(f"fewer than two lags in [{t_min}, {t_max}]")
        slope = np.polyfit(self.lag_times[use], self.msd[use], 1)[0]
        return float(slope / (2 * self.dim))

    def plot(self, ax=None):
        """MSD against lag time, log-log (lag 0 left out); returns the Axes."""
        ax = axes(ax)
        origins = "all time origins" if self.mode == "window" else "from the first frame"
        ax.loglog(self.lag_times[1:], self.msd[1:], "o-", ms=3, label=f"MSD ({origins})")
        ax.set_xlabel(r"lag time $\tau$")
        ax.legend(fontsize="small")
        ax.set_ylabel(r"$\langle |\Delta r|^2 \rangle$")
        return ax
