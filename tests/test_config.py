"""Configuration files: the documented examples work, mistakes are named."""

import numpy as np
import pytest

import edmd
from edmd.app.config import EXAMPLE, Config, ConfigError, default_job, dump_config, ignored_keys, load_config, parse_config
from edmd.app.runner import build_state

ISSUE_EXAMPLE = """
[system]
dim = {dim}
n = 4000
packing_fraction = 0.3
kT = 1.0
seed = 1
[run]
until_time = 50.0
output_interval = 1.0
"""


def test_issue_example_config(tmp_path, dim):
    p = tmp_path / "c.toml"
    p.write_text(ISSUE_EXAMPLE.format(dim=dim))
    cfg = load_config(p)
    s = build_state(cfg)
    assert (s.n, s.dim) == (4000, dim)
    assert s.packing_fraction == pytest.approx(0.3)
    assert s.temperature() == pytest.approx(1.0)


def test_example_file_parses_and_round_trips(tmp_path):
    p = tmp_path / "e.toml"
    p.write_text(EXAMPLE)
    cfg = load_config(p)
    assert cfg == Config()
    p.write_text(dump_config(cfg))
    assert load_config(p) == cfg


def test_typo_is_named_with_a_suggestion():
    with pytest.raises(ConfigError, match=r"system.pakcing_fraction: unknown key \(did you mean 'packing_fraction'\?\)"):
        parse_config({"system": {"pakcing_fraction": 0.3}})
    with pytest.raises(ConfigError, match=r"systme: unknown key \(did you mean 'system'\?\)"):
        parse_config({"systme": {}})


@pytest.mark.parametrize(
    "data, match",
    [
        ({"system": {"packing_fraction": 1.2}}, "system.packing_fraction: Input should be less than 1"),
        ({"system": {"n": -5}}, "system.n"),
        ({"system": {"dim": 4}}, "system.dim"),
        ({"system": {"radius": -0.5}}, "system.radius"),
        ({"system": {"radius": {"kind": "uniform", "min": 0.4}}}, "needs max"),
        ({"system": {"dim": 2, "lattice": "fcc"}}, "does not exist in 2D"),
        ({"collision": {"e_n": 0.9}}, "rule 'elastic' takes no parameters"),
        ({"collision": {"rule": "inelastic"}}, "rule 'inelastic' needs e_n"),
        ({"collision": {"rule": "rough", "e_n": 0.9}}, "needs beta"),
        ({"collision": {"rule": "rough", "beta": 0.0}}, "needs either e_n or the viscoelastic material"),
        ({"collision": {"rule": "viscoelastic", "young": 1e9}}, "needs young, poisson and A"),
        ({"collision": {"rule": "inelastic", "e_n": 0.9, "tc": -1.0}}, "collision.tc"),
        ({"walls": {"axes": ["w"]}}, "walls.axes"),
        ({"system": {"dim": 2}, "walls": {"axes": ["z"]}}, "a 2D system has no z axis"),
        ({"system": {"gravity": [0.0, -1.0]}}, "gravity needs 3 components"),
        ({"walls": {"viscoelastic": True}}, "walls.viscoelastic needs"),
        ({"walls": {"axes": ["z"], "e_n": 0.5, "viscoelastic": True}}, "give either e_n or viscoelastic = true"),  # (e_n was dropped)
        ({"run": {"until_time": "soon"}}, "run.until_time"),
        ({"engine": {"neighbours": "octree"}}, "engine.neighbours"),
        ({"system": {"n": 100, "replicate": [2, 2, 2]}}, "n = 100 is not a multiple of the 8 copies"),
        ({"system": {"replicate": [2, 2]}}, "replicate needs 3 numbers"),
        ({"system": {"replicate": [2, 0, 1]}}, "system.replicate"),
        ({"system": {"replicate": [1, 1, 2]}, "walls": {"axes": ["z"]}}, "replicate tiles the periodic axes only; walls close 'z'"),
    ],
)
def test_invalid_values_are_named(data, match):
    with pytest.raises(ConfigError, match=match):
        parse_config(data)


def test_unreadable_files(tmp_path):
    with pytest.raises(ConfigError, match="cannot read config file"):
        load_config(tmp_path / "nope.toml")
    p = tmp_path / "broken.toml"
    p.write_text("[system\nn = 3")
    with pytest.raises(ConfigError, match="is not valid TOML"):
        load_config(p)
    p.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")  # (the message named no file)
    with pytest.raises(ConfigError, match="broken.toml is not a text file"):
        load_config(p)


def test_polydisperse_config(dim):
    cfg = parse_config(
        {"system": {"dim": dim, "n": 200, "packing_fraction": 0.1, "init": "random", "radius": {"kind": "uniform", "min": 0.4, "max": 0.6}, "density": 1.0}}
    )
    s = build_state(cfg)
    assert s.radius.min() >= 0.4 and s.radius.max() <= 0.6
    assert isinstance(s, edmd.State)


def test_mass_and_density_together_are_refused_for_a_new_state():
    # (parsed, since the configs that older runs stored hold both and must still restart)
    cfg = parse_config({"system": {"n": 32, "mass": 2.0, "density": 3.0}})
    with pytest.raises(ConfigError, match=r"mass = 2.0 and density = 3.0 both set the mass: give one"):
        build_state(cfg)


def test_emdstar_rule_from_config(tmp_path):
    from edmd.physics.emdstar import EMDStar
    from edmd.app.runner import build_simulation

    cfg = parse_config(
        {
            "system": {"n": 64, "packing_fraction": 0.05, "radius": 0.001, "density": 2500.0, "kT": 3.5e-6},
            "collision": {"rule": "emdstar", "contact": "hertz", "young": 1e8, "poisson": 0.3, "A": 1e-6, "tables": "exact", "communication": False},
        }
    )
    sim = build_simulation(cfg)
    rule = sim.engine.rule
    assert isinstance(rule, EMDStar) and rule.tables == "exact" and rule.communication is False
    assert rule.contact == edmd.Hertz(1e8, 0.3, 1e-6)
    assert sim.engine.wall.e_n == rule.contact  # walls default to the contact law
    dashpot = parse_config({"collision": {"rule": "emdstar", "contact": "dashpot", "k": 1e4, "e_n": 0.8}}).collision.build(2.0)
    assert dashpot.contact.central(2.0, 2.0, 0.5, 0.5, v_n=1.0).e_n == pytest.approx(0.8, rel=1e-12)


@pytest.mark.parametrize(
    "collision, message",
    [
        ({"rule": "emdstar", "young": 1e7, "poisson": 0.3}, "needs contact"),
        ({"rule": "emdstar", "contact": "hertz", "young": 1e7, "poisson": 0.3, "k": 3.0}, "k not used by the 'hertz' contact law"),
        ({"rule": "emdstar", "contact": "hertz", "young": 1e7, "poisson": 0.3, "tc": 1e-4}, "tc not used"),
        ({"rule": "emdstar", "contact": "dashpot"}, "needs the spring constant k"),
        ({"rule": "inelastic", "e_n": 0.9, "tables": "exact"}, "only used by rule = 'emdstar'"),
        ({"rule": "emdstar", "contact": "hertz", "young": 1e7, "poisson": 0.3, "tables": "/no/such/table.npz"}, "no table file"),
    ],
)
def test_emdstar_config_errors_name_the_problem(collision, message):
    with pytest.raises((ConfigError, ValueError), match=message):
        parse_config({"collision": collision}).collision.build()


@pytest.mark.parametrize(
    "data, key",
    [
        ({"system": {"n": "100"}}, "system.n"),
        ({"system": {"packing_fraction": "0.3"}}, "system.packing_fraction"),
        ({"run": {"progress": "yes"}}, "run.progress"),
        ({"system": {"n": 10.0}}, "system.n"),
        ({"system": {"dim": 2.0}}, "system.dim"),
    ],
)
def test_strings_and_floats_are_not_converted_silently(data, key):
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        parse_config(data)


@pytest.mark.parametrize(
    "data, message",
    [
        ({"system": {"radius": float("inf")}}, r"system\.radius: Input should be a finite number"),
        ({"collision": {"rule": "inelastic", "e_n": 0.9, "tc": float("inf")}}, r"collision\.tc: Input should be a finite number"),
        ({"system": {"seed": -1}}, r"system\.seed: .*greater than or equal to 0"),
        ({"system": {"aspect": [1.0, 1.0, 2.0]}}, r"system: 'aspect' shapes the box of init = 'random' or 'compress' only"),
        ({"system": {"n": 1}}, r"kT: a single particle .* set kT = 0"),
        ({"collision": {"rule": "emdstar", "contact": "dashpot", "k": 1e4, "e_n": 0.0}}, r"e_n = 0 has no dashpot"),
        ({"run": {"until_time": float("inf")}}, r"until_time = inf needs max_events or wall_time"),
    ],
)
def test_every_bad_value_names_its_key(data, message):
    with pytest.raises(ConfigError, match=message) as err:
        parse_config(data)
    assert "constrained" not in str(err.value) and "pydantic" not in str(err.value)


def test_union_errors_name_the_key_once():
    with pytest.raises(ConfigError) as err:
        parse_config({"system": {"radius": "0.5"}})
    lines = str(err.value).splitlines()[1:]
    assert lines == ["  system.radius: Input should be a valid number (got '0.5')"]
    with pytest.raises(ConfigError, match=r"system\.radius: radius distribution 'uniform' needs max$"):
        parse_config({"system": {"radius": {"kind": "uniform", "min": 0.1}}})


def test_a_sweep_file_points_to_edmd_sweep():
    with pytest.raises(ConfigError, match="sweep file .*edmd sweep"):
        parse_config({"base": {"system": {"n": 10}}, "grid": {"system.n": [10, 20]}})


def test_until_time_inf_runs_a_number_of_events(tmp_path):
    from edmd.app.runner import run_directory

    cfg = parse_config({"system": {"dim": 2, "n": 64, "packing_fraction": 0.3}, "run": {"until_time": float("inf"), "max_events": 5000, "progress": False}, "output": {"plots": False}})
    summary = run_directory(cfg, tmp_path / "run")
    assert summary["events"] == 5000 and summary["time"] > 0
    assert load_config(tmp_path / "run" / "config.toml").run.until_time == float("inf")


def test_engine_debug_reaches_the_engine():
    from edmd.app.runner import build_simulation

    cfg = parse_config({"system": {"dim": 2, "n": 64, "packing_fraction": 0.3}, "engine": {"debug": True}})
    assert build_simulation(cfg).engine.options.debug is True


@pytest.mark.parametrize("dim", [2, 3])
def test_engine_auto_threshold_reaches_the_engine(dim):
    """[engine] auto_threshold moves where "auto" takes lists (default: the measured crossover,
    cells at packing fraction 0.3); out of (0, 1] it is refused, naming the key."""
    from edmd.app.runner import build_simulation

    system = {"dim": dim, "n": 200, "packing_fraction": 0.3}
    assert build_simulation(parse_config({"system": system})).engine.mode == "cells"
    assert build_simulation(parse_config({"system": system, "engine": {"auto_threshold": 0.25}})).engine.mode == "list"
    with pytest.raises(ConfigError, match="engine.auto_threshold"):
        parse_config({"engine": {"auto_threshold": 1.5}})


def test_a_float_for_a_whole_number_gets_a_hint():
    with pytest.raises(ConfigError, match=r"run\.max_events: .*write it without a decimal point or exponent \(1000000\)"):
        parse_config({"run": {"max_events": 1e6}})


def test_replicated_start_from_config(dim):
    """replicate = [2, 2(, 2)]: n / 2^d particles built and relaxed, tiled, velocities drawn anew."""
    reps = [2] * dim
    cfg = parse_config({"system": {"dim": dim, "n": 400 * 2**dim, "packing_fraction": 0.45, "init": "random", "kT": 2.0, "replicate": reps}})
    s = build_state(cfg)
    assert s.n == 400 * 2**dim and round(s.packing_fraction, 12) == 0.45 and round(s.temperature(), 12) == 2.0
    assert s.overlapping_pair() is None
    copies = s.position.reshape(2**dim, 400, dim)
    assert np.allclose(np.abs(copies[1] - copies[0])[:, 0], s.box[0] / 2)  # copy 1 is copy 0 one base box along x
    assert not np.allclose(s.velocity[:400], s.velocity[400:800])  # the velocities are not copies


@pytest.mark.parametrize(
    "data, notes",
    [
        ({"walls": {"e_n": 0.9, "mu": 0.1}}, ["walls.e_n: no walls", "walls.mu: no walls"]),
        ({"walls": {"axes": ["x"], "e_n": 0.9}}, []),
        ({"integrator": {"dt": 1e-3, "skin": 0.2}}, ["integrator.dt: used by integrator.kind = 'dem' only", "integrator.skin: used by"]),
        ({"integrator": {"kind": "dem", "dt": 1e-3}, "contact": {"model": "dashpot", "k": 1e4}}, []),
        ({"integrator": {"kind": "dem"}, "contact": {"model": "dashpot", "k": 1e4}, "engine": {"neighbours": "list"}}, ["engine.neighbours: the DEM has no event engine"]),
        ({"engine": {"neighbours": "list", "cell_size": 2.0}}, ["engine.cell_size: used by neighbours = 'cells' only"]),
        ({"engine": {"neighbours": "cells", "cell_size": 2.0}}, []),
        ({"engine": {"neighbours": "cells", "auto_threshold": 0.3}}, ["engine.auto_threshold: chooses between lists and cells"]),
        ({"engine": {"auto_threshold": 0.3}}, []),
        ({"system": {"from_frame": 2}}, ["system.from_frame: picks a frame of system.from_file"]),
        ({"system": {"init": "random", "compress_rate": 0.1}}, ["system.compress_rate: used by init = 'compress' only"]),
        ({"system": {"init": "compress", "compress_rate": 0.1}}, []),
        ({"system": {"from_file": "start.gsd", "n": 10}}, []),  # (the command announces that [system] is ignored)
    ],
)
def test_keys_without_effect_are_named(data, notes):
    found = ignored_keys(parse_config(data))
    assert len(found) == len(notes) and all(f.startswith(note) for f, note in zip(found, notes)), found


def test_the_shipped_configurations_set_no_key_without_effect():
    import tomllib

    assert ignored_keys(default_job()) == [] and ignored_keys(parse_config(tomllib.loads(EXAMPLE))) == []


def test_a_configuration_written_out_in_full_names_the_same_keys():
    """A sweep's points are written out with every key (dump_config): only the user's count."""
    import tomllib

    cfg = parse_config({"walls": {"e_n": 0.8}, "engine": {"neighbours": "list", "cell_size": 2.0}})
    assert len(ignored_keys(cfg)) == 2
    assert ignored_keys(parse_config(tomllib.loads(dump_config(cfg)))) == ignored_keys(cfg)
    assert ignored_keys(parse_config(tomllib.loads(dump_config(Config())))) == []
