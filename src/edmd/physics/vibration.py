r"""The vibrating wall: one wall moving along its normal as a prescribed function of time
(physics.md §1.6; the compiled side is ``_core/walls.py``).

The wall is displaced into the box by

.. math::
    d(t) = a\,\bigl(1 + w(\omega t + \varphi)\bigr),\qquad w \in [-1, 1],

about the plane :math:`\mp L/2 \pm a`, so it sweeps the slab between its rest plane and
:math:`2a` inside the box. ``wave = "sine"`` is :math:`w = \sin`; ``"triangle"`` and
``"sawtooth"`` are piecewise linear with :math:`w(0) = 0` rising like the sine (the sawtooth
drops back out of the box at once, half a period later). Contact times are exact (a segmented
search that cannot skip a root, or closed form on the linear pieces), and collisions act in the
wall's frame: restitution and roughness apply to the velocity relative to the wall, and the
work the wall does, :math:`u J_n` per impact, is booked as ``energy_input``.

A particle that chatters to rest on the wall (complete chattering, the inelastic collapse of
the bouncing ball: bounces converging in finite time while the wall presses it) **rides** with
the wall (physics.md §1.6.3): once its rebound from a pressing wall would be slower than
``stick_speed``, it sticks, moves with the wall along the axis and freely across it, and takes
off in closed form exactly when the wall stops pressing it (its acceleration falls below
gravity's: :math:`\sin\theta = 1/\Gamma` for a sine floor; the end of a piece of the linear
waves). A collision, a kick or the heat bath ends a ride at once. ``State.riding`` marks the
riders, and checkpoints keep them.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import layout as L
from .._core.wallmotion import wave_value

WAVES = {"sine": L.WAVE_SINE, "triangle": L.WAVE_TRIANGLE, "sawtooth": L.WAVE_SAWTOOTH}
#: the default ``stick_speed`` in units of the wall's speed scale :math:`a\omega`: a rebound this
#: slow rises :math:`10^{-12}\,(a\omega)^2/(2 g_{\rm eff})` off the wall, near the resolution of
#: positions, and the bounces it cuts short would all have ended within
#: :math:`2\times10^{-6}\,a\omega/(g_{\rm eff}(1-e))`
STICK = 1e-6
AXES = "xyz"
SIDES = ("lower", "upper")


@dataclasses.dataclass(frozen=True)
class VibratingWall:
    """A wall of a walled axis that moves along its normal: :math:`d(t) = a(1 + w(\\omega t + \\varphi))` into the box.

    Args:
        amplitude: :math:`a` (> 0): the wall sweeps :math:`[0, 2a]` from its rest plane.
        omega: angular frequency :math:`\\omega` (> 0).
        phase: :math:`\\varphi` (radians) at time 0.
        axis: ``"x"``, ``"y"`` or ``"z"``; the axis must be closed by walls.
        side: ``"lower"`` (the wall at :math:`-L/2`, a floor under gravity along :math:`-z`) or ``"upper"``.
        wave: ``"sine"``, ``"triangle"`` or ``"sawtooth"``.
        stick_speed: the rebound speed relative to the wall below which a particle that the wall
            presses sticks to it and rides (``None``: :data:`STICK` :math:`a\\omega`; 0: never, the
            bounces then pile up until the run stops with :class:`edmd.CollapseError` unless the
            TC model keeps it going).

    Example:
        >>> import edmd, numpy as np
        >>> ball = edmd.State(np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 0.0]]), np.array([0.05]), np.array([1.0]),
        ...                   box=np.array([1.0, 1.0, 1.0]), periodic=np.array([True, True, False]))
        >>> floor = edmd.VibratingWall(amplitude=0.01, omega=20.0)
        >>> sim = edmd.Simulation(ball, walls=edmd.collide.Wall(e_n=0.9), gravity=[0.0, 0.0, -1.0], vibration=floor)
        >>> sim.run(until_time=3.0)
        >>> sim.totals().wall_collisions > 0, sim.totals().energy_input != 0.0
        (True, True)
    """

    amplitude: float
    omega: float
    phase: float = 0.0
    axis: str = "z"
    side: str = "lower"
    wave: str = "sine"
    stick_speed: float | None = None

    def __post_init__(self):
        for name in ("amplitude", "omega"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"VibratingWall {name} must be a positive number, got {value!r}")
        if not (isinstance(self.phase, int | float) and math.isfinite(self.phase)):
            raise ValueError(f"VibratingWall phase must be a finite number (radians), got {self.phase!r}")
        speed = self.stick_speed
        if speed is not None and not (isinstance(speed, int | float) and math.isfinite(speed) and speed >= 0):
            raise ValueError(f"VibratingWall stick_speed must be a number >= 0 (or None), got {speed!r}")
        object.__setattr__(self, "stick_speed", STICK * self.amplitude * self.omega if speed is None else float(speed))
        for name, allowed in (("axis", tuple(AXES)), ("side", SIDES), ("wave", tuple(WAVES))):
            if getattr(self, name) not in allowed:
                raise ValueError(f"VibratingWall {name} must be one of {', '.join(allowed)}, got {getattr(self, name)!r}")

    @property
    def axis_index(self) -> int:
        """The axis as 0, 1 or 2."""
        return AXES.index(self.axis)

    @property
    def period(self) -> float:
        """:math:`2\\pi/\\omega`."""
        return 2.0 * math.pi / self.omega

    def gamma(self, g: float) -> float:
        """Peak acceleration of a sine wall in units of ``g``, :math:`\\Gamma = a\\omega^2/g`."""
        return self.amplitude * self.omega**2 / g

    def _wave(self, t):
        """:math:`w` and :math:`dw/d\\theta` at time(s) ``t`` (the core's formula)."""
        theta = self.omega * np.asarray(t, float) + self.phase
        w = np.array([wave_value(WAVES[self.wave], x) for x in theta.ravel()]).reshape(*theta.shape, 2)
        return (float(w[0]), float(w[1])) if w.ndim == 1 else (w[..., 0], w[..., 1])

    def displacement(self, t):
        """How far the wall is inside the box at time(s) ``t``, :math:`d(t)`."""
        return self.amplitude * (1.0 + self._wave(t)[0])

    def velocity(self, t):
        """The wall's velocity into the box at time(s) ``t``, :math:`\\dot d(t)`."""
        return self.amplitude * self.omega * self._wave(t)[1]

    def plane(self, t: float, length: float) -> float:
        """The wall's coordinate along its axis at time ``t`` in a box of ``length`` along it."""
        d = self.displacement(t)
        return -0.5 * length + d if self.side == "lower" else 0.5 * length - d

    def geo_entries(self, origin: float) -> tuple:
        """The core's description (``layout.G_WALL_*``) for local times counted from ``origin``:
        the phase at local time 0 is reduced to one period."""
        phase = math.fmod(self.omega * origin + self.phase, 2.0 * math.pi)
        return (self.axis_index, SIDES.index(self.side), WAVES[self.wave], self.amplitude, self.omega, phase, self.stick_speed)

    def to_dict(self) -> dict:
        """JSON-ready parameters."""
        return {"kind": "vibrating_wall", **dataclasses.asdict(self)}
