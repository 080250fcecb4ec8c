"""Collision statistics from the engine's collision log: rate, mean free time, impact speeds and
angles; the phases of impacts on a vibrating wall."""

from __future__ import annotations

import math

import numpy as np

from ._common import axes


def impact_angle_pdf(theta, dim: int):
    r"""Distribution of the impact angle :math:`\theta` between :math:`-\mathbf g` and the contact normal.

    Uncorrelated positions at contact (molecular chaos, also Enskog) give a collision rate
    :math:`\propto |\mathbf g\cdot\hat{\mathbf n}|` over the approaching half of the contact
    sphere: :math:`P(\theta) = \sin 2\theta` in 3D, :math:`\cos\theta` in 2D, on :math:`[0, \pi/2]`.

    Example:
        >>> round(float(impact_angle_pdf(np.pi / 4, 3)), 12)
        1.0
    """
    theta = np.asarray(theta, float)
    return np.sin(2 * theta) if dim == 3 else np.cos(theta)


def impact_speed_pdf(u, kT: float, mass: float = 1.0):
    r"""Distribution of the normal impact speed :math:`u = -\mathbf g\cdot\hat{\mathbf n}` in a Maxwellian gas.

    The normal relative velocity is Gaussian with variance :math:`s^2 = 2T/m` (equal masses) and
    the rate is weighted by :math:`u`: :math:`P(u) = \frac{u}{s^2}e^{-u^2/2s^2}`, mean
    :math:`\sqrt{\pi T/m}` (physics.md §5.2).

    Example:
        >>> round(float(impact_speed_pdf(1.0, kT=0.5)), 6)
        0.606531
    """
    s2 = 2.0 * kT / mass
    u = np.asarray(u, float)
    return u / s2 * np.exp(-0.5 * u * u / s2)


class CollisionStatistics:
    r"""Statistics of binary collisions from a collision log.

    The log comes from the engine (``sim.engine.enable_log()`` before running,
    ``sim.engine.take_log()`` after): one row ``(time, i, j, v_n, v_t)`` per collision with the
    normal impact speed :math:`v_n = -\mathbf g\cdot\hat{\mathbf n}` and the tangential relative
    speed :math:`v_t`.

    Args:
        bins: number of histogram bins.

    Attributes:
        collisions: number of collisions.
        collision_rate: collisions per particle per unit time, :math:`\omega = 2N_c/(N\Delta t)`.
        mean_free_time: :math:`1/\omega`.
        speed_edges, speed_pdf: distribution of :math:`v_n`.
        angle_edges, angle_pdf: distribution of the impact angle
            :math:`\theta = \arctan(v_t/v_n) \in [0, \pi/2]` (compare :func:`impact_angle_pdf`).
        free_times: every complete time between two collisions of one particle.
        free_time_edges, free_time_pdf: their distribution.

    Example:
        >>> import edmd
        >>> sim = edmd.Simulation(edmd.maxwell_boltzmann(edmd.lattice(500, 0.2), 1.0, seed=1))
        >>> sim.engine.enable_log(); sim.run(until_time=2.0)
        >>> cs = CollisionStatistics().compute(sim.engine.take_log(), n=500, duration=2.0)
        >>> round(cs.mean_free_time * cs.collision_rate, 12)
        1.0
    """

    def __init__(self, bins: int = 40):
        if bins < 1:
            raise ValueError(f"bins must be >= 1, got {bins}")
        self.bins = int(bins)

    def compute(self, log: np.ndarray, n: int, duration: float | None = None) -> CollisionStatistics:
        """Analyse ``log`` (``(k, 5)`` rows) of a system of ``n`` particles observed for ``duration``.

        ``duration`` defaults to the span of the logged times (an underestimate for short logs).
        """
        log = np.asarray(log, float)
        if log.ndim != 2 or log.shape[1] != 5:
            raise ValueError(f"a collision log has rows (time, i, j, v_n, v_t); got shape {log.shape}")
        log = log[log[:, 2] >= 0]  # binary collisions (wall impacts have j < 0)
        if len(log) == 0:
            raise ValueError("the collision log holds no binary collision (it is empty, or has wall impacts only; call sim.engine.enable_log() before running)")
        duration = float(log[-1, 0] - log[0, 0]) if duration is None else float(duration)
        if not duration > 0:
            raise ValueError(f"duration must be positive, got {duration}")
        self.collisions = len(log)
        self.collision_rate = 2.0 * self.collisions / (n * duration)
        self.mean_free_time = 1.0 / self.collision_rate
        vn, vt = log[:, 3], log[:, 4]
        self.impact_speeds = vn
        self.impact_angles = np.arctan2(vt, vn)
        self.speed_pdf, self.speed_edges = np.histogram(vn, self.bins, range=(0.0, float(vn.max())), density=True)
        self.angle_pdf, self.angle_edges = np.histogram(self.impact_angles, self.bins, range=(0.0, 0.5 * math.pi), density=True)
        self.free_times = _free_times(log)
        if self.free_times.size:
            self.free_time_pdf, self.free_time_edges = np.histogram(self.free_times, self.bins, density=True)
        else:
            self.free_time_pdf, self.free_time_edges = np.zeros(self.bins), np.linspace(0.0, duration, self.bins + 1)
        return self

    def plot(self, ax=None, dim: int = 3):
        """Impact-angle distribution against :func:`impact_angle_pdf`; returns the Axes."""
        ax = axes(ax)
        centers = 0.5 * (self.angle_edges[1:] + self.angle_edges[:-1])
        ax.plot(centers, self.angle_pdf, "o", ms=3, label="simulation")
        ax.plot(centers, impact_angle_pdf(centers, dim), "-", label="molecular chaos")
        ax.set_xlabel(r"impact angle $\theta$")
        ax.set_ylabel(r"P($\theta$)")
        ax.legend(fontsize="small")
        return ax


def _free_times(log: np.ndarray) -> np.ndarray:
    """Times between consecutive collisions of the same particle (complete intervals only)."""
    t = np.concatenate([log[:, 0], log[:, 0]])
    who = np.concatenate([log[:, 1], log[:, 2]]).astype(np.int64)
    order = np.lexsort((t, who))
    t, who = t[order], who[order]
    same = who[1:] == who[:-1]
    return (t[1:] - t[:-1])[same]


class ImpactPhases:
    r"""Impacts on a vibrating wall (physics.md §1.6): the wall's phase :math:`\theta = \omega t + \varphi`
    (mod :math:`2\pi`) at each impact, its distribution and the impact speeds relative to the wall.

    The log is the engine's collision log with wall impacts (``sim.engine.enable_log(walls=True)``), where an impact on wall
    ``face`` of ``axis`` has the partner :math:`j = -1 - (2\,\text{axis} + \text{face})`.

    Args:
        bins: number of phase bins over :math:`[0, 2\pi)`.

    Attributes:
        times, phases, speeds: time, wall phase and normal impact speed of every impact.
        phase_edges, phase_pdf: the distribution of the phase.
        rate: impacts per unit time (over the logged span, or ``duration``).
        mean_speed: mean normal impact speed.

    Example:
        >>> import edmd, math, numpy as np
        >>> ball = edmd.State(np.array([[0.0, 0.0, 0.0]]), np.zeros((1, 3)), np.array([0.05]), np.array([1.0]),
        ...                   box=np.full(3, 0.35), periodic=np.array([True, True, False]))
        >>> floor = edmd.VibratingWall(amplitude=1.2 / (4 * math.pi**2), omega=2 * math.pi, phase=-math.pi / 2)  # Gamma = 1.2 (g = 1)
        >>> sim = edmd.Simulation(ball, walls=edmd.collide.Wall(e_n=0.5), gravity=[0.0, 0.0, -1.0], vibration=floor)
        >>> sim.engine.enable_log(walls=True); sim.run(until_time=100.0)
        >>> imp = ImpactPhases().compute(sim.engine.take_log(), floor)
        >>> round(float(imp.phases[-1]), 9) == round(math.acos(math.pi * 0.5 / (1.2 * 1.5)), 9)   # the period-one orbit
        True
    """

    def __init__(self, bins: int = 36):
        if bins < 1:
            raise ValueError(f"bins must be >= 1, got {bins}")
        self.bins = int(bins)

    def compute(self, log: np.ndarray, wall, duration: float | None = None) -> ImpactPhases:
        """The impacts on ``wall`` (an :class:`edmd.VibratingWall`) in ``log`` (``(k, 5)`` rows)."""
        log = np.asarray(log, float)
        if log.ndim != 2 or log.shape[1] != 5:
            raise ValueError(f"a collision log has rows (time, i, j, v_n, v_t); got shape {log.shape}")
        code = -1 - (2 * wall.axis_index + (0 if wall.side == "lower" else 1))
        rows = log[log[:, 2] == code]
        if len(rows) == 0:
            raise ValueError(f"the collision log holds no impact on the vibrating wall (partner {code}); call sim.engine.enable_log(walls=True) before running")
        self.times = rows[:, 0]
        self.phases = np.mod(wall.omega * self.times + wall.phase, 2.0 * math.pi)
        self.speeds = rows[:, 3]
        self.mean_speed = float(self.speeds.mean())
        span = float(self.times[-1] - self.times[0]) if duration is None else float(duration)
        self.rate = len(rows) / span if span > 0 else math.nan
        self.phase_pdf, self.phase_edges = np.histogram(self.phases, self.bins, range=(0.0, 2.0 * math.pi), density=True)
        return self

    def plot(self, ax=None):
        """The phase distribution (the wall's displacement for reference); returns the Axes."""
        ax = axes(ax)
        centers = 0.5 * (self.phase_edges[1:] + self.phase_edges[:-1])
        ax.step(centers, self.phase_pdf, where="mid", label="impacts")
        ax.set_xlabel(r"wall phase at impact $\theta$")
        ax.set_ylabel(r"$P(\theta)$")
        ax.set_xlim(0.0, 2.0 * math.pi)
        ax.legend()
        return ax
