"""Write the checkpoint fixture of ``tests/test_checkpoint_migration.py`` (run once, from the code whose
checkpoint layout the fixture freezes; the files are committed, this script documents how).

    python tests/data/make_checkpoint_fixture.py

A rough, TC, walled granular gas under gravity (every rule parameter, wall law and accumulator in
use) is checkpointed at t = 1 and its state at t = 2 is saved: loading the checkpoint with any later
edmd and running to t = 2 must give that state bit for bit.
"""

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


def main():
    sim = fixture_simulation()
    sim.add(Checkpoint(HERE / "checkpoint_v1.gsd", interval=1.0))
    sim.run(until_time=1.0)
    frozen = (HERE / "checkpoint_v1.gsd").read_bytes()  # the point at t = 1 (the run goes on writing)
    sim.run(until_time=2.0)
    (HERE / "checkpoint_v1.gsd").write_bytes(frozen)
    write_state(HERE / "checkpoint_v1_continued.gsd", sim.state, sim.totals())


if __name__ == "__main__":
    main()
