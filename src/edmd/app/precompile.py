"""Compile the event loop ahead of time (``edmd compile``): one cached variant per feature set.

A run compiles only the loop variant of its physics (:func:`edmd._core.loop.loop_variant`): walls,
eMD*, a tangential law and the normal law, and its neighbour structure (cells or lists). The first
run of each feature set pays that compile (about 15-45 CPU-seconds); later runs load it from
Numba's on-disk cache. A cluster image, a sweep's workers or CI can warm the cache for the feature
sets they will use, with both neighbour structures (``neighbours = "auto"`` picks either by density)
or the one their runs use.

Features are written as ``+``-joined names: ``plain``, ``walls``, ``rough``, ``soft`` (the central
restitution of a contact law used instantaneously: viscoelastic spheres, ``viscoelastic`` is
another name for it), ``emdstar`` (``emdstar+rough``: frictional eMD*),
``bath`` (the Andersen heat bath, :class:`edmd.Andersen`), ``noise`` (white-noise kicks,
:class:`edmd.WhiteNoise`), ``vibration`` (a vibrating wall, :class:`edmd.VibratingWall`: the
walls variant compiled for its geometry), ``well`` (square wells, :class:`edmd.SquareWell`), ``grow``
(growing particles, :func:`edmd.compress`), ``shear`` (Lees-Edwards shear, :class:`edmd.Shear`: a
variant compiled for its geometry), e.g. ``walls+rough+soft``. Square wells and growth run with
lists only. Debug mode (``[engine] debug``) is a run-time switch of every variant and needs no
compile of its own.
"""

from __future__ import annotations

import time
import warnings

from .._core import layout as L
from .._core.jit import in_disk_cache
from .._core.loop import GEO_ARG, loop_variant

FEATURES = ("walls", "rough", "soft", "emdstar", "bath", "noise", "vibration", "well", "grow", "shear")
#: the neighbour structures a feature set can run with (``Simulation``'s ``neighbours`` option)
NEIGHBOURS = ("cells", "list")
#: features whose pair events are predicted over neighbour lists only
LISTS_ONLY = frozenset({"well", "grow"})
#: other names of features
SYNONYMS = {"viscoelastic": "soft"}


class FeatureError(ValueError):
    """A feature set that is misspelt or cannot occur in one run."""


def parse_features(spec: str) -> frozenset[str]:
    """The features of ``spec`` (``"plain"`` or names joined by ``+``), checked for consistency.

    Example:
        >>> sorted(parse_features("walls+rough"))
        ['rough', 'walls']
        >>> parse_features("emdstar+soft")
        Traceback (most recent call last):
        ...
        edmd.app.precompile.FeatureError: emdstar runs use their soft contact law: it cannot be combined with soft (emdstar+rough is frictional eMD*)
        >>> sorted(parse_features("walls+viscoelastic"))
        ['soft', 'walls']
    """
    names = [SYNONYMS.get(n.strip(), n.strip()) for n in spec.split("+") if n.strip()]
    if names == ["plain"]:
        return frozenset()
    if "debug" in names:
        raise FeatureError("debug is no feature set: debug mode is a run-time switch of every loop variant")
    unknown = [n for n in names if n not in FEATURES]
    if unknown or not names:
        raise FeatureError(f"unknown feature {unknown[0] if unknown else spec!r}; the features are plain or {', '.join(FEATURES)} joined by '+'")
    found = frozenset(names)
    if {"emdstar", "soft"} <= found:
        raise FeatureError("emdstar runs use their soft contact law: it cannot be combined with soft (emdstar+rough is frictional eMD*)")
    if {"emdstar", "noise"} <= found:
        raise FeatureError("white-noise kicks and eMD* cannot be combined")
    if {"emdstar", "well"} <= found:
        raise FeatureError("square wells and eMD* cannot be combined")
    if "grow" in found and found - {"grow", "walls"}:
        raise FeatureError("growing particles (compression) are smooth elastic hard spheres in a periodic box or between walls: grow takes only walls")
    if "vibration" in found and "walls" not in found:
        raise FeatureError("a vibrating wall is one of the walls: vibration needs walls")
    if "shear" in found and found & {"emdstar", "bath", "noise", "vibration", "well", "grow"}:
        raise FeatureError("shear takes walls (along z), rough and soft only")
    return found


def all_feature_sets() -> list[frozenset[str]]:
    """The feature sets ``edmd compile --all`` builds: every normal and tangential law with and without
    walls and eMD*, each with the drivers, a vibrating wall and square wells (with and without the
    drivers), shear, and growth.

    Example:
        >>> sets = all_feature_sets()
        >>> frozenset({"well", "bath", "noise"}) in sets, all(parse_features("+".join(sorted(s)) or "plain") == s for s in sets)
        (True, True)
    """
    sets = []
    for walls in ((), ("walls",)):
        for normal in ((), ("soft",)):
            for rough in ((), ("rough",)):
                sets.append(frozenset(walls + normal + rough))
        sets.append(frozenset(walls + ("emdstar",)))
        sets.append(frozenset(walls + ("emdstar", "rough")))
    driven = [s | extra for s in sets for extra in ({"bath"}, {"noise"}, {"bath", "noise"}) if not ("emdstar" in s and "noise" in extra)]
    vibrated = [s | {"vibration"} for s in sets if "walls" in s]
    wells = [s | {"well"} for s in sets + driven if "emdstar" not in s]
    sheared = [s | {"shear"} for s in sets if "emdstar" not in s]
    return sets + driven + vibrated + wells + sheared + [frozenset({"grow"}), frozenset({"grow", "walls"})]


def neighbour_structures(features: frozenset[str], neighbours: str = "both") -> list[str]:
    """The neighbour structures to compile ``features`` for: ``neighbours`` (``"cells"``,
    ``"list"`` or ``"both"``) as far as the features run with them.

    Example:
        >>> neighbour_structures(parse_features("walls")), neighbour_structures(parse_features("well"))
        (['cells', 'list'], ['list'])
        >>> neighbour_structures(parse_features("grow"), "cells")
        []
    """
    if neighbours not in NEIGHBOURS + ("both",):
        raise FeatureError(f"neighbours must be cells, list or both, got {neighbours!r}")
    wanted = NEIGHBOURS if neighbours == "both" else (neighbours,)
    return [mode for mode in wanted if mode == "list" or not features & LISTS_ONLY]


def _variant(features: frozenset[str], neighbours: str):
    normal = L.NORMAL_SOFT if features & {"soft", "emdstar"} else L.NORMAL_CONST
    flags = [name in features for name in ("bath", "noise", "well", "grow")]
    return loop_variant(*(name in features for name in ("walls", "emdstar", "rough")), normal, *flags, neighbours == "list")


def _example(features: frozenset[str], neighbours: str):
    """A small simulation with exactly these features and neighbour structure (its first events compile the variant)."""
    import edmd
    from ..physics.collide import Rough
    from ..physics.contact import Hertz
    from ..physics.emdstar import EMDStar
    from ..physics.thermostats import Andersen, WhiteNoise
    from ..physics.vibration import VibratingWall
    from ..physics.growth import Growth
    from ..physics.wells import SquareWell
    from ..physics.shear import Shear

    hertz = Hertz(young=1e5, poisson=0.3, A=1e-3)
    normal = hertz if "soft" in features else 0.9
    rule = Rough(e_n=normal, beta=0.5) if "rough" in features else Rough(e_n=normal)
    if "emdstar" in features:
        rule = EMDStar(hertz, friction=edmd.Friction(mu=0.5, law="mindlin") if "rough" in features else None)
    periodic = [True, True, "walls" not in features]
    state = edmd.maxwell_boltzmann(edmd.lattice(32, 0.1, periodic=periodic), 1.0, seed=1, spin="rough" in features)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. the viscoelastic validity warning of this toy system
        bath = Andersen(kT=1.0, rate=0.1) if "bath" in features else None
        kicks = WhiteNoise(xi0=1.0, interval=0.1) if "noise" in features else None
        shaker = VibratingWall(amplitude=0.1, omega=1.0, phase=-1.5707963267948966) if "vibration" in features else None
        well = SquareWell(width=1.5, depth=0.5) if "well" in features else None
        growth = Growth(rate=0.01) if "grow" in features else None
        shear = Shear(rate=0.1) if "shear" in features else None
        return edmd.Simulation(
            state, collision=None if growth else rule, thermostat=bath, forcing=kicks, vibration=shaker, well=well, growth=growth, shear=shear,
            engine={"neighbours": neighbours},
        )  # fmt: skip


def compile_features(features: frozenset[str], neighbours: str = "cells") -> tuple[str, float, bool]:
    """Compile (or load) the loop variant of ``features`` with ``neighbours`` (``"cells"`` or
    ``"list"``), and what the outputs compile for its geometry (the snapshot's streams, a thermo
    row's sums).

    Returns its name, the seconds it took and whether it was already in the on-disk cache.

    Example:
        >>> name, seconds, cached = compile_features(parse_features("plain"))
        >>> name
        'plain (cells)'
    """
    loop = _variant(features, neighbours)
    geo = (0.0,) * (L.G_WALL_STICK + 1 if "vibration" in features else L.N_GEO_SHEAR if "shear" in features else L.G_ON + 1)  # (longer geometries)
    cached = in_disk_cache(loop.run_events, (GEO_ARG, geo))
    start = time.perf_counter()
    sim = _example(features, neighbours)
    if sim.engine.loop is not loop:  # the toy system must have exactly the features asked for
        raise RuntimeError(f"internal error: {sim.engine.loop.name} ({sim.engine.loop.neighbours}) built for {loop.name} ({loop.neighbours})")
    sim.run(max_events=200)
    view = sim.state_view()  # what the outputs compile at their first row or frame, for this geometry
    view.temperature()
    view.copy()
    geometry = "+vibration" if "vibration" in features else "+shear" if "shear" in features else ""
    return f"{loop.name}{geometry} ({loop.neighbours})", time.perf_counter() - start, cached
