"""Run configuration: a TOML file validated by pydantic (unknown keys are errors).

Example:
    >>> cfg = parse_config({"system": {"dim": 2, "n": 100, "packing_fraction": 0.2}, "run": {"until_time": 1.0}})
    >>> cfg.system.dim, cfg.run.output_interval
    (2, 1.0)
"""

from __future__ import annotations

import difflib
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator


class ConfigError(ValueError):
    """A configuration problem; the message names the key and what is wrong."""


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


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
    seed: int = 1
    init: Literal["lattice", "random"] = "lattice"
    lattice: Literal["fcc", "sc", "hex", "square"] | None = None
    radius: Annotated[float, Field(gt=0)] | RadiusDistribution = 0.5
    mass: float = Field(1.0, gt=0)
    density: float | None = Field(None, gt=0, description="material density: mass = density * volume")
    aspect: list[Annotated[float, Field(gt=0)]] | None = None
    from_file: str | None = Field(None, description="start from a frame of this GSD file (other keys then ignored)")
    from_frame: int = Field(-1, description="frame of from_file (negative counts from the end)")

    @model_validator(mode="after")
    def _consistent(self):
        if self.lattice is not None and self.init != "lattice":
            raise ValueError("'lattice' is only used with init = 'lattice'")
        if self.lattice in ("fcc", "sc") and self.dim == 2 or self.lattice in ("hex", "square") and self.dim == 3:
            raise ValueError(f"lattice {self.lattice!r} does not exist in {self.dim}D")
        if self.aspect is not None and len(self.aspect) != self.dim:
            raise ValueError(f"aspect needs {self.dim} numbers")
        return self


class CollisionConfig(_Section):
    """``[collision]``: the collision rule."""

    rule: Literal["elastic", "inelastic"] = "elastic"
    e_n: float = Field(1.0, ge=0, le=1, description="normal restitution coefficient")

    @model_validator(mode="after")
    def _consistent(self):
        if self.rule == "elastic" and self.e_n != 1.0:
            raise ValueError("rule 'elastic' has e_n = 1; use rule = 'inelastic' for e_n < 1")
        return self


class RunConfig(_Section):
    """``[run]``: how long, and how often to write output."""

    until_time: float = Field(20.0, gt=0)
    output_interval: float = Field(1.0, gt=0, description="thermo row + trajectory frame every this much time")
    max_events: int | None = Field(None, ge=1)
    wall_time: float | None = Field(None, gt=0, description="stop after this many wall-clock seconds")
    progress: bool = True


class EngineConfig(_Section):
    """``[engine]``: neighbour search and calendar tuning (see :class:`edmd.engine.EngineOptions`)."""

    neighbours: Literal["auto", "list", "cells"] = "auto"
    skin: float = Field(0.5, gt=0)
    resync_every: float = Field(50.0, gt=0)
    events_per_bucket: float = Field(4.0, gt=0)


class OutputConfig(_Section):
    """``[output]``: which files the run directory gets."""

    thermo: bool = True
    trajectory: bool = True
    trajectory_interval: float | None = Field(None, gt=0, description="default: run.output_interval")
    checkpoint: bool = True
    checkpoint_interval: float | None = Field(None, gt=0, description="simulation time; default: run.output_interval")
    checkpoint_wall_interval: float | None = Field(None, gt=0, description="seconds between checkpoint writes")
    plots: bool = True


class Config(_Section):
    """A whole run."""

    system: SystemConfig = SystemConfig()
    collision: CollisionConfig = CollisionConfig()
    run: RunConfig = RunConfig()
    engine: EngineConfig = EngineConfig()
    output: OutputConfig = OutputConfig()


def _known_keys(model: type[BaseModel], loc: tuple) -> list[str]:
    for part in loc[:-1]:
        field = model.model_fields.get(part) if isinstance(part, str) else None
        ann = getattr(field, "annotation", None) if field else None
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            model = ann
        else:
            return []
    return list(model.model_fields)


def _format(exc: ValidationError) -> str:
    lines = []
    for err in exc.errors():
        loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p.startswith(("function-", "RadiusDistribution"))))
        key = ".".join(str(p) for p in loc) or "(top level)"
        if err["type"] == "extra_forbidden":
            hint = difflib.get_close_matches(str(loc[-1]), _known_keys(Config, loc), n=1)
            extra = f" (did you mean '{hint[0]}'?)" if hint else ""
            lines.append(f"{key}: unknown key{extra}")
        else:
            msg = err["msg"].removeprefix("Value error, ")
            lines.append(f"{key}: {msg} (got {err.get('input')!r})" if "input" in err and not isinstance(err["input"], dict) else f"{key}: {msg}")
    return "invalid configuration:\n  " + "\n  ".join(dict.fromkeys(lines))


def parse_config(data: dict[str, Any]) -> Config:
    """Validate a configuration dict; raises :class:`ConfigError` with readable messages."""
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(_format(exc)) from None


def load_config(path: str | Path) -> Config:
    """Read and validate a TOML configuration file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"cannot read config file {path}: {exc.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path} is not valid TOML: {exc}") from None
    return parse_config(data)


def dump_config(cfg: Config) -> str:
    """The fully resolved configuration as TOML (every default written out)."""
    lines = []
    for section, model in cfg:
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
init = "lattice"          # "lattice" (fcc/sc in 3D, hex/square in 2D) or "random" (low density)
# lattice = "fcc"
radius = 0.5              # or a distribution, e.g. { kind = "uniform", min = 0.4, max = 0.6 }
mass = 1.0                # or set density = ... to give mass = density * particle volume

[collision]
rule = "elastic"          # or "inelastic" with e_n < 1
# e_n = 0.9

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
