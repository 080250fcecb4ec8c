"""Force-based MD against the event-driven engine and the two-body solver, long runs (``pytest -m slow``).

1. Cooling of a dilute dashpot gas (constant e_n = 0.9): DEM vs EDMD over 6 independent initial
   states per dimension. Each state gives the relative difference of the Haff slope of 1/sqrt(T)
   (DEM vs EDMD from the same state) and of a decorrelated EDMD control run; the mean DEM
   difference must vanish within 3 standard errors of the control differences plus 0.5 %
   (the O(Lambda) softness effects: Lambda_v ~ 4e-3 here, and the restitution of oblique soft
   contacts exceeds e_n by O(Lambda tan^2 alpha), amplified ~8x in 1 - e^2).
2. Convergence order of a viscoelastic two-body collision down to 1280 steps per contact.
"""

import numpy as np
import pytest
from test_dem import cooling_slopes, dem_two_body_error

from edmd.physics.contact import Hertz

pytestmark = pytest.mark.slow


def test_cooling_many_states(dim):
    rows = [cooling_slopes(dim, seed) for seed in range(100, 106)]
    dem = np.array([r[0] for r in rows])
    control = np.array([r[1] for r in rows])
    se = control.std(ddof=1) / np.sqrt(len(rows))
    print(f"{dim}D: DEM/EDMD slope - 1 = {dem.mean():.4f} +- {dem.std(ddof=1) / np.sqrt(len(rows)):.4f}; control {control.mean():.4f} +- {se:.4f}")
    assert abs(dem.mean()) < 3 * se + 0.005
    assert dem.std(ddof=1) < 2 * control.std(ddof=1) + 0.005


def test_viscoelastic_collision_order():
    contact = Hertz(young=1e6, poisson=0.3, A=1e-3)
    steps = [80, 160, 320, 640, 1280, 2560]
    # errors depend strongly on the onset phase within a step: 31 phases
    gaps = np.linspace(0.3, 0.5, 31)
    rms = np.array([np.sqrt(np.mean([dem_two_body_error(contact, 3, n, g)[1] ** 2 for g in gaps])) for n in steps])
    orders = np.log2(rms[:-1] / rms[1:])
    print("viscoelastic velocity errors", rms, "local orders", orders)
    # ~2 while steps are coarse, ~1.5 asymptotically: the damping force grows as sqrt(s) after onset
    assert -np.polyfit(np.log(steps), np.log(rms), 1)[0] >= 1.4
    assert -np.polyfit(np.log(steps[-3:]), np.log(rms[-3:]), 1)[0] >= 1.1
