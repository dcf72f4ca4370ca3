#!/usr/bin/python3
"""Rotating drum at four sizes (He 2018 Fig. 16: 100, 200, 300, 400 mm diameter at constant fill fractions):
time per engine step split into SPH, coupling and host DEM, with the particle counts.

Each size runs examples/drum/in.drum through a launcher with the drum diameter D (= length), the grain
count scaled with D^3 (the same fill fraction of grains; water fills the lower half at every size), a
settling stage without fluid (--tsettle, 0.2 s: the grains fall from their lattice into a bed with
contacts; not timed) and a few hundred steps of rotation, which are timed. Sources of the split, all for the rotation run only:
  - LAMMPS/LIGGGHTS' own breakdown: Pair (+ Neigh) = the host DEM contacts and their neighbour lists;
  - `Fix sph/fluid timing` (printed at the end of each run): sort, walls, rates, integrate, transfer,
    reduce = SPH; coupling = porosity, grain forces, reaction (inside the fluid's rate evaluation);
  - the rest of the loop (fix move of the wall particles, nve/sphere, output, ...) = other host work.

Usage: /usr/bin/python3 bench/drum_bench.py [--exe build/src_fix/lmp_sphdem] [--sizes 0.1 0.2 0.3 0.4]
           [--steps 200] [--coarse | --full] [--tsettle 0.2] [--dmax V] [--var NAME VALUE ...]
           [--out bench/results_drum]
On a GPU: --var lmppair gran/hertz/history/gpu (LAMMPS) or --var ligpair gran/gpu (LIGGGHTS).
--coarse (default): grains 5.4 mm, fluid dx 6 mm, DEM dt 1e-5 s, fluid every 2 steps (the README's coarse
variant, 969 grains at D = 0.1 m); --full: the paper's 2.7 mm grains, dx 3 mm, dt 2.5e-6 s (7755 grains at
D = 0.1 m). Writes drum_bench.csv and drum_bench.md (table) in --out, and prints the table.
"""
import argparse
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def run_size(exe, D, steps, full, workdir, threads, tsettle, dmax, extra=()):
    n0, dg, dx, dt, every = (7755, 0.0027, 0.003, 2.5e-6, 2) if full else (969, 0.0054, 0.006, 1e-5, 2)
    ngrain = int(round(n0 * (D / 0.1) ** 3))
    trot = steps * dt
    os.makedirs(workdir, exist_ok=True)
    cmd = [exe, "-in", os.path.join(ROOT, "examples", "drum", "in.drum"), "-log", "log.bench", "-screen", "none",
           "-var", "D", str(D), "-var", "ngrain", str(ngrain), "-var", "dg", str(dg), "-var", "dx", str(dx),
           "-var", "dt", str(dt), "-var", "every", str(every), "-var", "tsettle", str(tsettle), "-var", "dmax", str(dmax),
           "-var", "trot", "%.10g" % trot, "-var", "tavg", "%.10g" % trot, "-var", "nsamp", "1",
           "-var", "nfluid", "1"]
    for name, value in extra:
        cmd += ["-var", name, value]
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    t0 = time.time()
    p = subprocess.run(cmd, cwd=workdir, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.time() - t0
    log = open(os.path.join(workdir, "log.bench")).read()
    if p.returncode != 0 or "ERROR" in log:
        err = [l for l in log.splitlines() if "ERROR" in l]
        raise RuntimeError("D = %g: run failed: %s" % (D, err[-1] if err else p.stdout[-500:]))
    # the last run of the input is the rotation: its loop time, breakdown and the fix's timing line
    loops = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms", log)
    loop_s, nsteps, natoms = float(loops[-1][0]), int(loops[-1][1]), int(loops[-1][2])
    tail = log[log.rfind("Loop time of"):]

    def section(name):
        m = re.search(r"^%s\s*\|\s*([0-9.eE+-]+)" % name, tail, re.M)
        if m:
            return float(m.group(1))
        m = re.search(r"^%s\s+time \(%%\) = ([0-9.eE+-]+)" % name, tail, re.M)  # LIGGGHTS' format
        return float(m.group(1)) if m else 0.0

    pair, neigh = section("Pair"), section("Neigh")
    fl = re.findall(r"Fix sph/fluid timing \(s, this run\): sort ([0-9.eE+-]+), walls ([0-9.eE+-]+), rates "
                    r"([0-9.eE+-]+), coupling ([0-9.eE+-]+), integrate ([0-9.eE+-]+), transfer ([0-9.eE+-]+), "
                    r"reduce ([0-9.eE+-]+); total ([0-9.eE+-]+) over (\d+) fluid steps", log)
    f = [float(x) for x in fl[-1][:8]]
    nfs = int(fl[-1][8])
    sph = f[0] + f[1] + f[2] + f[4] + f[5] + f[6]
    coup = f[3]
    m = re.search(r"Fix sph/fluid: \w+ backend.*?; (\d+) fluid \+ (\d+) wall particles", log)
    nfluid, nwall = int(m.group(1)), int(m.group(2))
    return dict(D=D, ngrain=ngrain, nfluid=nfluid, nwall=nwall, natoms=natoms, steps=nsteps, fluid_steps=nfs,
                loop_s=loop_s, dem_s=pair + neigh, sph_s=sph, couple_s=coup, other_s=loop_s - pair - neigh - sph - coup,
                wall_s=wall)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--exe", default=os.path.join(ROOT, "build", "src_fix", "lmp_sphdem"))
    ap.add_argument("--sizes", type=float, nargs="+", default=[0.1, 0.2, 0.3, 0.4])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--tsettle", type=float, default=0.2, help="settling time without fluid before the timed "
                    "rotation (s): the grains fall from their lattice into a bed with contacts")
    ap.add_argument("--dmax", type=float, default=0.0, help="dmax of fix sph/couple (grain search cell size)")
    ap.add_argument("--var", nargs=2, action="append", default=[], metavar=("NAME", "VALUE"),
                    help="more -var settings of in.drum, e.g. --var lmppair gran/hertz/history/gpu (GPU DEM)")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--coarse", action="store_true", default=True)
    g.add_argument("--full", action="store_true")
    ap.add_argument("--out", default=os.path.join(HERE, "results_drum"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    exe = os.path.abspath(a.exe)
    rows = []
    for D in a.sizes:
        r = run_size(exe, D, a.steps, a.full, os.path.join(a.out, "run_D%g" % D), a.threads, a.tsettle, a.dmax,
                     a.var)
        rows.append(r)
        print("D = %.2f m: %d grains, %d fluid, %d wall; %.1f ms/step (DEM %.1f, SPH %.1f, coupling %.1f, other %.1f)"
              % (D, r["ngrain"], r["nfluid"], r["nwall"], 1e3 * r["loop_s"] / r["steps"], 1e3 * r["dem_s"] / r["steps"],
                 1e3 * r["sph_s"] / r["steps"], 1e3 * r["couple_s"] / r["steps"], 1e3 * r["other_s"] / r["steps"]),
              flush=True)
    keys = ["D", "ngrain", "nfluid", "nwall", "steps", "fluid_steps", "loop_s", "dem_s", "sph_s", "couple_s", "other_s"]
    with open(os.path.join(a.out, "drum_bench.csv"), "w") as fcsv:
        fcsv.write(",".join(keys) + "\n")
        for r in rows:
            fcsv.write(",".join(str(r[k]) for k in keys) + "\n")
    lines = ["| D (mm) | grains | fluid | wall | ms / engine step | host DEM | SPH | coupling | other host |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        n = r["steps"]
        pct = lambda x: "%.1f (%.0f %%)" % (1e3 * x / n, 100 * x / r["loop_s"])
        lines.append("| %.0f | %d | %d | %d | %.1f | %s | %s | %s | %s |" % (
            1e3 * r["D"], r["ngrain"], r["nfluid"], r["nwall"], 1e3 * r["loop_s"] / n, pct(r["dem_s"]), pct(r["sph_s"]),
            pct(r["couple_s"]), pct(r["other_s"])))
    txt = "\n".join(lines) + "\n"
    open(os.path.join(a.out, "drum_bench.md"), "w").write(txt)
    print(txt)
    plot(rows, os.path.join(a.out, "drum_bench.png"))
    return 0


def plot(rows, path):
    """Stacked bars: ms per engine step by part, one bar per drum size."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: no PNG")
        return
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    labels = ["%.0f mm\n%d grains\n%d fluid" % (1e3 * r["D"], r["ngrain"], r["nfluid"]) for r in rows]
    bottom = [0.0] * len(rows)
    for key, name in (("dem_s", "host DEM"), ("sph_s", "SPH"), ("couple_s", "coupling"), ("other_s", "other host")):
        vals = [100.0 * r[key] / r["loop_s"] for r in rows]
        ax.bar(labels, vals, bottom=bottom, label=name)
        bottom = [b + v for b, v in zip(bottom, vals)]
    for i, r in enumerate(rows):
        ax.text(i, 101, "%.1f ms/step" % (1e3 * r["loop_s"] / r["steps"]), ha="center", va="bottom", fontsize=8)
    ax.set_ylim(0, 112)
    ax.set_ylabel("share of the engine step (%)")
    ax.set_title("rotating drum, CPU backend, 1 core: time per engine step", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print("wrote", path)


if __name__ == "__main__":
    sys.exit(main())
