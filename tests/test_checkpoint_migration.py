"""Checkpoints written by earlier versions keep loading and continue bit for bit.

``tests/data/checkpoint_v1.gsd`` was written by the code of checkpoint format 1 (see
``tests/data/make_checkpoint_fixture.py``); ``checkpoint_v1_continued.gsd`` is where that code took
the run. A change of the core's data layout must migrate such files, not reject them.
"""

from pathlib import Path

import gsd.hoomd
import numpy as np

from edmd.checkpoint import Checkpoint, load_checkpoint, read_checkpoint
from edmd.trajectory import read_state

DATA = Path(__file__).parent / "data"


def test_a_format_1_checkpoint_continues_bit_for_bit(tmp_path):
    assert read_checkpoint(DATA / "checkpoint_v1.gsd").time == 1.0
    sim = load_checkpoint(DATA / "checkpoint_v1.gsd", [Checkpoint(tmp_path / "ck.gsd", interval=1.0)])
    sim.run(until_time=2.0)
    then, now = read_state(DATA / "checkpoint_v1_continued.gsd"), sim.state
    for field in ("position", "velocity", "angular_velocity", "image", "last_collision"):
        assert np.array_equal(getattr(now, field), getattr(then, field)), field
    with gsd.hoomd.open(DATA / "checkpoint_v1_continued.gsd") as f:
        log = f[0].log
    assert sim.collisions == int(log["collisions"][0]) > 100 and sim.events == int(log["events"][0])
