import os
import sys

import numpy as np
import pytest

from edmd.cores import usable_cores

sys.path.insert(0, os.path.dirname(__file__))


@pytest.fixture(params=[2, 3], ids=["2d", "3d"])
def dim(request):
    return request.param


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def pytest_xdist_auto_num_workers(config):
    """Workers of ``-n auto`` (pyproject's addopts): the cores this process may use, at most 4.

    xdist's own count (psutil's physical cores) ignores CPU affinity and a container's CPU quota
    (:func:`edmd.cores.usable_cores` does not), and a worker per core of a large host would each
    compile the loop variants it meets.
    """
    return min(usable_cores(), 4)
