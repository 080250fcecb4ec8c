"""Clustering of a freely cooling granular gas in 2D: the showcase frame ``docs/figures/showcase-clustering.png``.

N = 10 000 smooth inelastic disks (e_n = 0.8, the TC model against inelastic collapse) at
packing fraction 0.35 start homogeneous with Maxwellian velocities. The homogeneous cooling
state of a large enough system is unstable (the clustering instability of Goldhirsch & Zanetti,
PRL 70, 1619 (1993)): after some tens of collisions per particle dense clusters and dilute
voids form and grow. The last frame is drawn coloured by the local packing fraction
(:func:`edmd.app.movie.plot_frame`). About 5 s of simulation (~150 collisions per particle)::

    python examples/clustering_2d.py [RUN_DIR]      # trajectory.gsd, thermo.csv in RUN_DIR (default clustering-run)
    edmd movie clustering-run --color density       # the whole run as clustering-run/movie.gif
"""

import sys
import time
from pathlib import Path

import edmd
from edmd import collide
from edmd.app.movie import plot_frame
from edmd.app.plots import save

HERE = Path(__file__).parent
FIGURE = HERE.parent / "docs" / "figures" / "showcase-clustering.png"
N, ETA, E_N, TC = 10_000, 0.35, 0.8, 1e-4
UNTIL, INTERVAL = 1000.0, 50.0  # T falls by ~3 decades; a frame every 50 time units


def simulate(run_dir: Path) -> Path:
    """Run the cooling gas, writing ``trajectory.gsd`` and ``thermo.csv`` into ``run_dir``; returns the trajectory."""
    run_dir.mkdir(parents=True, exist_ok=True)
    state = edmd.maxwell_boltzmann(edmd.random_packing(N, ETA, dim=2, seed=1), kT=1.0, seed=1)
    sim = edmd.Simulation(state, collision=collide.TC(collide.Inelastic(E_N), duration=TC))
    thermo = sim.add(edmd.Thermo(INTERVAL, path=run_dir / "thermo.csv"))
    sim.add(edmd.Trajectory(run_dir / "trajectory.gsd", INTERVAL))
    started = time.perf_counter()
    sim.run(until_time=UNTIL)
    sim.close()
    table = thermo.table()
    print(f"{time.perf_counter() - started:.1f} s: {2 * table['collisions'][-1] / N:.0f} collisions per particle, "
          f"T = {table['temperature'][-1]:.3g} (T0 = 1)")  # fmt: skip
    return run_dir / "trajectory.gsd"


def main(argv=()):
    run_dir = Path(argv[0]) if argv else Path("clustering-run")
    last = edmd.read_state(simulate(run_dir), frame=-1, check_overlaps=False)
    ax = plot_frame(last, "density")
    ax.set_title(f"cooling granular gas, N = {N}, packing fraction {ETA}, e_n = {E_N}: t = {last.time:g}", fontsize="small")
    print(f"wrote {save(ax, FIGURE, dpi=150)}")


if __name__ == "__main__":
    main(sys.argv[1:])
