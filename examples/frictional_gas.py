r"""A cooling gas of frictional soft spheres: eMD*, force-based MD and the constant-beta rough model.

Frictional eMD* (docs/physics.md §4.8, §4.11) against the frictional DEM from one state: a dilute
(packing fraction 0.05) gas of viscoelastic Hertz spheres with Hertz-Mindlin friction
(:math:`\mu = 0.3`, :math:`e_n \approx 0.9` at the thermal speed, contact duration ~1e-2),
translational and rotational temperature equal at the start, cools freely. Four runs:

* **MD** (:class:`edmd.DEMSimulation` with :class:`edmd.Friction`, 200 steps per contact);
* **eMD*** (:class:`~edmd.physics.emdstar.EMDStar` with the same ``friction``), every contact
  solved, and with the hard-limit table (``friction_table=True``, docs/physics.md §4.12: first
  order in the softness, here Lambda ~ 3e-3 at the thermal speed);
* **rough EDMD**, the usual hard-sphere model of frictional grains: instantaneous collisions with
  the same viscoelastic :math:`e_n(v_n)` and one constant tangential restitution
  :math:`\beta`, fitted to the same mean restitution: :math:`\beta = -\langle\mathbf v_c'\cdot\mathbf v_c\rangle/\langle|\mathbf v_c|^2\rangle`
  (:math:`\mathbf v_c` the contact-point velocity) over 4000 collisions of the initial state's
  distribution, each solved exactly (:func:`edmd.physics.twobody.collide_frictional`).

Run ``python examples/frictional_gas.py`` (about two minutes): writes ``examples/frictional_gas.png``
(:math:`T_{tr}(t)`, :math:`T_{rot}(t)` and their ratio, as Fig. 6 of Müller & Pöschel sets MD,
classic EDMD and eMD* side by side) and ``examples/data/frictional_gas.csv``, and prints the
largest relative departures from MD.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import edmd  # noqa: E402
from edmd.physics.emdstar import EMDStar  # noqa: E402
from edmd.physics.twobody import collide_frictional  # noqa: E402

HERE = Path(__file__).parent
CONTACT = edmd.Hertz(young=2.5e6, poisson=0.3, A=2e-4)  # t_c ~ 0.01, e_n ~ 0.9 at the thermal speed
FRICTION = edmd.Friction(mu=0.3, law="mindlin")
N, ETA, T_END, ROWS = 8000, 0.05, 15.0, 31  # about 10 collisions per particle


def initial_state() -> edmd.State:
    return edmd.maxwell_boltzmann(edmd.random_packing(N, ETA, dim=3, seed=11), 1.0, seed=12, spin=True)


def fitted_beta(state: edmd.State, samples: int = 4000, seed: int = 3) -> float:
    r"""The mean tangential restitution :math:`-\langle\mathbf v_c'\cdot\mathbf v_c\rangle/\langle|\mathbf v_c|^2\rangle` of collisions
    drawn from the state's distribution (pairs at random, impacts weighted by the normal speed)."""
    rng = np.random.default_rng(seed)
    R, m = float(state.radius[0]), float(state.mass[0])
    num = den = 0.0
    drawn = 0
    while drawn < samples:
        i, j = rng.choice(state.n, 2, replace=False)
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        g = state.velocity[i] - state.velocity[j]
        if g @ n >= 0.0 or rng.uniform() * 8.0 > -(g @ n):  # approaching, accepted in proportion to the normal speed
            continue
        wi, wj = state.angular_velocity[i], state.angular_velocity[j]
        end = collide_frictional(CONTACT, FRICTION, n * 2 * R, np.zeros(3), state.velocity[i], state.velocity[j], wi, wj, m, m, R, R)
        before = g - np.cross(R * (wi + wj), n)
        after = end.v1 - end.v2 - np.cross(R * (end.omega1 + end.omega2), n)
        before -= (before @ n) * n
        after -= (after @ n) * n
        num += after @ before
        den += before @ before
        drawn += 1
    return -num / den


def temperatures(sim, times) -> np.ndarray:
    rows = []
    for t in times:
        sim.run(until_time=float(t))
        rows.append((sim.state.temperature(), sim.state.rotational_temperature()))
    return np.array(rows)


def main():
    state = initial_state()
    beta = fitted_beta(state)
    times = np.linspace(0.0, T_END, ROWS)
    runs = {
        "MD (DEM, 200 steps/contact)": edmd.DEMSimulation(state, CONTACT, steps_per_contact=200, friction=FRICTION),
        "eMD*": edmd.Simulation(state, collision=EMDStar(CONTACT, friction=FRICTION)),
        "eMD*, hard-limit table": edmd.Simulation(state, collision=EMDStar(CONTACT, friction=FRICTION, friction_table=True)),
        f"rough EDMD, beta = {beta:.3f}": edmd.Simulation(state, collision=edmd.physics.collide.Rough(e_n=CONTACT, beta=beta)),
    }
    data = {name: temperatures(sim, times) for name, sim in runs.items()}
    md = data[next(iter(runs))]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for (name, rows), style in zip(data.items(), ("k-", "C1--", "C2-.", "C0:")):
        axes[0].plot(times, rows[:, 0], style, label=name)
        axes[1].plot(times, rows[:, 1], style, label=name)
        axes[2].plot(times, rows[:, 1] / rows[:, 0], style, label=name)
        dev = np.abs(rows / md - 1.0).max(axis=0)
        print(f"{name:32s} largest departure from MD: T_tr {dev[0]:.2%}, T_rot {dev[1]:.2%}")
    for ax, label in zip(axes, ("translational temperature $T_{tr}$", "rotational temperature $T_{rot}$", "$T_{rot}/T_{tr}$")):
        ax.set_xlabel("time")
        ax.set_ylabel(label)
    axes[0].set_yscale("log")
    axes[1].set_yscale("log")
    axes[2].legend(fontsize=8)
    fig.suptitle(f"Cooling of frictional Hertz-Mindlin spheres (N = {N}, packing fraction {ETA}, mu = {FRICTION.mu})")
    fig.tight_layout()
    fig.savefig(HERE / "frictional_gas.png", dpi=120)
    table = np.column_stack([times] + [rows for rows in data.values()])
    header = "time," + ",".join(f"{name} T_tr,{name} T_rot" for name in data)
    (HERE / "data").mkdir(exist_ok=True)
    np.savetxt(HERE / "data" / "frictional_gas.csv", table, delimiter=",", header=header, comments="")
    print("wrote", HERE / "frictional_gas.png")
    return data


if __name__ == "__main__":
    main()
