"""Sweep files: a base run configuration times a grid and/or a list of overrides by dotted key.

A sweep file (TOML)::

    replicas = 2                 # optional: each point this many times, with distinct seeds
    base = "run.toml"            # the base run configuration: a file (relative to this one) ...
    # [base.system]              # ... or inline tables, exactly as in a run file
    # n = 500

    [grid]                       # every combination of these values
    "collision.e_n" = [0.7, 0.8, 0.9]
    system.packing_fraction = [0.05, 0.1]

    [[points]]                   # explicit points; with a grid, each point takes every combination
    "system.n" = 100

Points are ``points x grid x replicas`` (the last varying fastest).

Example:
    >>> spec = SweepSpec.from_dict({
    ...     "base": {"system": {"dim": 2, "n": 64}, "collision": {"rule": "inelastic"}},
    ...     "grid": {"collision.e_n": [0.8, 0.9], "system": {"packing_fraction": [0.05, 0.1]}},
    ...     "replicas": 2,
    ... })
    >>> len(spec.expand())
    8
    >>> [p.params for p in spec.resolve()[:2]]  # doctest: +NORMALIZE_WHITESPACE
    [{'collision.e_n': 0.8, 'system.packing_fraction': 0.05, 'system.seed': 1, 'replica': 0},
     {'collision.e_n': 0.8, 'system.packing_fraction': 0.05, 'system.seed': 1454127163, 'replica': 1}]
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import hashlib
import itertools
import math
import tomllib
from pathlib import Path
from typing import Any, get_args

import numpy as np

from ..config import Config, ConfigError, SystemConfig, dump_config, parse_config

TOP_LEVEL = ("base", "grid", "points", "replicas")
#: the most points one sweep may have (each is a directory and a process; 1e8 replicas filled the memory)
MAX_POINTS = 100_000


class SweepError(ConfigError):
    """A problem with a sweep file or a sweep directory; the message names it."""


@dataclasses.dataclass(frozen=True)
class RawPoint:
    """One point of a sweep before validation.

    Attributes:
        index: position in the sweep (points x grid x replicas, the last varying fastest).
        overrides: dotted key -> value applied to the base (the replica's seed included).
        replica: replica number (0 when the sweep has no replicas).
        config: the base configuration with the overrides applied (a nested dict).
    """

    index: int
    overrides: dict[str, Any]
    replica: int
    config: dict[str, Any]


@dataclasses.dataclass(frozen=True)
class Point:
    """One validated point of a sweep.

    Attributes:
        index: position in the sweep.
        params: the swept keys (and ``replica``) with their resolved values: the point's row in the results.
        config: the fully resolved configuration.
        text: ``config`` as TOML (:func:`edmd.app.config.dump_config`): what the point's directory stores.
        id: the point's directory name, a hash of ``text``.
    """

    index: int
    params: dict[str, Any]
    config: Config
    text: str
    id: str


def config_id(text: str) -> str:
    """The directory name of a resolved configuration: the first 16 hex digits of its SHA-256.

    Example:
        >>> len(config_id(dump_config(Config()))), config_id("a") == config_id("b")
        (16, False)
    """
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def replica_seed(seed: int, replica: int) -> int:
    """The seed of replica ``replica`` of a point whose configuration has ``system.seed = seed``.

    Replica 0 keeps ``seed``; replica ``k > 0`` gets a 32-bit seed drawn from numpy's
    ``SeedSequence(seed, spawn_key=(k,))``: deterministic, independent streams, and the same
    for every point that shares ``seed`` (common random numbers across the grid).

    Example:
        >>> replica_seed(1, 0), replica_seed(1, 1) == replica_seed(1, 1), replica_seed(1, 1) == replica_seed(2, 1)
        (1, True, False)
    """
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise SweepError(f"replicas need system.seed to be a non-negative integer, got {seed!r}")
    if replica == 0:
        return seed
    return int(np.random.SeedSequence(seed, spawn_key=(replica,)).generate_state(1)[0])


def known_keys() -> list[str]:
    """Every dotted key a sweep may set (``section.field`` of :class:`edmd.app.config.Config`)."""
    return [f"{s}.{f}" for s, field in Config.model_fields.items() for f in _section_model(field.annotation).model_fields]


def _section_model(annotation):
    """The pydantic model of a configuration section (optional sections: ``Model | None``)."""
    if isinstance(annotation, type):
        return annotation
    return next(a for a in get_args(annotation) if isinstance(a, type) and a is not type(None))


def check_key(key: str, where: str):
    """Raise :class:`SweepError` naming ``key`` (and the closest known key) if it is not a configuration key."""
    known = known_keys()
    if key not in known:
        hint = difflib.get_close_matches(key, known, n=1)
        raise SweepError(f"{where}: unknown key '{key}'" + (f" (did you mean '{hint[0]}'?)" if hint else ""))


@dataclasses.dataclass
class SweepSpec:
    """A sweep: a base configuration (nested dict, as in a run file), a grid, explicit points, replicas.

    Build it with :meth:`from_dict` or :meth:`load` (they check the file's structure); :meth:`expand`
    lists the points without validating them, :meth:`resolve` validates every point.

    Attributes:
        base: the base run configuration (not validated on its own: the points are).
        grid: dotted key -> list of values; every combination is a point.
        points: explicit points, each a dict of dotted key -> value.
        replicas: copies of every point with distinct seeds (:func:`replica_seed`).
    """

    base: dict[str, Any]
    grid: dict[str, list]
    points: list[dict[str, Any]]
    replicas: int = 1

    # ------------------------------------------------------------------ reading
    @classmethod
    def from_dict(cls, data: dict[str, Any], root: str | Path | None = None) -> SweepSpec:
        """A sweep from the contents of a sweep file; ``root`` is where a ``base = "file"`` path starts."""
        if not isinstance(data, dict):
            raise SweepError(f"a sweep must be a table, got {type(data).__name__}")
        for key in data:
            if key not in TOP_LEVEL:
                hint = difflib.get_close_matches(key, TOP_LEVEL, n=1)
                raise SweepError(f"unknown sweep key '{key}'" + (f" (did you mean '{hint[0]}'?)" if hint else f"; known: {', '.join(TOP_LEVEL)}"))
        spec = cls(
            base=_read_base(data.get("base", {}), Path(root) if root is not None else Path.cwd()),
            grid=_read_grid(data["grid"]) if "grid" in data else {},
            points=_read_points(data["points"]) if "points" in data else [],
            replicas=_read_replicas(data.get("replicas", 1)),
        )
        spec._check_structure()
        return spec

    @classmethod
    def load(cls, path: str | Path) -> SweepSpec:
        """Read a sweep file (TOML)."""
        path = Path(path)
        return cls.from_dict(_read_toml(path, "sweep file"), root=path.parent)

    def _check_structure(self):
        for i, point in enumerate(self.points):
            both = [k for k in point if k in self.grid]
            if both:
                raise SweepError(f"points[{i}]: '{both[0]}' is also a [grid] key; a key is swept by one of them")
        if not self.grid and not self.points and self.replicas == 1:
            raise SweepError("nothing to sweep: give a [grid], [[points]] or replicas > 1")

    def to_dict(self) -> dict[str, Any]:
        """The sweep as a sweep-file dict (the base inlined)."""
        return {"replicas": self.replicas, "base": self.base, "grid": self.grid, "points": self.points}

    # ------------------------------------------------------------------ points
    @property
    def keys(self) -> list[str]:
        """The swept dotted keys, in column order (points' keys, grid keys, then the seed with replicas)."""
        keys = dict.fromkeys(k for point in self.points for k in point)
        keys.update(dict.fromkeys(self.grid))
        if self.replicas > 1:
            keys["system.seed"] = None
        return list(keys)

    def expand(self) -> list[RawPoint]:
        """Every point of the sweep, not validated (``points x grid x replicas``, the last varying fastest)."""
        count = max(len(self.points), 1) * math.prod(len(v) for v in self.grid.values()) * self.replicas
        if count > MAX_POINTS:
            raise SweepError(f"the sweep has {count} points (points x grid x replicas), more than {MAX_POINTS}: split it into several sweeps")
        out = []
        for point in self.points or [{}]:
            for combo in itertools.product(*self.grid.values()):
                overrides = {**point, **dict(zip(self.grid, combo))}
                config = _apply(self.base, overrides)
                if self.replicas == 1:
                    out.append(RawPoint(len(out), overrides, 0, config))
                    continue
                for k in range(self.replicas):
                    seeded = {**overrides, "system.seed": replica_seed(_seed_of(config), k)}
                    out.append(RawPoint(len(out), seeded, k, _apply(config, {"system.seed": seeded["system.seed"]})))
        return out

    def resolve(self) -> list[Point]:
        """Every point, validated against the configuration schema, with its resolved config and id.

        Raises :class:`SweepError` for unknown keys (with a suggestion), invalid points (named
        with their overrides and the problem) and points that resolve to the same configuration.
        """
        for i, point in enumerate(self.points):
            for key in point:
                check_key(key, f"points[{i}]")
        for key in self.grid:
            check_key(key, "grid")
        errors, seen, out = [], {}, []
        for raw in self.expand():
            try:
                cfg = parse_config(raw.config)
            except ConfigError as exc:
                detail = str(exc).removeprefix("invalid configuration:\n  ").replace("\n  ", "; ")
                errors.append(f"point {raw.index} ({_describe(raw.overrides)}): {detail}")
                continue
            text = dump_config(cfg)
            pid = config_id(text)
            if pid in seen:
                errors.append(f"points {seen[pid]} and {raw.index} ({_describe(raw.overrides)}) resolve to the same configuration")
                continue
            seen[pid] = raw.index
            out.append(Point(raw.index, self._params(cfg, raw.replica), cfg, text, pid))
        if errors:
            more = f"\n  ... and {len(errors) - 10} more" if len(errors) > 10 else ""
            raise SweepError("invalid sweep:\n  " + "\n  ".join(errors[:10]) + more)
        return out

    def _params(self, cfg: Config, replica: int) -> dict[str, Any]:
        params = {key: config_value(cfg, key) for key in self.keys}
        if self.replicas > 1:
            params["replica"] = replica
        return params


def config_value(cfg: Config, key: str) -> Any:
    """The value of dotted ``key`` in a resolved configuration (tables as dicts, ``None`` entries left out).

    Example:
        >>> config_value(Config(), "system.packing_fraction")
        0.3
    """
    section, field = key.split(".", 1)
    value = getattr(getattr(cfg, section), field)
    if hasattr(value, "model_dump"):
        return {k: v for k, v in value.model_dump().items() if v is not None}
    return value


# ---------------------------------------------------------------------- helpers
def _read_toml(path: Path, what: str) -> dict:
    try:
        text = path.read_text()
    except OSError as exc:
        raise SweepError(f"cannot read {what} {path}: {exc.strerror}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{path} is not valid TOML: {exc}") from None


def _read_base(base: Any, root: Path) -> dict:
    if isinstance(base, str):
        return _read_toml(root / base, "base configuration")
    if not isinstance(base, dict):
        raise SweepError(f"base must be a table (a run configuration) or a file name, got {base!r}")
    for name, section in base.items():
        misplaced = [k for k in section if k in TOP_LEVEL] if isinstance(section, dict) else []
        if misplaced:
            raise SweepError(_misplaced(f"base.{name}.{misplaced[0]}", misplaced[0]))
    return base


def _misplaced(where: str, key: str) -> str:
    return f"{where}: '{key}' is a top-level key: put it before the first [table] of the sweep file"


def _flatten(table: Any, where: str) -> dict[str, Any]:
    """Dotted keys ``section.field`` -> values, from quoted (``"system.n"``) or nested (``system.n``) TOML keys."""
    if not isinstance(table, dict):
        raise SweepError(f"{where} must be a table of dotted keys, got {table!r}")
    flat: dict[str, Any] = {}

    def visit(parts: tuple[str, ...], value: Any):
        if len(parts) >= 2:
            key = ".".join(parts)
            if key in flat:
                raise SweepError(f"{where}: duplicate key '{key}'")
            flat[key] = value
        elif isinstance(value, dict):
            for k, v in value.items():
                visit(parts + tuple(k.split(".")), v)
        elif parts[0] in TOP_LEVEL:
            raise SweepError(_misplaced(where, parts[0]))
        else:
            raise SweepError(f"{where}: '{'.'.join(parts)}' is not a dotted key 'section.field' such as 'system.n'")

    visit((), table)
    return flat


def _read_grid(grid: Any) -> dict[str, list]:
    flat = _flatten(grid, "grid")
    if not flat:
        raise SweepError("[grid] is empty: give each swept key a list of values, e.g. \"collision.e_n\" = [0.8, 0.9]")
    for key, values in flat.items():
        if not isinstance(values, list):
            raise SweepError(f"grid.{key}: expected a list of values, got {values!r} (write [{values!r}] for one value)")
        if not values:
            raise SweepError(f"grid.{key}: empty list (a grid key needs at least one value)")
        for i, v in enumerate(values):
            if v in values[:i]:
                raise SweepError(f"grid.{key}: duplicate value {v!r}")
    return flat


def _read_points(points: Any) -> list[dict[str, Any]]:
    if not isinstance(points, list) or not all(isinstance(p, dict) for p in points):
        raise SweepError("points must be a list of tables ([[points]] in TOML)")
    if not points:
        raise SweepError("points is empty: give at least one [[points]] table")
    return [_flatten(p, f"points[{i}]") for i, p in enumerate(points)]


def _read_replicas(replicas: Any) -> int:
    if not isinstance(replicas, int) or isinstance(replicas, bool) or replicas < 1:
        raise SweepError(f"replicas must be a positive integer, got {replicas!r}")
    return replicas


def _apply(base: dict, overrides: dict[str, Any]) -> dict:
    config = copy.deepcopy(base)
    for key, value in overrides.items():
        section, field = key.split(".", 1)
        table = config.setdefault(section, {})
        if not isinstance(table, dict):
            raise SweepError(f"base: '{section}' must be a table, got {table!r}")
        table[field] = copy.deepcopy(value)
    return config


def _seed_of(config: dict) -> Any:
    default = SystemConfig.model_fields["seed"].default
    system = config.get("system", {})
    return system.get("seed", default) if isinstance(system, dict) else default


def _describe(overrides: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in overrides.items()) or "the base"
