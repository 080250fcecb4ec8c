"""Run configuration: a TOML file validated by pydantic (unknown keys are errors).

Example:
    >>> cfg = parse_config({"system": {"dim": 2, "n": 100, "packing_fraction": 0.2}, "run": {"until_time": 1.0}})
    >>> cfg.system.dim, cfg.run.output_interval
    (2, 1.0)
"""

from __future__ import annotations

import difflib
import math
import tomllib
import typing
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..physics import collide
from ..physics.thermostats import Andersen, WhiteNoise
from ..physics.vibration import VibratingWall
from ..physics.shear import Shear
from ..physics.wells import SquareWell
from ..run.updaters import VelocityRescale


class ConfigError(ValueError):
    """A configuration problem; the message names the key and what is wrong."""


class _Section(BaseModel):
    # strict: no silent conversions ("100" is not a number, "yes" not a boolean); numbers finite
    model_config = ConfigDict(extra="forbid", validate_assignment=True, strict=True, allow_inf_nan=False)


class RadiusDistribution(_Section):
    """Polydisperse radii (see :func:`edmd.initial.radii`)."""

    kind: Literal["uniform", "normal", "lognormal", "discrete"]
    min: float | None = Field(None, gt=0)
    max: float | None = Field(None, gt=0)
    mean: float | None = Field(None, gt=0)
    std: float | None = Field(None, ge=0)
    values: list[Annotated[float, Field(gt=0)]] | None = None
    fractions: list[Annotated[float, Field(ge=0)]] | None = None

    @model_validator(mode="after")
    def _complete(self):
        need = {"uniform": ("min", "max"), "normal": ("mean", "std"), "lognormal": ("mean", "std"), "discrete": ("values",)}
        missing = [k for k in need[self.kind] if getattr(self, k) is None]
        if missing:
            raise ValueError(f"radius distribution {self.kind!r} needs {', '.join(missing)}")
        return self

    def as_dict(self) -> dict:
        return {k: v for k, v in self.model_dump().items() if v is not None}


class SystemConfig(_Section):
    """``[system]``: what to simulate and how to start it."""

    dim: Literal[2, 3] = 3
    n: int = Field(4000, ge=1, description="number of particles")
    packing_fraction: float = Field(0.3, gt=0, lt=1)
    kT: float = Field(1.0, ge=0, description="initial temperature (Maxwell-Boltzmann)")
    seed: int = Field(1, ge=0, description="random seed (a non-negative integer)")
    init: Literal["lattice", "random", "compress"] = "lattice"
    compress_rate: float = Field(0.02, gt=0, allow_inf_nan=False, description="init = 'compress': radii grow as R(0) (1 + rate t)")
    lattice: Literal["fcc", "sc", "hex", "square"] | None = None
    radius: Annotated[float, Field(gt=0)] | RadiusDistribution = 0.5
    mass: float = Field(1.0, gt=0)
    density: float | None = Field(None, gt=0, description="material density: mass = density * volume")
    aspect: list[Annotated[float, Field(gt=0)]] | None = None
    gravity: list[float] | None = Field(None, description="uniform acceleration, d components")
    replicate: list[Annotated[int, Field(ge=1)]] | None = Field(
        None, description="copies per axis: build n / prod(replicate) particles, tile them (edmd.replicate), then draw the velocities"
    )
    from_file: str | None = Field(None, description="start from a frame of this GSD file (other keys then ignored)")
    from_frame: int = Field(-1, description="frame of from_file (negative counts from the end)")

    @field_validator("dim", mode="before")
    @classmethod
    def _whole_dim(cls, value):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError("dim must be the whole number 2 or 3")
        return value

    @model_validator(mode="after")
    def _consistent(self):
        if self.gravity is not None and len(self.gravity) != self.dim:
            raise ValueError(f"gravity needs {self.dim} components")
        if self.lattice is not None and self.init != "lattice":
            raise ValueError("'lattice' is only used with init = 'lattice'")
        if self.lattice in ("fcc", "sc") and self.dim == 2 or self.lattice in ("hex", "square") and self.dim == 3:
            raise ValueError(f"lattice {self.lattice!r} does not exist in {self.dim}D")
        if self.aspect is not None and len(self.aspect) != self.dim:
            raise ValueError(f"aspect needs {self.dim} numbers")
        if self.n == 1 and self.kT > 0 and self.from_file is None:
            raise ValueError("kT: a single particle at zero total momentum is at rest and has no temperature; set kT = 0")
        if self.aspect is not None and self.init == "lattice":
            raise ValueError("'aspect' shapes the box of init = 'random' or 'compress' only (a lattice fixes its own box)")
        if self.replicate is not None:
            copies = math.prod(self.replicate)
            if len(self.replicate) != self.dim:
                raise ValueError(f"replicate needs {self.dim} numbers (copies per axis)")
            if self.n % copies:
                raise ValueError(f"replicate = {self.replicate}: n = {self.n} is not a multiple of the {copies} copies")
        if self.init == "compress" and self.kT <= 0:
            raise ValueError("init = 'compress' needs kT > 0 (the particles fly while they grow)")
        return self


SOFT_KEYS = {"dashpot": ("k", "gamma", "e_n"), "hertz": ("young", "poisson", "A")}


def _check_soft_law(model: str, section, unused: tuple[str, ...] = ()):
    """A soft contact law in a section (``k``, ``gamma``, ``e_n`` / ``young``, ``poisson``, ``A``) is complete,
    and neither the other law's keys nor ``unused`` are set."""
    own = SOFT_KEYS[model]
    foreign = [k for k in SOFT_KEYS["dashpot"] + SOFT_KEYS["hertz"] + unused if k not in own and getattr(section, k) is not None]
    if foreign:
        raise ValueError(f"{', '.join(foreign)} not used by the {model!r} contact law (it takes {', '.join(own)})")
    if model == "dashpot":
        if section.k is None:
            raise ValueError("'dashpot' needs the spring constant k")
        if section.gamma is not None and section.e_n is not None:
            raise ValueError("'dashpot': give gamma or e_n, not both")
    elif section.young is None or section.poisson is None:
        raise ValueError("'hertz' needs young and poisson (and A, default 0)")


def _build_soft_law(model: str, section, mass: float):
    """The :class:`~edmd.physics.contact.ContactModel` of a section (``mass``: the mean particle mass, for a dashpot's ``e_n``)."""
    from ..physics.contact import Hertz, LinearDashpot

    if model == "hertz":
        return Hertz(section.young, section.poisson, section.A or 0.0)
    if section.e_n is not None:
        return LinearDashpot.from_restitution(section.e_n, section.k, mass)
    return LinearDashpot(section.k, section.gamma or 0.0)


class CollisionConfig(_Section):
    """``[collision]``: the collision rule (:mod:`edmd.physics.collide`).

    ``rule``: ``"elastic"``; ``"inelastic"`` (``e_n``); ``"rough"`` (``e_n`` or the viscoelastic
    material, and ``beta`` or ``e_t = -beta``, optional Coulomb ``mu``); ``"viscoelastic"``
    (``young``, ``poisson``, ``A``). ``tc`` switches the TC model on with that duration.
    ``"emdstar"`` (soft spheres, :class:`edmd.physics.emdstar.EMDStar`): ``contact = "hertz"`` with
    ``young``, ``poisson``, ``A`` or ``contact = "dashpot"`` with ``k`` and ``gamma`` (or ``e_n``
    for two particles of the mean mass), ``tables`` and ``communication``; with a ``[friction]``
    section the contacts are frictional, ``beta`` sets the sticking restitution of the
    instantaneous fallback (default from the laws) and ``friction_table`` takes the tangential
    impulse from the hard-limit table instead of solving each contact.
    """

    rule: Literal["elastic", "inelastic", "rough", "viscoelastic", "emdstar"] = "elastic"
    e_n: float | None = Field(None, ge=0, le=1, description="normal restitution coefficient")
    beta: float | None = Field(None, ge=-1, le=1, description="tangential restitution (-1 smooth, 1 perfectly rough)")
    e_t: float | None = Field(None, ge=-1, le=1, description="tangential restitution in the e_t = -beta convention")
    mu: float | None = Field(None, ge=0, description="Coulomb friction coefficient")
    young: float | None = Field(None, gt=0, description="Young's modulus (viscoelastic)")
    poisson: float | None = Field(None, gt=-1, le=0.5, description="Poisson ratio (viscoelastic)")
    A: float | None = Field(None, ge=0, description="dissipative time constant (viscoelastic)")
    tc: float | None = Field(None, gt=0, description="TC model duration")
    contact: Literal["hertz", "dashpot"] | None = Field(None, description="emdstar: the soft contact law")
    k: float | None = Field(None, gt=0, description="emdstar dashpot: spring constant")
    gamma: float | None = Field(None, ge=0, description="emdstar dashpot: damping constant")
    tables: str | None = Field(None, description="emdstar: 'default', 'exact' or a table file")
    communication: bool | None = Field(None, description="emdstar: post-collisional communication (default true)")
    friction_table: bool | None = Field(None, description="emdstar with [friction]: the tangential impulse from the hard-limit table (default false)")

    @model_validator(mode="after")
    def _consistent(self):
        emd_keys = [k for k in ("contact", "k", "gamma", "tables", "communication", "friction_table") if getattr(self, k) is not None]
        if self.rule == "emdstar":
            return self._emdstar_consistent()
        if emd_keys:
            raise ValueError(f"{', '.join(emd_keys)}: only used by rule = 'emdstar'")
        material = [k for k in ("young", "poisson", "A") if getattr(self, k) is not None]
        tangential = [k for k in ("beta", "e_t", "mu") if getattr(self, k) is not None]
        if self.rule == "elastic" and (self.e_n not in (None, 1.0) or material or tangential):
            raise ValueError("rule 'elastic' takes no parameters but tc (use 'inelastic', 'rough' or 'viscoelastic')")
        if self.rule == "inelastic" and (self.e_n is None or material or tangential):
            raise ValueError("rule 'inelastic' needs e_n (and no tangential or material parameters)")
        if self.rule == "viscoelastic" and (len(material) < 3 or self.e_n is not None or tangential):
            raise ValueError("rule 'viscoelastic' needs young, poisson and A (and no e_n or tangential parameters)")
        if self.rule == "rough":
            if (self.e_n is None) == (len(material) < 3):
                raise ValueError("rule 'rough' needs either e_n or the viscoelastic material (young, poisson, A)")
            if self.beta is None and self.e_t is None:
                raise ValueError("rule 'rough' needs beta (or e_t = -beta)")
        if 0 < len(material) < 3:
            raise ValueError("the viscoelastic material needs all of young, poisson and A")
        return self

    def _emdstar_consistent(self):
        if self.contact is None:
            raise ValueError("rule 'emdstar' needs contact = 'hertz' (young, poisson, A) or 'dashpot' (k, gamma or e_n)")
        _check_soft_law(self.contact, self, unused=("e_t", "mu", "tc"))
        if self.e_n == 0.0:
            raise ValueError("e_n = 0 has no dashpot (its damping would be infinite): give 0 < e_n <= 1, or gamma")
        return self

    def soft_contact(self, mass: float):
        """The soft contact law of rule 'emdstar' (``mass``: the mean particle mass, for a dashpot's ``e_n``)."""
        return _build_soft_law(self.contact, self, mass)

    def material(self) -> collide.Viscoelastic | None:
        """The viscoelastic material, if given (not for rule 'emdstar', whose contact law is :meth:`soft_contact`)."""
        if self.young is None or self.rule == "emdstar":
            return None
        return collide.Viscoelastic(young=self.young, poisson=self.poisson, A=self.A)

    def build(self, mass: float = 1.0, friction=None) -> collide.Rule:
        """The :mod:`edmd.physics.collide` rule object (``mass``: the mean particle mass, see :meth:`soft_contact`;
        ``friction``: the :class:`~edmd.physics.friction.Friction` of frictional eMD* contacts)."""
        if self.rule == "emdstar":
            from ..physics.emdstar import EMDStar

            given = (("tables", self.tables), ("communication", self.communication), ("fallback_beta", self.beta), ("friction_table", self.friction_table))
            extra = {k: v for k, v in given if v is not None}
            return EMDStar(self.soft_contact(mass), friction=friction, **extra)
        if self.rule == "elastic":
            rule = collide.Inelastic(1.0)
        elif self.rule == "inelastic":
            rule = collide.Inelastic(self.e_n)
        elif self.rule == "viscoelastic":
            rule = self.material()
        else:
            rule = collide.Rough(self.e_n if self.e_n is not None else self.material(), beta=self.beta, e_t=self.e_t, mu=self.mu)
        return collide.TC(rule, self.tc) if self.tc is not None else rule


class WallsConfig(_Section):
    """``[walls]``: hard walls closing the listed axes at +-L/2 (the others stay periodic)."""

    axes: list[Literal["x", "y", "z"]] = []
    e_n: float | None = Field(None, ge=0, le=1, description="normal restitution of the walls (default 1; emdstar: the contact law)")
    beta: float | None = Field(None, ge=-1, le=1, description="tangential restitution (default -1: smooth)")
    e_t: float | None = Field(None, ge=-1, le=1)
    mu: float | None = Field(None, ge=0)
    viscoelastic: bool = Field(False, description="use the collision's viscoelastic material for e_n(v) at the walls")

    @model_validator(mode="after")
    def _consistent(self):
        if len(set(self.axes)) != len(self.axes):
            raise ValueError(f"axes repeated: {self.axes}")
        if self.beta is not None and self.e_t is not None:
            raise ValueError("give either beta or e_t (= -beta), not both")
        if self.viscoelastic and self.e_n is not None:
            raise ValueError("give either e_n or viscoelastic = true (e_n(v) of the collision's material), not both")
        return self

    def build(self, material: collide.Viscoelastic | None, soft=None) -> collide.Wall:
        """The :class:`edmd.physics.collide.Wall` object (``material``: the collision's, for ``viscoelastic``;
        ``soft``: the eMD* contact law, the default normal law of walls with rule 'emdstar')."""
        e_n = material if self.viscoelastic else self.e_n
        if e_n is None:
            e_n = 1.0 if soft is None else soft
        return collide.Wall(e_n=e_n, beta=self.beta, e_t=self.e_t, mu=self.mu)


class RunConfig(_Section):
    """``[run]``: how long, and how often to write output."""

    until_time: float = Field(20.0, gt=0, allow_inf_nan=True, description="inf: run until max_events or wall_time")
    output_interval: float = Field(1.0, gt=0, description="thermo row + trajectory frame every this much time")
    max_events: int | None = Field(None, ge=1)
    wall_time: float | None = Field(None, gt=0, description="stop after this many wall-clock seconds")
    progress: bool = True

    @model_validator(mode="after")
    def _ends(self):
        if math.isinf(self.until_time) and self.max_events is None and self.wall_time is None:
            raise ValueError("until_time = inf needs max_events or wall_time to end the run")
        return self


class EngineConfig(_Section):
    """``[engine]``: neighbour search and calendar tuning (see :class:`edmd.run.engine.EngineOptions`)."""

    neighbours: Literal["auto", "list", "cells"] = "auto"
    skin: float = Field(0.5, gt=0)
    resync_every: float = Field(200.0, gt=0)
    events_per_bucket: float = Field(4.0, gt=0)
    cell_size: float | None = Field(None, ge=1, description="cells mode: cell edge in largest contact distances (default: the cost model's)")
    auto_threshold: float | None = Field(None, gt=0, le=1, description='packing fraction from which "auto" takes lists (default: 0.35 spheres, 0.6 disks)')
    debug: bool = Field(False, description="check every collision for overlaps (slow; for testing)")


class IntegratorConfig(_Section):
    """``[integrator]``: event-driven MD of hard particles, or force-based MD (DEM) of soft ones."""

    kind: Literal["edmd", "dem"] = "edmd"
    dt: float | None = Field(None, gt=0, description="DEM time step (default: shortest contact / steps_per_contact)")
    steps_per_contact: float = Field(50.0, ge=10, description="DEM steps per shortest contact duration (>= 10)")
    impact_speed: float | None = Field(None, gt=0, description="impact speed for the Hertz contact duration (default from the state)")
    skin: float = Field(0.3, gt=0, description="DEM neighbour-list skin, in mean diameters")


class ContactConfig(_Section):
    """``[contact]``: the soft contact law of the DEM (see :mod:`edmd.physics.contact`).

    ``model = "dashpot"``: ``k`` and ``gamma`` (or ``e_n``: the restitution of two particles of
    the mean mass); ``model = "hertz"``: ``young``, ``poisson`` and ``A``.
    """

    model: Literal["dashpot", "hertz"]
    k: float | None = Field(None, gt=0, description="dashpot spring constant")
    gamma: float | None = Field(None, ge=0, description="dashpot damping constant")
    e_n: float | None = Field(None, gt=0, le=1, description="dashpot restitution (instead of gamma)")
    young: float | None = Field(None, gt=0, description="Hertz: Young's modulus")
    poisson: float | None = Field(None, gt=-1, le=0.5, description="Hertz: Poisson ratio")
    A: float | None = Field(None, ge=0, description="Hertz: dissipative time constant")

    @model_validator(mode="after")
    def _complete(self):
        _check_soft_law(self.model, self)
        return self

    def build(self, mass: float):
        """The :class:`~edmd.physics.contact.ContactModel` (``mass``: the mean particle mass, for ``e_n``)."""
        return _build_soft_law(self.model, self, mass)


class FrictionConfig(_Section):
    """``[friction]``: tangential spring, damping and Coulomb slider of soft contacts, in the DEM or
    in eMD* (see :mod:`edmd.physics.friction`); the particles' spins then evolve."""

    mu: float = Field(ge=0, allow_inf_nan=True, description="Coulomb friction coefficient (inf: never slides)")
    law: Literal["linear", "mindlin"] = Field("linear", description="linear: constant k_t (Cundall-Strack); mindlin: k_t = stiffness * contact radius")
    stiffness: float | None = Field(None, gt=0, allow_inf_nan=False, description="k_t (linear, needed) or k_t0 (mindlin; default 8 G_eff of the Hertz law)")
    damping: float = Field(0.0, ge=0, allow_inf_nan=False, description="tangential damping as a multiple of the normal damping coefficient")

    def build(self):
        """The :class:`~edmd.physics.friction.Friction`."""
        from ..physics.friction import Friction

        return Friction(mu=self.mu, law=self.law, stiffness=self.stiffness, damping=self.damping)


class ThermostatConfig(_Section):
    """``[thermostat]``: a heat bath acting through events (:class:`edmd.Andersen`), or exact
    rescaling of the temperature at fixed intervals (:class:`edmd.VelocityRescale`)."""

    kind: Literal["andersen", "rescale"] = Field(
        description="andersen: each particle's velocity is drawn anew at Poisson times; rescale: all velocities scaled to kT every interval"
    )
    kT: float = Field(gt=0, allow_inf_nan=False, description="bath (target) temperature")
    rate: float | None = Field(None, gt=0, allow_inf_nan=False, description="andersen: rate of each particle's bath events")
    seed: int = Field(0, ge=0, lt=2**63, description="andersen: random seed of the bath")
    interval: float | None = Field(None, gt=0, allow_inf_nan=False, description="rescale: time between two rescalings")

    @model_validator(mode="after")
    def _keys_of_kind(self):
        needed, unused = ("rate", "interval") if self.kind == "andersen" else ("interval", "rate")
        if getattr(self, needed) is None:
            raise ValueError(f"kind = {self.kind!r} needs {needed}")
        if getattr(self, unused) is not None:
            raise ValueError(f"{unused} is not used by kind = {self.kind!r}")
        return self

    def build(self) -> Andersen | None:
        """The event-driven bath (``None`` for ``rescale``, an updater: :meth:`updater`)."""
        return Andersen(kT=self.kT, rate=self.rate, seed=self.seed) if self.kind == "andersen" else None

    def updater(self) -> VelocityRescale | None:
        """The rescaling updater of ``kind = "rescale"`` (``None`` for the bath)."""
        return VelocityRescale(kT=self.kT, interval=self.interval) if self.kind == "rescale" else None


class ForcingConfig(_Section):
    """``[forcing]``: random kicks at fixed intervals (see :class:`edmd.WhiteNoise`)."""

    kind: Literal["white_noise"] = Field(description="white_noise: every particle gets a Gaussian kick every interval, momentum kept")
    xi0: float = Field(gt=0, allow_inf_nan=False, description="strength: kick variance xi0^2 * interval per component")
    interval: float = Field(gt=0, allow_inf_nan=False, description="time between kicks")
    seed: int = Field(0, ge=0, lt=2**63, description="random seed of the kicks")
    start: float = Field(0.0, allow_inf_nan=False, description="time of kick 0")

    def build(self) -> WhiteNoise:
        return WhiteNoise(xi0=self.xi0, interval=self.interval, seed=self.seed, start=self.start)


class VibrationConfig(_Section):
    """``[vibration]``: one wall moving along its normal (see :class:`edmd.VibratingWall`)."""

    axis: Literal["x", "y", "z"] = Field("z", description="a walled axis (walls.axes)")
    side: Literal["lower", "upper"] = Field("lower", description="which wall of the axis moves")
    amplitude: float = Field(gt=0, allow_inf_nan=False, description="a: the wall sweeps [0, 2a] into the box")
    omega: float = Field(gt=0, allow_inf_nan=False, description="angular frequency")
    phase: float = Field(0.0, allow_inf_nan=False, description="phase at time 0 (radians)")
    wave: Literal["sine", "triangle", "sawtooth"] = Field("sine", description="waveform of the displacement")
    stick_speed: float | None = Field(
        None, ge=0, allow_inf_nan=False,
        description="rebound speed below which a pressed particle rides on the wall (default 1e-6 amplitude omega; 0: never)",
    )  # fmt: skip

    def build(self) -> VibratingWall:
        return VibratingWall(
            amplitude=self.amplitude, omega=self.omega, phase=self.phase, axis=self.axis, side=self.side, wave=self.wave, stick_speed=self.stick_speed
        )  # fmt: skip


class WellConfig(_Section):
    """``[well]``: square-well attraction between the hard cores (see :class:`edmd.SquareWell`)."""

    width: float = Field(gt=1, allow_inf_nan=False, description="lambda: the edge at lambda * (R_i + R_j)")
    depth: float = Field(gt=0, allow_inf_nan=False, description="epsilon: the energy gained on entering the well")

    def build(self) -> SquareWell:
        return SquareWell(width=self.width, depth=self.depth)


class ShearConfig(_Section):
    """``[shear]``: uniform shear flow by Lees-Edwards boundaries (see :class:`edmd.Shear`): flow along
    x, gradient along y."""

    rate: float = Field(allow_inf_nan=False, description="shear rate gamma_dot (the images above move towards +x)")
    profile: bool = Field(True, description="start the generated initial state in the flow: v_x += rate * y (not a state read from system.from_file)")

    def build(self) -> Shear:
        return Shear(rate=self.rate)


class OutputConfig(_Section):
    """``[output]``: which files the run directory gets."""

    thermo: bool = True
    trajectory: bool = True
    trajectory_interval: float | None = Field(None, gt=0, description="default: run.output_interval")
    checkpoint: bool = True
    checkpoint_interval: float | None = Field(None, gt=0, description="simulation time; default: run.output_interval")
    checkpoint_wall_interval: float | None = Field(None, gt=0, description="seconds between checkpoint writes")
    plots: bool = True
    wall_impacts: bool = Field(False, description="wall_impacts.csv: every impact on a wall (time, particle, wall, speeds)")


class Config(_Section):
    """A whole run."""

    @model_validator(mode="after")
    def _walls_fit(self):
        if self.system.dim == 2 and "z" in self.walls.axes:
            raise ValueError("walls.axes: a 2D system has no z axis")
        if self.walls.viscoelastic and self.collision.young is None:
            raise ValueError("walls.viscoelastic needs a viscoelastic material in [collision] (young, poisson, A)")
        walled = [axis for axis, c in zip("xyz", self.system.replicate or []) if c > 1 and axis in self.walls.axes]
        if walled:
            raise ValueError(f"system.replicate tiles the periodic axes only; walls close {walled[0]!r}")
        if self.vibration is not None and self.vibration.axis not in self.walls.axes:
            raise ValueError(f"vibration.axis = {self.vibration.axis!r} must be one of walls.axes (the vibrating wall is one of its walls)")
        if self.shear is not None and {"x", "y"} & set(self.walls.axes):
            raise ValueError("[shear] needs periodic x (the flow) and y (the gradient): walls.axes may hold 'z' only")
        if self.shear is not None and (self.thermostat, self.forcing, self.vibration, self.well) != (None,) * 4:
            raise ValueError("[shear] cannot be combined with [thermostat], [forcing], [vibration] or [well] (yet)")
        if self.shear is not None and any(self.system.gravity or []):
            raise ValueError("[shear] cannot be combined with gravity (yet)")
        return self

    system: SystemConfig = SystemConfig()
    collision: CollisionConfig = CollisionConfig()
    walls: WallsConfig = WallsConfig()
    run: RunConfig = RunConfig()
    engine: EngineConfig = EngineConfig()
    output: OutputConfig = OutputConfig()
    integrator: IntegratorConfig = IntegratorConfig()
    contact: ContactConfig | None = None
    friction: FrictionConfig | None = None
    thermostat: ThermostatConfig | None = None
    forcing: ForcingConfig | None = None
    vibration: VibrationConfig | None = None
    well: WellConfig | None = None
    shear: ShearConfig | None = None

    @model_validator(mode="after")
    def _integrator(self):
        if self.integrator.kind == "dem":
            if self.contact is None:
                raise ValueError("integrator.kind = 'dem' needs a [contact] section (model = 'dashpot' or 'hertz')")
            if self.collision.rule != "elastic" or self.collision.tc is not None:
                raise ValueError("the DEM takes its dissipation from [contact]; leave [collision] at rule = 'elastic' (no tc)")
            if self.walls.axes:
                raise ValueError("the DEM needs a periodic box: leave walls.axes empty")
            if any(x is not None for x in (self.thermostat, self.forcing, self.vibration, self.well, self.shear)):
                raise ValueError("[thermostat], [forcing], [vibration], [well] and [shear] act through events: they need integrator.kind = 'edmd'")
            soft = self.contact.model
        elif self.contact is not None:
            raise ValueError("[contact] is used by integrator.kind = 'dem' only")
        elif self.friction is not None and self.collision.rule != "emdstar":
            raise ValueError("[friction] (frictional contacts of soft particles) needs integrator.kind = 'dem' or collision.rule = 'emdstar'")
        else:
            soft = self.collision.contact
        if self.friction is not None and self.friction.law == "mindlin" and self.friction.stiffness is None and soft != "hertz":
            raise ValueError("friction.law = 'mindlin' takes its stiffness from a Hertz contact law; give friction.stiffness for a dashpot")
        if self.friction is not None and self.friction.law == "linear" and self.friction.stiffness is None:
            raise ValueError("friction.law = 'linear' needs friction.stiffness (the tangential spring constant k_t)")
        if self.collision.rule == "emdstar" and self.collision.beta is not None and self.friction is None:
            raise ValueError("collision.beta of rule 'emdstar' is the sticking restitution of frictional contacts: it needs a [friction] section")
        if self.collision.friction_table and self.friction is None:
            raise ValueError("collision.friction_table is the tangential map of frictional contacts: it needs a [friction] section")
        if self.collision.rule == "emdstar" and self.friction is not None:
            from ..physics.emdstar import STICKING_PAIRINGS, TABLE_CHOICES

            pairing = (soft, self.friction.law)
            if self.collision.beta is None and pairing not in STICKING_PAIRINGS:
                raise ValueError(f"a {pairing[1]} spring with a {pairing[0]} contact has no sticking restitution of its own: give collision.beta (the fallback's beta_0)")
            if pairing == ("dashpot", "mindlin") and self.friction.damping > 0.0:
                raise ValueError("friction.damping > 0 with law = 'mindlin' on a dashpot contact cannot be solved by eMD* (Mindlin's stiffness vanishes at the touch): use damping = 0 or law = 'linear'")
            if self.collision.friction_table and pairing not in STICKING_PAIRINGS:
                raise ValueError(f"collision.friction_table covers a dashpot with a linear spring or Hertz with Mindlin, not a {pairing[1]} spring with a {pairing[0]} contact")
            if self.collision.tables not in (None, *TABLE_CHOICES) and not self.collision.friction_table:
                raise ValueError("collision.tables: frictional contacts are solved directly (a table file needs friction_table = true)")
        return self


def _given(section: BaseModel, keys) -> list[str]:
    """Those of ``keys`` that the configuration sets in ``section`` to other than their defaults
    (a configuration written out in full, as a sweep's points are, sets every key)."""
    fields = type(section).model_fields
    return [k for k in keys if k in section.model_fields_set and getattr(section, k) != fields[k].default]


def ignored_keys(cfg: Config) -> list[str]:
    """The keys a configuration sets (to other than their defaults) that its run would not use,
    each with the reason.

    Valid but without effect (a run keeps them in its stored configuration, so they are not
    refused): a wall's restitution with no walls, a time step of the DEM in an event-driven run,
    a cell size with neighbour lists. ``edmd run`` warns about them for a new run. The keys of
    ``[system]`` with ``from_file`` are not listed (the command says that they are ignored).

    Example:
        >>> cfg = parse_config({"walls": {"e_n": 0.9}, "integrator": {"dt": 1e-3}})
        >>> for note in ignored_keys(cfg):
        ...     print(note)
        walls.e_n: no walls (walls.axes is empty)
        integrator.dt: used by integrator.kind = 'dem' only
    """
    notes = []
    s, w, i, e = cfg.system, cfg.walls, cfg.integrator, cfg.engine
    if s.from_file is None:
        notes += [f"system.{k}: picks a frame of system.from_file, which is not given" for k in _given(s, ["from_frame"])]
    if s.init != "compress":
        notes += [f"system.{k}: used by init = 'compress' only" for k in _given(s, ["compress_rate"])]
    if not w.axes:
        notes += [f"walls.{k}: no walls (walls.axes is empty)" for k in _given(w, ["e_n", "beta", "e_t", "mu", "viscoelastic"])]
    if i.kind == "dem":
        return notes + [f"engine.{k}: the DEM has no event engine (its neighbour-list skin is integrator.skin)" for k in _given(e, EngineConfig.model_fields)]
    notes += [f"integrator.{k}: used by integrator.kind = 'dem' only" for k in _given(i, ["dt", "steps_per_contact", "impact_speed", "skin"])]
    if e.neighbours == "list":
        notes += [f"engine.{k}: used by neighbours = 'cells' only" for k in _given(e, ["cell_size"])]
    if e.neighbours != "auto":
        notes += [f"engine.{k}: chooses between lists and cells for neighbours = 'auto' only" for k in _given(e, ["auto_threshold"])]
    return notes


def _known_keys(model: type[BaseModel], loc: tuple) -> list[str]:
    for part in loc[:-1]:
        field = model.model_fields.get(part) if isinstance(part, str) else None
        ann = getattr(field, "annotation", None) if field else None
        models = [a for a in typing.get_args(ann) if isinstance(a, type) and issubclass(a, BaseModel)]
        ann = models[0] if models and not isinstance(ann, type) else ann
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            model = ann
        else:
            return []
    return list(model.model_fields)


#: location parts that name a branch of a union or a validator, not a key
_BRANCH_TAGS = {"float", "int", "str", "bool", "RadiusDistribution"}


def _is_branch(part) -> bool:
    return isinstance(part, str) and (part.startswith(("function-", "constrained-")) or "[" in part or part in _BRANCH_TAGS)


def _field(err: dict) -> tuple:
    return tuple(p for p in err["loc"] if not _is_branch(p))


def _relevant(errors: list[dict]) -> list[dict]:
    """Of a number-or-table union (``radius``), the errors of the branch the user meant:
    the table's for a table, the number's otherwise."""
    model_types = ("model_type", "dict_type", "model_attributes_type")
    keep = []
    for err in errors:
        table_given = isinstance(err.get("input"), dict)
        number_branch = any(p in ("float", "constrained-float") for p in err["loc"])
        if number_branch and table_given:
            continue
        if err["type"] in model_types and not table_given and any(e is not err and _field(e) == _field(err) for e in errors):
            continue
        keep.append(err)
    return keep or errors


def format_errors(exc: ValidationError, prefix: tuple = ()) -> str:
    """A readable message of a pydantic error: one line per problem, each naming its key."""
    lines = []
    for err in _relevant(exc.errors()):
        loc = prefix + _field(err)
        key = ".".join(str(p) for p in loc) or "(top level)"
        if err["type"] == "extra_forbidden":
            hint = difflib.get_close_matches(str(loc[-1]), _known_keys(Config, loc), n=1)
            extra = f" (did you mean '{hint[0]}'?)" if hint else ""
            lines.append(f"{key}: unknown key{extra}")
        else:
            msg = err["msg"].removeprefix("Value error, ")
            if err["type"] == "int_type" and isinstance(err.get("input"), float) and err["input"].is_integer():
                msg += f"; write it without a decimal point or exponent ({int(err['input'])})"
            lines.append(f"{key}: {msg} (got {err.get('input')!r})" if "input" in err and not isinstance(err["input"], dict) else f"{key}: {msg}")
    return "invalid configuration:\n  " + "\n  ".join(dict.fromkeys(lines))


#: top-level tables of a sweep file (:mod:`edmd.app.sweeps`), not of a run configuration
SWEEP_TABLES = ("base", "grid", "points")


def parse_config(data: dict[str, Any]) -> Config:
    """Validate a configuration dict; raises :class:`ConfigError` with readable messages."""
    sweep = [k for k in SWEEP_TABLES if k in data]
    if sweep:
        tables = ", ".join(f"[{k}]" for k in sweep)
        raise ConfigError(f"this is a sweep file (it has {tables}), not a run configuration: run it with `edmd sweep FILE`")
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_errors(exc)) from None


def load_config(path: str | Path) -> Config:
    """Read and validate a TOML configuration file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"cannot read config file {path}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path} is not a text file (TOML configurations are UTF-8 text)") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path} is not valid TOML: {exc}") from None
    return parse_config(data)


def dump_config(cfg: Config) -> str:
    """The fully resolved configuration as TOML (every default written out)."""
    lines = []
    for section, model in cfg:
        if model is None:
            continue
        lines.append(f"[{section}]")
        for key, value in model:
            if value is None:
                continue
            lines.append(f"{key} = {_toml_value(value)}")
        lines.append("")
    return "\n".join(lines)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, BaseModel):
        items = {k: x for k, x in v.model_dump().items() if x is not None}
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in items.items()) + " }"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {v!r} as TOML")


EXAMPLE = """\
# edmd run configuration. Every key is optional; these are the defaults unless noted.
# Run it with:  edmd run this-file.toml --out my-run

[system]
dim = 3                   # 2 (disks) or 3 (spheres)
n = 4000                  # number of particles
packing_fraction = 0.3    # eta = total particle volume / box volume
kT = 1.0                  # initial temperature (Maxwell-Boltzmann, zero total momentum)
seed = 1                  # random seed: runs are reproducible
init = "lattice"          # "lattice" (fcc/sc in 3D, hex/square in 2D), "random" (low density) or
                          # "compress" (random at low density, grown to packing_fraction: dense fluids, glasses)
# compress_rate = 0.02    # init = "compress": radii grow as R(0) (1 + rate t) (slower: closer to equilibrium)
# replicate = [4, 4, 4]   # build n / 64 particles, tile them 4 x 4 x 4 (fast large amorphous starts)
# lattice = "fcc"
radius = 0.5              # or a distribution, e.g. { kind = "uniform", min = 0.4, max = 0.6 }
mass = 1.0                # or set density = ... to give mass = density * particle volume

# gravity = [0.0, 0.0, -9.81]   # uniform acceleration (put it in [system])

[collision]
rule = "elastic"          # "inelastic" (e_n), "rough" (e_n, beta or e_t = -beta, optional Coulomb mu),
                          # "viscoelastic" (young, poisson, A: e_n(v) of viscoelastic spheres),
                          # "emdstar" (soft spheres, eMD*: contact = "hertz" or "dashpot", see below)
# e_n = 0.9
# beta = 0.0
# tc = 1e-5               # TC model against inelastic collapse: elastic within tc of a previous collision
# contact = "hertz"       # emdstar: "hertz" (young, poisson, A) or "dashpot" (k, gamma or e_n)
# young = 1e7
# poisson = 0.3
# A = 1e-5
# tables = "default"      # emdstar: "default" (shipped tables), "exact" (solve every contact) or a table file
# communication = true    # emdstar: exception b) also ends the former partner's pending contact
#                         # emdstar with a [friction] section: frictional contacts with spins (beta: the
#                         #   sticking restitution of the instantaneous fallback; default from the laws)
# friction_table = false  # emdstar with [friction]: tangential impulse from the hard-limit table (~100x
#                         #   cheaper per contact; first order in the softness, docs/physics.md 4.12)

[walls]
axes = []                 # axes closed by hard walls at +-L/2, e.g. ["z"]; the others are periodic
# e_n = 1.0               # wall restitution (beta, e_t, mu as for rough particles; emdstar: the contact law)

[run]
until_time = 20.0         # simulation time to reach
output_interval = 1.0     # thermo row + trajectory frame every this much simulation time
# max_events = 1000000
# wall_time = 3600        # seconds
progress = true

[engine]
neighbours = "auto"       # "list" (dense), "cells" (dilute) or "auto"
skin = 0.5                # neighbour-list shell, in mean diameters

[output]
thermo = true             # thermo.csv: time, events, collisions, temperature, pressure, ...
trajectory = true         # trajectory.gsd (GSD 5, double precision)
# trajectory_interval = 5.0
checkpoint = true         # checkpoint.gsd: continue with `edmd run --restart DIR`, bit for bit
# checkpoint_interval = 10.0       # simulation time between checkpoint points (default: output_interval)
# checkpoint_wall_interval = 600   # write a point only if this many seconds passed since the last write
plots = true              # PNG figures at the end of the run (also: `edmd plot DIR`)
# wall_impacts = false    # wall_impacts.csv: every wall impact (then `edmd steady DIR --impacts`)

# [thermostat]            # a heat bath (edmd integrator only)
# kind = "andersen"       # each particle's velocity (and spin) drawn anew from Maxwell-Boltzmann at kT
# kT = 1.0                #   at the times of its own Poisson process of this rate
# rate = 0.1
# seed = 0
#                         # or: kind = "rescale", kT = 1.0, interval = 1.0: every velocity scaled
#                         #   (about the mean) to temperature kT at exact times, every interval

# [forcing]               # random kicks (edmd integrator only)
# kind = "white_noise"    # every particle's velocity gets a Gaussian kick of variance xi0^2 * interval
# xi0 = 1.0               #   per component every interval (the mean kick removed: momentum kept)
# interval = 0.01
# seed = 0

# [vibration]             # a vibrating wall (edmd integrator only): displaced into the box by
# axis = "z"              #   amplitude * (1 + w(omega t + phase)), w = sin, triangle or sawtooth
# side = "lower"          #   the axis must be in walls.axes
# amplitude = 0.1
# omega = 10.0
# phase = 0.0
# wave = "sine"
# stick_speed = 0.0       #   a particle chattering to rest rides on the wall (default 1e-6 amplitude omega; 0: never)

# [well]                  # square-well attraction between the hard cores (edmd integrator, neighbour lists)
# width = 1.5             #   the edge at width * (R_i + R_j): pairs inside have energy -depth
# depth = 1.0

# [shear]                 # uniform shear flow, Lees-Edwards boundaries (edmd integrator; auto takes cells): flow along x,
# rate = 0.1              #   gradient along y; temperatures and the kinetic stress are peculiar
# profile = true          #   start in the flow (v_x += rate * y)

[integrator]
kind = "edmd"             # "edmd" (event-driven, hard particles) or "dem" (force-based, soft contacts)
# steps_per_contact = 50  # DEM time step = shortest contact duration / steps_per_contact (or set dt)

# [contact]               # the soft contact law, needed by kind = "dem"
# model = "dashpot"       # "dashpot": k, gamma (or e_n); "hertz": young, poisson, A
# k = 1e4
# e_n = 0.9
# [friction]              # optional with kind = "dem" or rule = "emdstar": tangential spring + Coulomb slider, spins evolve
# mu = 0.3                # Coulomb coefficient (inf: never slides)
# law = "linear"          # "linear" (k_t = stiffness) or "mindlin" (k_t = stiffness * contact radius)
# stiffness = 2857.0      # k_t; mindlin with a Hertz contact may leave it out (8 G_eff)
# damping = 0.0           # tangential damping / normal damping coefficient
"""

#: The built-in job of ``edmd run`` without a configuration: a freely cooling granular gas
#: (Haff's law, physics.md §5.4) that leaves every kind of output behind.
DEFAULT_JOB = """\
[system]
dim = 3
n = 8000
packing_fraction = 0.15
kT = 1.0
seed = 1

[collision]
rule = "inelastic"
e_n = 0.9

[run]
until_time = 1000.0
output_interval = 1.0

[output]
trajectory_interval = 50.0
checkpoint_interval = 50.0
"""


def default_job() -> Config:
    """The built-in showcase job (:data:`DEFAULT_JOB`)."""
    return parse_config(tomllib.loads(DEFAULT_JOB))
