"""Fig. 6 of Müller & Pöschel (2013): one oblique soft collision by force-based MD, classic EDMD and eMD*.

Two viscoelastic spheres (Hertz, very soft so that the contact is visible: contact duration
~0.2 of the time unit, rotation of the normal Phi ~ 0.4 rad) collide obliquely. Three runs from
the same state:

* **MD** (:class:`edmd.DEMSimulation`, 4000 steps per contact): the reference, Newton's equations;
* **classic EDMD** with the same force law's central :math:`e_n(v_n)`: an instantaneous
  collision at first contact, the outgoing directions are wrong for oblique impacts;
* **eMD*** (:class:`edmd.physics.emdstar.EMDStar`): event A relocates the pair and both move with the
  centre-of-mass velocity during the contact, event B gives the post-collisional velocities:
  after the contact the paths coincide with MD.

Run ``python examples/fig6_two_particle_trajectories.py``: writes
``examples/fig6_two_particle_trajectories.png`` and the sampled paths to
``examples/data/fig6_two_particle_trajectories.csv``, and prints the deviations from MD at the end.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import edmd  # noqa: E402
from edmd.physics.emdstar import EMDStar  # noqa: E402

HERE = Path(__file__).parent
CONTACT = edmd.Hertz(young=600.0, poisson=0.3, A=2e-2)
T_END, SAMPLES = 1.6, 801


def initial_state() -> edmd.State:
    """Disks of radius 0.5 and mass 1 meeting at t = 0.5 with impact speed 2 and eccentricity b = 0.7."""
    b = 0.7
    n = np.array([1.0, 0.0])
    t = np.array([0.0, 1.0])
    g = 2.0 * (-np.sqrt(1 - b * b) * n + b * t)  # velocity of 1 relative to 2
    pos = np.array([0.5 * n, -0.5 * n]) - 0.5 * np.array([0.5 * g, -0.5 * g])
    return edmd.State(position=pos, velocity=[0.5 * g, -0.5 * g], radius=0.5, mass=1.0, box=[20.0, 20.0])


def sample(sim) -> np.ndarray:
    """Unwrapped positions ``(SAMPLES, 2, 2)`` at equally spaced times up to ``T_END``."""
    out = []
    sim.add(edmd.Callback(lambda s, _tot: out.append(s.unwrapped_position.copy()), interval=T_END / (SAMPLES - 1)))
    sim.run(until_time=T_END)
    return np.array(out[:SAMPLES])


def main():
    state = initial_state()
    runs = {
        "MD": sample(edmd.DEMSimulation(state, CONTACT, steps_per_contact=4000)),
        "classic EDMD": sample(edmd.Simulation(state, collision=CONTACT)),
        "eMD*": sample(edmd.Simulation(state, collision=EMDStar(CONTACT, tables="exact"))),
    }
    times = np.linspace(0.0, T_END, SAMPLES)
    (HERE / "data").mkdir(exist_ok=True)
    columns = [f"{name}_{p}{ax}".replace(" ", "_").replace("*", "star") for name in runs for p in (1, 2) for ax in "xy"]
    table = np.column_stack([times] + [runs[name][:, p, ax] for name in runs for p in (0, 1) for ax in (0, 1)])
    np.savetxt(HERE / "data" / "fig6_two_particle_trajectories.csv", table, delimiter=",", header="t," + ",".join(columns), comments="")
    fig, ax = plt.subplots(figsize=(6.0, 5.0))
    styles = {"MD": ("k", "-", 3.0), "classic EDMD": ("tab:blue", "--", 1.5), "eMD*": ("tab:red", "-", 1.2)}
    for name, path in runs.items():
        colour, ls, lw = styles[name]
        for p in (0, 1):
            ax.plot(path[:, p, 0], path[:, p, 1], ls, color=colour, lw=lw, label=name if p == 0 else None)
    for p, c in zip((0, 1), ("0.6", "0.8")):
        ax.add_patch(plt.Circle(state.position[p] + 0.5 * state.velocity[p], 0.5, fill=False, color=c, lw=0.8))
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_title("oblique soft collision (Hertz, b = 0.7): paths of both particles")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(HERE / "fig6_two_particle_trajectories.png", dpi=130)
    for name in ("classic EDMD", "eMD*"):
        dev = np.abs(runs[name][-1] - runs["MD"][-1]).max()
        print(f"{name}: largest deviation from MD at t = {T_END}: {dev:.2e} (sigma = 1)")


if __name__ == "__main__":
    main()
