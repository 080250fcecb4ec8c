"""Uniform shear flow (``edmd.Shear``, Lees-Edwards): the peculiar accumulators and the energy
balance under every kind of collision, files, restarts and clear refusals."""

import tomllib

import numpy as np
import pytest

import edmd
from edmd import collide
from edmd._core import layout as L
from edmd.state import StateError


def _gas(dim, n=300, eta=0.15, seed=4, periodic=None, spin=False):
    s = edmd.random_packing(n, eta, dim=dim, seed=seed, radius={"kind": "uniform", "min": 0.4, "max": 0.6}, periodic=periodic)
    return edmd.maxwell_boltzmann(s, 1.0, seed=seed + 1, spin=spin)


RULES = {
    "elastic": dict(e_n=1.0),
    "inelastic": dict(e_n=0.8),
    "rough": dict(collision=collide.Rough(e_n=0.9, beta=0.2)),
    "coulomb": dict(collision=collide.Rough(e_n=0.85, beta=0.4, mu=0.1)),
    "tc": dict(collision=collide.TC(collide.Inelastic(0.6), 0.02)),
    "viscoelastic": dict(collision=collide.Viscoelastic(young=1e4, poisson=0.3, A=1e-3)),
}
#: each neighbour structure under three of the rules
MODES = {"elastic": "cells", "inelastic": "list", "rough": "list", "coulomb": "cells", "tc": "list", "viscoelastic": "cells"}


@pytest.mark.parametrize("rule", list(RULES))
def test_peculiar_sums_follow_the_state_and_the_energy_balance_closes(dim, rule):
    # walls close z (3D, rough pair rules): rough walls in a sheared box book their work on the
    # peculiar motion too (the other rules in 3D go without, so as not to compile two more loop variants)
    rough = rule in ("rough", "coulomb")
    walled = dim == 3 and rough
    periodic = [True, True, False] if walled else None
    shear = edmd.Shear(1.5)
    s = shear.with_profile(_gas(dim, periodic=periodic, spin=rough))
    walls = collide.Wall(e_n=0.9, beta=0.3, mu=0.2) if walled else None
    sim = edmd.Simulation(s, shear=shear, walls=walls, engine={"debug": True, "neighbours": MODES[rule]}, **RULES[rule])
    assert sim.engine.mode == MODES[rule]
    start = sim.peculiar_state(sim.state)
    e0 = start.kinetic_energy() + start.rotational_energy()
    sim.run(until_time=3.0)
    state = sim.peculiar_state(sim.state)
    acc = sim.engine.accumulators_at(sim.time)
    c, m = state.velocity, state.mass
    c3 = np.zeros((state.n, 3))
    c3[:, :dim] = c
    tensor = np.einsum("i,ij,ik->jk", m, c3, c3)
    assert acc[L.A_KE] == pytest.approx(state.kinetic_energy(), rel=1e-10)
    assert np.allclose(acc[L.A_KT : L.A_KT + 6], [tensor[a, b] for a, b in L.TENSOR_AXES], rtol=1e-10, atol=1e-9 * state.kinetic_energy())
    if dim == 2:
        assert np.allclose(acc[L.A_PX : L.A_PX + 2], m @ c, atol=1e-9 * state.n)
    totals = sim.totals()
    e1 = state.kinetic_energy() + state.rotational_energy()
    assert totals.shear_work > 0.05 * e0  # the flow heats the gas
    assert e1 - e0 == pytest.approx(totals.shear_work - totals.dissipated, abs=1e-9 * e0)
    if rule == "elastic":
        assert totals.dissipated == 0.0


def test_shear_work_is_the_viscous_heating():
    # -gamma_dot V int P_xy dt: the kinetic part and every collision's -gamma_dot y_ij J_x
    shear = edmd.Shear(1.0)
    s = shear.with_profile(_gas(3, n=400, eta=0.2))
    sim = edmd.Simulation(s, shear=shear, e_n=0.9)
    th = sim.add(edmd.Thermo(0.5))
    sim.run(until_time=4.0)
    pxy = np.array([r["pressure_xy"] for r in th.rows[1:]])
    heat = -shear.rate * s.volume * 0.5 * pxy.sum()
    assert sim.totals().shear_work == pytest.approx(heat, rel=1e-9)
    assert np.allclose([r["energy_balance"] for r in th.rows], th.rows[0]["energy_balance"], atol=1e-9 * th.rows[0]["kinetic_energy"])
    assert all(r["temperature"] > 0.9 for r in th.rows)  # peculiar: the flow's own kinetic energy left out


def test_offset_travels_through_files(tmp_path, dim):
    shear = edmd.Shear(0.7)
    sim = edmd.Simulation(shear.with_profile(_gas(dim)), shear=shear)
    sim.run(until_time=3.3)
    state = sim.state
    assert state.shear_offset != 0.0
    edmd.write_state(tmp_path / "s.gsd", state)
    back = edmd.read_state(tmp_path / "s.gsd")
    assert back.shear_offset == state.shear_offset
    assert np.array_equal(back.position, state.position)
    with pytest.raises(StateError, match="sliding"):
        edmd.replicate(state, [2] + [1] * (dim - 1))


@pytest.mark.parametrize("mode", ["cells", "list"])
def test_checkpoint_restart_under_shear_is_bit_for_bit(tmp_path, dim, mode):
    from edmd.files.checkpoint import load_checkpoint

    shear = edmd.Shear(0.9)
    s = shear.with_profile(_gas(dim, spin=True))
    physics = dict(shear=shear, collision=collide.Rough(e_n=0.9, beta=0.1), engine={"resync_every": 0.5, "neighbours": mode})

    def run(d, until):
        d.mkdir()
        sim = edmd.Simulation(s, **physics)
        th = sim.add(edmd.Thermo(0.25, path=d / "thermo.csv"))
        sim.add(edmd.Checkpoint(d / "ck.gsd", 0.5))
        sim.run(until_time=until)
        sim.close()
        return sim, th

    whole, _ = run(tmp_path / "whole", 3.0)
    run(tmp_path / "part", 1.3)
    part = tmp_path / "part"
    sim = load_checkpoint(part / "ck.gsd", [edmd.Thermo(0.25, path=part / "thermo.csv"), edmd.Checkpoint(part / "ck.gsd", 0.5)])
    assert sim.time == 1.0
    sim.run(until_time=3.0)
    sim.close()
    assert (tmp_path / "whole" / "thermo.csv").read_bytes() == (tmp_path / "part" / "thermo.csv").read_bytes()
    assert sim.totals() == whole.totals()
    a, b = sim.state, whole.state
    assert np.array_equal(a.position, b.position) and np.array_equal(a.velocity, b.velocity) and a.shear_offset == b.shear_offset


def test_clear_refusals(dim):
    s = _gas(dim)
    shear = edmd.Shear(0.5)
    with pytest.raises(StateError, match="gravity"):
        edmd.Simulation(s, shear=shear, gravity=[0.0] * (dim - 1) + [-1.0])
    with pytest.raises(StateError, match="a thermostat"):
        edmd.Simulation(s, shear=shear, thermostat=edmd.Andersen(kT=1.0, rate=1.0))
    with pytest.raises(StateError, match="periodic x"):
        edmd.Simulation(_gas(dim, periodic=[True, False] + [True] * (dim - 2)), shear=shear)
    sim = edmd.Simulation(shear.with_profile(s), shear=shear)
    sim.run(until_time=1.0)
    with pytest.raises(StateError, match="Lees-Edwards images"):
        edmd.Simulation(sim.state)  # sliding images without the shear that made them
    edmd.Simulation(sim.state, shear=edmd.Shear(0.0))  # (kept where they are)
    with pytest.raises(ValueError, match="finite number"):
        edmd.Shear(float("nan"))


def test_config_section_and_refusals():
    cfg = edmd.parse_config(tomllib.loads("[system]\nn = 100\npacking_fraction = 0.1\n[shear]\nrate = 0.3\n"))
    assert cfg.shear.build() == edmd.Shear(0.3) and cfg.shear.profile
    with pytest.raises(edmd.ConfigError, match="walls.axes may hold 'z' only"):
        edmd.parse_config(tomllib.loads('[system]\nn = 100\npacking_fraction = 0.1\n[walls]\naxes = ["y"]\n[shear]\nrate = 0.3\n'))
    with pytest.raises(edmd.ConfigError, match="cannot be combined with \\[thermostat\\]"):
        edmd.parse_config(tomllib.loads('[system]\nn = 100\npacking_fraction = 0.1\n[thermostat]\nkind = "andersen"\nkT = 1.0\nrate = 1.0\n[shear]\nrate = 0.3\n'))


def test_grad_theory_limits_and_balance(dim):
    # the steady energy balance -2/d a* P*_xy = zeta*, and the elastic limit: no normal-stress
    # differences, a* -> 0, eta* -> 1 (the first-Sonine viscosity)
    from edmd.analysis import dilute_viscosity, usf_collision_frequency, usf_grad

    for alpha in (0.3, 0.7, 0.9, 0.99):
        g = usf_grad(alpha, dim)
        assert -2.0 / dim * g["a"] * g["xy"] == pytest.approx(g["zeta"], rel=1e-12)
        assert g["xx"] + (dim - 1) * g["yy"] == pytest.approx(dim, rel=1e-12)  # the trace is d p
    near = usf_grad(1.0 - 1e-9, dim)
    assert near["a"] < 1e-4 and near["viscosity"] == pytest.approx(1.0, rel=1e-6) and near["yy"] == pytest.approx(1.0, abs=1e-8)
    assert usf_collision_frequency(0.3, dim, 1.0, 1.0, 2.0) == pytest.approx(0.3 * 2.0 / dilute_viscosity(dim, 1.0, 1.0, 2.0))


def test_cli_shear_reports_the_steady_flow(tmp_path):
    from typer.testing import CliRunner

    from edmd.app.cli import app

    config = tmp_path / "c.toml"
    config.write_text('[system]\ndim = 2\nn = 400\npacking_fraction = 0.02\n[collision]\nrule = "inelastic"\ne_n = 0.8\n'
                      "[shear]\nrate = 0.05\n[run]\nuntil_time = 300.0\noutput_interval = 2.0\n")  # fmt: skip
    runner = CliRunner()
    r = runner.invoke(app, ["run", str(config), "--out", str(tmp_path / "run"), "--no-progress"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["shear", str(tmp_path / "run"), "--settle", "100"])
    assert r.exit_code == 0, r.output
    assert "Grad theory a*" in r.output and "velocity profile" in r.output
    assert (tmp_path / "run" / "shear_stress.png").exists() and (tmp_path / "run" / "shear_profile.png").exists()
    (tmp_path / "plain").mkdir()
    (tmp_path / "plain" / "config.toml").write_text("[system]\nn = 10\npacking_fraction = 0.01\n")
    r = runner.invoke(app, ["shear", str(tmp_path / "plain")])
    assert r.exit_code != 0 and "not a sheared run" in r.output and "Traceback" not in r.output
