#!/usr/bin/python3
"""Accuracy against cost of the coupled and free-surface examples at three resolutions each: error (%)
against wall time per simulated second, one CPU thread, through a launcher (lmp_sphdem by default).

Cases (each runs the committed example input; only the resolution variable changes):
  settling     examples/settling/in.settling, dx = 3, 2, 1.5 mm (h = 1.3 dx; 1 mm glass sphere, Re 169),
               t = 0.25 s. Error: mean |v - v_ODE| / v_ODE over the acceleration (0.01-0.07 s) and over the
               terminal phase (0.125-0.25 s), v_ODE the Schiller-Naumann single-sphere ODE of
               data/reference/closed_forms.md (examples/settling/plot.py). The terminal phase carries the
               tank's spurious water motion (examples/settling/README.md).
  dambreak2d   examples/dambreak2d/in.dambreak2d, a/dx = 20, 40, 80 (water only, He 2018 2.1). Error: mean
               |Z - Z_exp| / Z_exp over the Martin & Moyce (1952) points with T <= 3 of both series
               (data/reference/martin_moyce_1952.dat).
  particles    examples/dambreak_particles/in.dambreak_particles (water + 200 g of beads, He 2018 3.2.1),
               dx = 6, 5, 3.75 mm (every = 32, 27, 20: the DEM step stays near 4.1e-6 s), t = 0.15 s (the
               water front reaches x = 160 mm of the 200 mm tank). No experimental front data are in this
               repository, so the error is the DIFFERENCE TO THE dx = 3 mm RUN (He 2018's resolution):
               mean |x - x_3mm| / x_3mm of the water and of the bead front over the output times with
               t > 0.01 s. This is a self-convergence measure, not a validation. The 3 mm run costs ~10-20
               min on one core: pass an existing one with --ref DIR (its front.csv and log.lammps), or it is
               run here.

Cost: the engine's "Loop time" (set-up excluded) divided by the simulated time, with OMP_NUM_THREADS=1.

  hydrostatic  examples/hydrostatic/in.hydrostatic, dx = 5, 2.5, 1.25 mm, t = 0.6 s. Error: the bottom row's
               pressure averaged over the last four dumps (t = 0.45-0.6 s) against rho0 g (H - z).
  poiseuille2phase  examples/poiseuille2phase/in.poiseuille2phase (mu_A/mu_B = 4), res = 20, 40, 80, t = 5 s.
               Error: L2 of the final velocity profile against the steady solution (Shi & Huang 2022 §5.2).

Precision: --precisions double mixed single runs the settling, dambreak2d, hydrostatic and poiseuille2phase cases
once per precision of fix sph/fluid (-var precision P of the examples), one series each in the table and the chart.

Usage: /usr/bin/python3 bench/accuracy_cost.py [--exe build/src_fix/lmp_sphdem] [--cases settling dambreak2d
           particles hydrostatic poiseuille2phase] [--precisions double mixed single] [--work /tmp/sphdem_acc] [--ref DIR] [--reuse]
           [--out bench/results_accuracy]
--reuse analyses existing run directories under --work without running them again.
Writes accuracy_cost.csv, accuracy_cost.md and accuracy_cost.png in --out and prints the table.
"""
import argparse
import csv
import glob
import importlib.util
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
EX = os.path.join(ROOT, "examples")
REF_MM = os.path.join(ROOT, "data", "reference", "martin_moyce_1952.dat")


def load(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


settling_plot = load(os.path.join(EX, "settling", "plot.py"), "settling_plot")
dambreak2d_plot = load(os.path.join(EX, "dambreak2d", "plot.py"), "dambreak2d_plot")
hydrostatic_plot = load(os.path.join(EX, "hydrostatic", "plot.py"), "hydrostatic_plot")
poiseuille_plot = load(os.path.join(EX, "poiseuille2phase", "plot.py"), "poiseuille_plot")


def run(exe, inp, workdir, variables, reuse):
    """Runs one input in workdir (unless reuse and its log exists); returns the loop time in s."""
    os.makedirs(workdir, exist_ok=True)
    log = os.path.join(workdir, "log.lammps")
    if not (reuse and os.path.exists(log)):
        cmd = [exe, "-in", inp, "-log", "log.lammps", "-screen", "none"]
        for k, v in variables:
            cmd += ["-var", k, str(v)]
        env = dict(os.environ, OMP_NUM_THREADS="1", OMP_PROC_BIND="false")
        print("  running:", " ".join(cmd[1:]), "in", workdir, flush=True)
        p = subprocess.run(cmd, cwd=workdir, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if p.returncode != 0:
            raise RuntimeError("%s failed (exit %d): %s" % (inp, p.returncode, p.stdout[-800:]))
    return loop_time(log)


def loop_time(log):
    text = open(log).read()
    if "ERROR" in text:
        raise RuntimeError("%s: %s" % (log, [l for l in text.splitlines() if "ERROR" in l][-1]))
    loops = re.findall(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps", text)
    if not loops:
        raise RuntimeError("%s: no 'Loop time' line (run not finished?)" % log)
    return sum(float(l[0]) for l in loops)


def prec_runs(args):
    """(precision, workdir suffix, series suffix) of each --precisions entry; double keeps the earlier names"""
    return [(p, "" if p == "double" else "_" + p, "" if p == "double" else " (%s)" % p) for p in args.precisions]


def settling(args):
    rows = []
    for prec, wsuf, ssuf in prec_runs(args):
        rows += settling_prec(args, prec, wsuf, ssuf)
    return rows


def settling_prec(args, prec, wsuf, ssuf):
    rows = []
    for dx in (0.003, 0.002, 0.0015):
        wd = os.path.join(args.work, "settling_dx%g%s" % (dx * 1e3, wsuf))
        loop = run(args.exe, os.path.join(EX, "settling", "in.settling"), wd, [("dx", dx), ("precision", prec)],
                   args.reuse)
        a = np.loadtxt(os.path.join(wd, "settling.dat"), comments="#", ndmin=2)
        t, v = a[:, 1], -a[:, 3]
        t_ode, v_ode = settling_plot.ode(0.001, 2500.0, 1000.0, 8.9e-4, 9.81, t[-1])
        ve_all = np.interp(t, t_ode, v_ode)
        for name, sel in (("acceleration, 0.01-0.07 s", (t >= 0.01) & (t <= 0.07)),
                          ("terminal, 0.125-0.25 s", t >= 0.125)):
            err = 100 * np.mean(np.abs(v[sel] - ve_all[sel]) / ve_all[sel])
            rows.append(dict(case="settling", series=name + ssuf, res="dx = %g mm" % (dx * 1e3),
                             tsim=t[-1], loop_s=loop, cost=loop / t[-1], err=err))
    return rows


def dambreak2d(args):
    Tr, Zr = [], []
    for width_in in (2.25, 1.125):
        T, Z = dambreak2d_plot.read_table(args.reference, width_in)
        Tr += list(T[T <= 3.0])
        Zr += list(Z[T <= 3.0])
    Tr, Zr = np.array(Tr), np.array(Zr)
    rows = []
    for (prec, wsuf, ssuf), nres in [(pr, n) for pr in prec_runs(args) for n in (20, 40, 80)]:
        wd = os.path.join(args.work, "dambreak2d_n%d%s" % (nres, wsuf))
        loop = run(args.exe, os.path.join(EX, "dambreak2d", "in.dambreak2d"), wd, [("nres", nres), ("precision", prec)],
                   args.reuse)
        T, Z = dambreak2d_plot.read_front(os.path.join(wd, "front.dat"))
        err = 100 * np.mean(np.abs(np.interp(Tr, T, Z) - Zr) / Zr)
        a = np.loadtxt(os.path.join(wd, "front.dat"), comments="#", ndmin=2)
        rows.append(dict(case="dambreak2d", series="front vs Martin & Moyce" + ssuf, res="a/dx = %d" % nres,
                         tsim=a[-1, 1], loop_s=loop, cost=loop / a[-1, 1], err=err))
    return rows


def hydrostatic(args):
    """still water: the bottom row's time-averaged pressure (last four dumps, t = 0.45-0.6 s) vs rho0 g (H - z)"""
    rows = []
    for (prec, wsuf, ssuf), dx in [(pr, d) for pr in prec_runs(args) for d in (0.005, 0.0025, 0.00125)]:
        wd = os.path.join(args.work, "hydrostatic_dx%g%s" % (dx * 1e3, wsuf))
        loop = run(args.exe, os.path.join(EX, "hydrostatic", "in.hydrostatic"), wd, [("dx", dx), ("precision", prec)],
                   args.reuse)
        files = sorted(glob.glob(os.path.join(wd, "dump.hydrostatic.*")), key=hydrostatic_plot.natural_key)[-4:]
        z, p, _ = hydrostatic_plot.profile(files, dx, 0.2, "f_water[2]")
        exact = 1000.0 * 9.81 * (0.2 - z[0])
        rows.append(dict(case="hydrostatic", series="bottom pressure vs rho0 g (H - z)" + ssuf,
                         res="dx = %g mm" % (dx * 1e3), tsim=0.6, loop_s=loop, cost=loop / 0.6,
                         err=100 * abs(p[0] - exact) / exact))
    return rows


def poiseuille2phase(args):
    """two-phase Poiseuille (mu_A/mu_B = 4, renormalised diffusion) to t = 5 s: L2 of the final profile vs the
    steady solution"""
    rows = []
    fa, fb = poiseuille_plot.parse_model("newtonian 1.0"), poiseuille_plot.parse_model("newtonian 0.25")
    ye, ue = poiseuille_plot.steady(fa, fb)
    for (prec, wsuf, ssuf), res in [(pr, n) for pr in prec_runs(args) for n in (20, 40, 80)]:
        wd = os.path.join(args.work, "poiseuille2phase_res%d%s" % (res, wsuf))
        loop = run(args.exe, os.path.join(EX, "poiseuille2phase", "in.poiseuille2phase"), wd,
                   [("res", res), ("precision", prec)], args.reuse)
        y, u = poiseuille_plot.final_profile(wd)
        ref = np.interp(y, ye, ue)
        rows.append(dict(case="poiseuille2phase", series="L2 vs steady profile" + ssuf, res="res %d" % res, tsim=5.0,
                         loop_s=loop, cost=loop / 5.0, err=100 * np.sqrt(np.sum((u - ref) ** 2) / np.sum(ref ** 2))))
    return rows


def read_fronts(path):
    a = np.genfromtxt(path, delimiter=",", names=True)
    return a["t"], a["x_water"], a["x_beads"]


def particles(args):
    inp = os.path.join(EX, "dambreak_particles", "in.dambreak_particles")
    tend = 0.15
    coarse = []
    for dx, every in ((0.006, 32), (0.005, 27), (0.00375, 20)):
        wd = os.path.join(args.work, "particles_dx%g" % (dx * 1e3))
        loop = run(args.exe, inp, wd, [("dx", dx), ("every", every), ("tend", tend)], args.reuse)
        coarse.append((dx, wd, loop))
    ref = args.ref or os.path.join(args.work, "particles_dx3")
    loop_ref = run(args.exe, inp, ref, [("tend", tend)], args.reuse or bool(args.ref))
    tr, xwr, xgr = read_fronts(os.path.join(ref, "front.csv"))
    rows = []
    # cost of the reference: its loop time scaled to per simulated second (it may have run longer than tend)
    rows.append(dict(case="particles", series="reference", res="dx = 3 mm", tsim=tr[-1], loop_s=loop_ref,
                     cost=loop_ref / tr[-1], err=float("nan")))
    for dx, wd, loop in coarse:
        t, xw, xg = read_fronts(os.path.join(wd, "front.csv"))
        sel = (t > 0.01) & (t <= min(tend, tr[-1]))
        for name, x, xr in (("water front", xw, xwr), ("bead front", xg, xgr)):
            xe = np.interp(t[sel], tr, xr)
            err = 100 * np.mean(np.abs(x[sel] - xe) / xe)
            rows.append(dict(case="particles", series=name + " vs dx = 3 mm", res="dx = %g mm" % (dx * 1e3),
                             tsim=t[-1], loop_s=loop, cost=loop / t[-1], err=err))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--exe", default=os.path.join(ROOT, "build", "src_fix", "lmp_sphdem"))
    ap.add_argument("--cases", nargs="*", default=["settling", "dambreak2d", "particles"])
    ap.add_argument("--work", default="/tmp/sphdem_acc")
    ap.add_argument("--ref", help="an existing dx = 3 mm run of in.dambreak_particles (front.csv, log.lammps)")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--reference", default=REF_MM)
    ap.add_argument("--precisions", nargs="*", default=["double"], choices=["double", "mixed", "single"],
                    help="fix sph/fluid precision of the settling and dambreak2d runs (one series each; default double)")
    ap.add_argument("--out", default=os.path.join(HERE, "results_accuracy"))
    args = ap.parse_args()
    args.exe = os.path.abspath(args.exe)
    if args.ref:
        args.ref = os.path.abspath(args.ref)
    funcs = dict(settling=settling, dambreak2d=dambreak2d, particles=particles, hydrostatic=hydrostatic,
                 poiseuille2phase=poiseuille2phase)
    rows = []
    for c in args.cases:
        if c not in funcs:
            sys.exit("unknown case '%s' (allowed: %s)" % (c, ", ".join(funcs)))
        print("case", c, flush=True)
        rows += funcs[c](args)

    os.makedirs(args.out, exist_ok=True)
    keys = ["case", "series", "res", "tsim", "loop_s", "cost", "err"]
    with open(os.path.join(args.out, "accuracy_cost.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow(r)
    lines = ["| case | measure | resolution | simulated (s) | loop (s) | wall s per simulated s | error (%) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append("| %s | %s | %s | %.3f | %.1f | %.0f | %s |" % (
            r["case"], r["series"], r["res"], r["tsim"], r["loop_s"], r["cost"],
            "-" if np.isnan(r["err"]) else "%.2f" % r["err"]))
    table = "\n".join(lines)
    open(os.path.join(args.out, "accuracy_cost.md"), "w").write(table + "\n")
    print(table)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    order = ("settling", "dambreak2d", "hydrostatic", "poiseuille2phase", "particles")
    cases = [c for c in order if any(r["case"] == c for r in rows)]
    titles = dict(settling="Settling sphere (1 mm, Re 169, engine example)\nmean error of v(t) vs Schiller-Naumann ODE",
                  dambreak2d="2D dam break (water)\nfront vs Martin & Moyce 1952, T <= 3",
                  hydrostatic="Still water (0.2 m deep, 0.6 s)\nbottom-row pressure vs rho0 g (H - z)",
                  poiseuille2phase="Two-phase Poiseuille (mu_A/mu_B = 4, 5 s)\nL2 vs the steady profile",
                  particles="Two-phase dam break (water + beads)\nfronts: difference to the dx = 3 mm run")
    fig, axes = plt.subplots(1, len(cases), figsize=(5 * len(cases), 4.2), squeeze=False)
    for ax, c in zip(axes[0], cases):
        sub = [r for r in rows if r["case"] == c and not np.isnan(r["err"])]
        for s in dict.fromkeys(r["series"] for r in sub):
            pts = [r for r in sub if r["series"] == s]
            ax.plot([r["cost"] for r in pts], [r["err"] for r in pts], "o-", label=s)
            for r in pts:
                ax.annotate(r["res"], (r["cost"], r["err"]), textcoords="offset points", xytext=(4, 4), fontsize=8)
        for r in rows:
            if r["case"] == c and np.isnan(r["err"]):
                ax.axvline(r["cost"], color="grey", ls=":", label="cost of the %s reference" % r["res"])
        ax.set_xscale("log")
        ax.set_xlabel("wall time per simulated second (s, 1 CPU thread)")
        ax.set_ylabel("error (%)")
        ax.set_ylim(bottom=0)
        ax.set_title(titles[c], fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "accuracy_cost.png"), dpi=120)
    print("wrote", os.path.join(args.out, "accuracy_cost.png"))


if __name__ == "__main__":
    main()
