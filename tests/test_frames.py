"""Frames written chunk by chunk (``files/frames.py``): a chunk is left out of a later frame
exactly when it equals frame 0's, bit for bit."""

import gsd.fl
import numpy as np

from edmd.files.frames import SAMPLES, FrameReader, FrameWriter
from edmd.state import filled


def _written(path, name):
    with gsd.fl.open(str(path), "r") as f:
        return [f.chunk_exists(k, name) for k in range(f.nframes)]


def test_a_chunk_is_written_again_exactly_when_it_differs_from_frame_0(tmp_path):
    n = 40 * SAMPLES
    base = np.linspace(0.0, 1.0, n)
    hidden = base.copy()
    hidden[1] += 1e-16  # (between the sampled elements: only the digest sees it)
    frames = [
        {"a": base, "u": np.zeros(n), "z": np.zeros(n), "c": np.full(n, -np.inf), "s": np.ones(n)},
        {"a": base.copy(), "u": filled(0.0, (n,)), "z": np.full(n, -0.0), "c": filled(-np.inf, (n,)), "s": np.ones(n, np.float32)},
        {"a": hidden, "u": np.zeros(n + 1), "z": np.zeros(n), "c": np.full(n, np.inf), "s": np.ones((n, 1))},
    ]
    path = tmp_path / "f.gsd"
    with FrameWriter(path) as w:
        for chunks in frames:
            w.append({"particles/N": np.array([n], np.uint32), **{f"log/{k}": v for k, v in chunks.items()}})
    assert _written(path, "log/a") == [True, False, True]  # equal bytes; then one element differs
    assert _written(path, "log/u") == [True, False, True]  # a broadcast constant of frame 0's value; another shape
    assert _written(path, "log/z") == [True, True, False]  # -0.0 is not 0.0 bit for bit
    assert _written(path, "log/c") == [True, False, True]
    assert _written(path, "log/s") == [True, True, True]  # the same values in another dtype, another shape
    with FrameReader(path) as r:
        for k, chunks in enumerate(frames):
            for name, value in chunks.items():
                got = r.chunk(k, f"log/{name}")
                assert got.tobytes() == np.ascontiguousarray(value).tobytes(), (k, name)
