"""Generate ``src/edmd/data/viscoelastic_eps.npz``: eps(delta) of viscoelastic spheres (physics.md §2.2.2).

Integrates the scaled central collision X'' = -X^{3/2} - delta X^{1/2} X', X(0) = 0, X'(0) = 1,
until the force vanishes (X + delta X' = 0), with scipy DOP853 at rtol 1e-13, on a uniform grid
in s = sqrt(delta) in [0, 10], and stores the cubic-spline coefficients in s. Run once:

    python tools/make_viscoelastic_table.py
"""

from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

S_MAX, POINTS = 10.0, 2001


def eps_and_tau(delta):
    def rhs(t, y):
        x, v = y
        xp = max(x, 0.0)
        return [v, -(xp**1.5) - delta * np.sqrt(xp) * v]

    def force_zero(t, y):
        return y[0] + delta * y[1]

    force_zero.terminal = True
    force_zero.direction = -1
    sol = solve_ivp(rhs, (0.0, 50.0), [0.0, 1.0], method="DOP853", rtol=1e-13, atol=1e-15, events=force_zero, first_step=1e-8)
    # X + delta X' = delta > 0 at t = 0, so the first downward crossing is the end of the contact
    te = sol.t_events[0]
    ye = sol.y_events[0]
    return -ye[-1][1], te[-1]


def main():
    s = np.linspace(0.0, S_MAX, POINTS)
    eps = np.array([1.0 if x == 0 else eps_and_tau(x * x)[0] for x in s])
    spline = CubicSpline(s, eps, bc_type=((1, 0.0), "not-a-knot"))
    out = Path(__file__).resolve().parents[1] / "src" / "edmd" / "data" / "viscoelastic_eps.npz"
    np.savez_compressed(out, s_max=S_MAX, coefficients=spline.c.T.copy(), grid=s, eps=eps)
    print(f"wrote {out}: eps(0.1) = {spline(np.sqrt(0.1)):.8f}, eps(1) = {spline(1.0):.8f}")


if __name__ == "__main__":
    main()
