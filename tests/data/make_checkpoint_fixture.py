"""Write the checkpoint fixtures of ``tests/test_checkpoint_migration.py`` (each run once, from the code
whose checkpoint layout it freezes; the files are committed, this script documents how).

    python tests/data/make_checkpoint_fixture.py NAME

``v1`` (checkpoint format 1): a rough, TC, walled granular gas under gravity (every rule parameter,
wall law and accumulator in use). ``viscoelastic`` (before the one Hertz material replaced the
``NORMAL_VISCO`` law): viscoelastic spheres and walls under gravity. Each is checkpointed at t = 1
and its state at t = 2 is saved: loading the checkpoint with any later edmd and running to t = 2
must reach that state.
"""

import sys
from pathlib import Path

import edmd
from edmd import collide
from edmd.files.checkpoint import Checkpoint
from edmd.files.trajectory import write_state

HERE = Path(__file__).parent


def fixture_simulation() -> edmd.Simulation:
    state = edmd.random_packing(200, 0.2, dim=3, periodic=[True, True, False], seed=11)
    state = edmd.maxwell_boltzmann(state, 1.0, seed=12, spin=True)
    rule = collide.TC(collide.Rough(0.85, beta=0.2, mu=0.4), 1e-4)
    return edmd.Simulation(state, collision=rule, walls=collide.Wall(e_n=0.9, beta=-0.5), gravity=[0.0, 0.0, -0.5])


def viscoelastic_simulation() -> edmd.Simulation:
    state = edmd.random_packing(100, 0.15, dim=3, periodic=[True, True, False], seed=21)
    state = edmd.maxwell_boltzmann(state, 1.0, seed=22)
    material = collide.Viscoelastic(young=1e4, poisson=0.3, A=1e-3)
    return edmd.Simulation(state, collision=material, walls=collide.Wall(e_n=material), gravity=[0.0, 0.0, -0.2])


FIXTURES = {"v1": ("checkpoint_v1", fixture_simulation), "viscoelastic": ("checkpoint_viscoelastic", viscoelastic_simulation)}


def main(name: str):
    stem, make = FIXTURES[name]
    sim = make()
    sim.add(Checkpoint(HERE / f"{stem}.gsd", interval=1.0))
    sim.run(until_time=1.0)
    frozen = (HERE / f"{stem}.gsd").read_bytes()  # the point at t = 1 (the run goes on writing)
    sim.run(until_time=2.0)
    (HERE / f"{stem}.gsd").write_bytes(frozen)
    write_state(HERE / f"{stem}_continued.gsd", sim.state, sim.totals())


if __name__ == "__main__":
    main(sys.argv[1])
