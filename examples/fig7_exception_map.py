"""Fig. 7 of Müller & Pöschel (2013): how often eMD* meets its exceptions a) and b).

An elastic gas of 1000 viscoelastic spheres (Hertz contact, A = 0, R = 1 mm, glass density,
sqrt(<v^2>) = 1 m/s) in a periodic box, for Young's moduli from rubber (1e7 Pa) to glass
(6.3e10 Pa) and packing fractions 0.005 ... 0.3 (physics.md §4.9). Per collision (A event),
the frequency of

* exception a) ("rotation step impossible": the relocated partners would overlap a third
  particle), f_a = N_a / N_A, and
* exception b) ("three-particle contact" while a contact is pending), f_b = N_b / N_A,

counted over collisions 10 ... 110 per particle (the first 10 are discarded). N_A counts the
contacts relocated by an A event; a contact that meets exception a) is resolved by the
instantaneous rule instead (a fallback) and is not in N_A, so the frequency per contact attempt
is N_a / (N_A + N_a) = n_a / (collisions_per_particle_counted * N / 2). Both grow with the
packing fraction and with the softness (longer contacts, larger rotation of the normal); the
dashed marks are the rough order-of-magnitude estimates of physics.md §4.9.

Run the sweep first (35 points, resumable), then this script on its directory::

    edmd sweep examples/emd_exception_map.toml --out emd-map --workers 1
    python examples/fig7_exception_map.py emd-map

It writes ``examples/data/fig7_exception_map.csv`` and ``examples/fig7_exception_map.png``.
"""

import csv
import json
import sys
import tomllib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from edmd.files.thermo import read_thermo  # noqa: E402

HERE = Path(__file__).parent
DISCARD = 10.0
"""Collisions per particle discarded before counting."""
COLUMNS = ["young", "packing_fraction", "collisions_per_particle_counted", "n_A", "n_a", "n_b", "f_a", "f_b"]
ESTIMATES = {  # physics.md §4.9: young -> {packing fraction: (f_a, f_b)}, order of magnitude only
    1e7: {0.01: (0.006, 0.016), 0.1: (0.08, 0.19), 0.3: (0.46, 0.69)},
    1e9: {0.01: (0.001, 0.003), 0.1: (0.013, 0.03), 0.3: (0.07, 0.17)},
    6.3e10: {0.01: (0.0002, 0.0005), 0.1: (0.0025, 0.006), 0.3: (0.014, 0.035)},
}


def ratio(count: float, total: float) -> float:
    """``count / total`` to 6 significant digits (NaN when ``total`` is 0)."""
    return float(f"{count / total:.6g}") if total else float("nan")


def point_frequencies(directory: Path) -> dict:
    """The exception counts and frequencies of one finished sweep point.

    Args:
        directory: a point directory (``<sweep>/points/<id>``) with ``config.toml`` and ``thermo.csv``.

    Returns:
        A row with the keys of :data:`COLUMNS`: the counter differences between the first thermo row
        with at least :data:`DISCARD` collisions per particle and the last row.
    """
    config = tomllib.loads((directory / "config.toml").read_text())
    n = config["system"]["n"]
    thermo = read_thermo(directory / "thermo.csv")
    per_particle = 2.0 * thermo["collisions"] / n
    start = int((per_particle >= DISCARD).argmax())
    delta = {k: float(thermo[k][-1] - thermo[k][start]) for k in ("emd_contacts", "emd_exceptions_a", "emd_exceptions_b")}
    n_A = delta["emd_contacts"]
    return {
        "young": config["collision"]["young"],
        "packing_fraction": config["system"]["packing_fraction"],
        "collisions_per_particle_counted": round(float(per_particle[-1] - per_particle[start]), 3),
        "n_A": int(n_A),
        "n_a": int(delta["emd_exceptions_a"]),
        "n_b": int(delta["emd_exceptions_b"]),
        "f_a": ratio(delta["emd_exceptions_a"], n_A),
        "f_b": ratio(delta["emd_exceptions_b"], n_A),
    }


def sweep_table(out: Path) -> list[dict]:
    """One row per finished point of sweep directory ``out``, sorted by Young's modulus and packing fraction."""
    dirs = sorted((out / "points").iterdir()) if (out / "points").is_dir() else []
    points = [d for d in dirs if (d / "status.json").exists() and json.loads((d / "status.json").read_text())["status"] == "done"]
    return sorted((point_frequencies(d) for d in points), key=lambda r: (r["young"], r["packing_fraction"]))


def write_csv(rows: list[dict], path: Path):
    """Write the table ``rows`` (columns :data:`COLUMNS`) to ``path``."""
    path.parent.mkdir(exist_ok=True)
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)


def pascal(value: float) -> str:
    r"""A modulus in Pa as mathtext, e.g. ``6.3e10`` -> ``$6.3\times10^{10}$ Pa``."""
    mantissa, exponent = f"{value:.1e}".split("e")
    prefix = "" if mantissa == "1.0" else f"{mantissa.rstrip('0').rstrip('.')}\\times"
    return f"${prefix}10^{{{int(exponent)}}}$ Pa"


def plot(rows: list[dict], path: Path):
    """Two log-log panels, f_a and f_b vs packing fraction, one line per Young's modulus, estimates dashed."""
    youngs = sorted({r["young"] for r in rows})
    colours = dict(zip(youngs, plt.cm.viridis([0.85 * i / max(len(youngs) - 1, 1) for i in range(len(youngs))])))
    fig, axes = plt.subplots(1, 2, figsize=(12.0, 4.3), sharey=True)
    for ax, key, label in zip(axes, ("f_a", "f_b"), ("a) rotation step impossible", "b) three-particle contact")):
        for young in youngs:
            line = [(r["packing_fraction"], r[key]) for r in rows if r["young"] == young and r[key] > 0]
            if line:
                ax.plot(*zip(*line), "o-", color=colours[young], label=f"Y = {pascal(young)}")
        for young, marks in ESTIMATES.items():
            eta = sorted(marks)
            ax.plot(eta, [marks[e][key == "f_b"] for e in eta], "x--", color=colours.get(young, "0.5"), lw=0.8, alpha=0.7)
        ax.set(xscale="log", yscale="log", xlabel="packing fraction", title=f"exception {label}")
        ax.set_ylabel(f"$f_{key[-1]} = N_{key[-1]} / N_A$")
        ax.grid(True, which="major", alpha=0.3)
    axes[1].plot([], [], "x--", color="0.5", lw=0.8, label="estimate (physics.md §4.9)")
    fig.legend(*axes[1].get_legend_handles_labels(), fontsize=8, loc="center right")
    fig.suptitle("eMD* exceptions per A event, elastic Hertz gas (N = 1000, counted over 100 collisions/particle)")
    fig.tight_layout(rect=(0.0, 0.0, 0.83, 1.0))
    fig.savefig(path, dpi=130)


def main(out: str = "emd-map"):
    rows = sweep_table(Path(out))
    if not rows:
        sys.exit(f"no finished points in {out}: run `edmd sweep examples/emd_exception_map.toml --out {out}` first")
    write_csv(rows, HERE / "data" / "fig7_exception_map.csv")
    plot(rows, HERE / "fig7_exception_map.png")
    print(f"{'young':>9} {'eta':>6} {'coll/p':>7} {'N_A':>7} {'N_a':>6} {'N_b':>6} {'f_a':>9} {'f_b':>9}")
    for r in rows:
        print(
            f"{r['young']:9.2g} {r['packing_fraction']:6.3f} {r['collisions_per_particle_counted']:7.1f} "
            f"{r['n_A']:7d} {r['n_a']:6d} {r['n_b']:6d} {r['f_a']:9.2e} {r['f_b']:9.2e}"
        )


if __name__ == "__main__":
    main(*sys.argv[1:2])
