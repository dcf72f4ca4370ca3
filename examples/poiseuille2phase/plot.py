#!/usr/bin/env python3
"""plot.py - two-phase Poiseuille flow (in.poiseuille2phase): final velocity profile against the
semi-analytical steady solution, L2 error (Shi & Huang 2022 §5.2), convergence over resolutions.

The steady solution: shear stress tau(y) = tau0 - G y (G = 2 m/s^2 x 1 kg/m^3), du/dy from each
layer's rheology (Newtonian tau/mu; Herschel-Bulkley 0 below tau_y, ((|tau| - tau_y)/K)^(1/N) above),
u = 0 on both walls; tau0 by bisection. With --cut the law of the solver is used instead (viscosity
held at its value at the cut-off shear rate below it, eq 23), which shows how much of the error is
the cut-off.

  /usr/bin/python3 plot.py --dir run20 run40 run80 [--muB 0.25] [--modelA "newtonian 1.0"]
  /usr/bin/python3 plot.py --summary build/tests/mp_poiseuille_convergence_summary.csv \
                                     build/tests/mp_poiseuille_hb_*_summary.csv   # the ctest's cases

Writes profile.png (and convergence.png with several resolutions, cutoff.png with --summary).
Needs python3, numpy and matplotlib (Debian: python3-numpy, python3-matplotlib).
"""
import argparse
import glob
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tools"))
from dumputil import natural_key, read_dump  # noqa: E402

H, A, G = 2.0, 1.0, 2.0


def parse_model(text):
    w = text.split()
    if w[0] == "newtonian":
        return dict(tau_y=0.0, K=float(w[1]), N=1.0, cut=0.0)
    return dict(tau_y=float(w[1]), K=float(w[2]), N=float(w[3]), cut=float(w[4]))


def viscosity(f, g):
    if f["tau_y"] == 0 and f["N"] == 1:
        return f["K"]
    g = max(g, f["cut"])
    return f["tau_y"] / g + f["K"] * g ** (f["N"] - 1)


def shear_rate(f, tau, cut):
    s, t = np.sign(tau), np.abs(tau)
    if cut and (f["tau_y"] > 0 or f["N"] != 1) and f["cut"] > 0:
        muc = viscosity(f, f["cut"])
        low = t <= muc * f["cut"]
        out = s * np.where(t > f["tau_y"], (np.maximum(t - f["tau_y"], 0) / f["K"]) ** (1 / f["N"]), 0.0)
        return np.where(low, s * t / muc, out)
    return s * np.where(t > f["tau_y"], (np.maximum(t - f["tau_y"], 0) / f["K"]) ** (1 / f["N"]), 0.0)


def steady(fa, fb, cut=False, n=8000):
    y = (np.arange(n) + 0.5) * H / n
    dy = H / n

    def profile(tau0):
        g = np.where(y < A, shear_rate(fa, tau0 - G * y, cut), shear_rate(fb, tau0 - G * y, cut))
        u = np.cumsum(g) * dy - 0.5 * g * dy
        return u, np.sum(g) * dy

    lo, hi = 0.0, G * H
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if profile(mid)[1] > 0:
            hi = mid
        else:
            lo = mid
    return y, profile(0.5 * (lo + hi))[0]


def final_profile(d):
    dumps = sorted(glob.glob(os.path.join(d, "dump.poiseuille.*")), key=natural_key)
    s = list(read_dump(dumps[-1]))[-1]
    fl = s.col("type") < 3
    return s.col("y")[fl], s.col("vx")[fl]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dir", nargs="*", default=["."])
    ap.add_argument("--muB", type=float, default=0.25)
    ap.add_argument("--modelA", default="newtonian 1.0")
    ap.add_argument("--cut", action="store_true", help="compare with the cut-off law of the solver")
    ap.add_argument("--summary", nargs="*", help="mp_poiseuille_*_summary.csv files of verify_mp_poiseuille")
    a = ap.parse_args()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if a.summary:
        import csv
        rows = [r for path in a.summary for r in csv.DictReader(open(path))]
        conv = [r for r in rows if r["case"] == "conv_ratio4"]
        if conv:
            dx = np.array([H / int(r["res"]) for r in conv])
            e = np.array([float(r["l2_exact"]) for r in conv])
            fig, ax = plt.subplots(figsize=(5, 4))
            ax.loglog(dx, 100 * e, "o-", label="SPH, $\\mu_A/\\mu_B$ = 4")
            ax.loglog(dx, 100 * e[0] * dx / dx[0], "k--", lw=0.8, label="order 1")
            ax.set_xlabel("dx (m)")
            ax.set_ylabel("L2 error (%)")
            order = np.log(e[0] / e[-1]) / np.log(dx[0] / dx[-1])
            ax.set_title(f"two-phase Poiseuille: observed order {order:.2f}")
            ax.legend()
            fig.tight_layout()
            fig.savefig("convergence.png", dpi=120)
            print(f"convergence order {order:.2f}")
        nn = [r for r in rows if "_cut" in r["case"]]
        if nn:
            fig, ax = plt.subplots(figsize=(6, 4))
            names = sorted({r["case"].rsplit("_cut", 1)[0] for r in nn})
            for name in names:
                rr = sorted([r for r in nn if r["case"].startswith(name + "_cut")],
                            key=lambda r: float(r["case"].rsplit("_cut", 1)[1]))
                cuts = [float(r["case"].rsplit("_cut", 1)[1]) for r in rr]
                line, = ax.plot(cuts, [100 * float(r["l2_exact"]) for r in rr], "o-", label=name + " vs exact law")
                ax.plot(cuts, [100 * float(r["l2_cutoff"]) for r in rr], "s--", color=line.get_color(),
                        label=name + " vs cut-off law")
            ax.set_xscale("log")
            ax.set_xlabel("cut-off shear rate (1/s)")
            ax.set_ylabel("L2 error (%)")
            ax.set_title("non-Newtonian phase A: the error is the cut-off")
            ax.legend(fontsize=7)
            fig.tight_layout()
            fig.savefig("cutoff.png", dpi=120)
        return

    fa, fb = parse_model(a.modelA), parse_model("newtonian %g" % a.muB)
    ye, ue = steady(fa, fb, cut=False)
    yc, uc = steady(fa, fb, cut=True)
    fig, ax = plt.subplots(figsize=(5, 5))
    errs = []
    for d in a.dir:
        y, u = final_profile(d)
        ref = np.interp(y, yc if a.cut else ye, uc if a.cut else ue)
        e = np.sqrt(np.sum((u - ref) ** 2) / np.sum(ref ** 2))
        res = int(round(H / np.min(np.diff(np.unique(np.round(y, 9))))))
        errs.append((H / res, e))
        print(f"{d}: {len(y)} particles, res {res}, L2 error {100 * e:.3f} %")
        ax.plot(u, y, ".", ms=3, label=f"SPH res {res}")
    ax.plot(ue, ye, "k-", lw=1, label="steady solution")
    if fa["cut"] > 0:
        ax.plot(uc, yc, "k--", lw=1, label="steady, cut-off law")
    ax.axhline(A, color="gray", lw=0.5)
    ax.set_xlabel("u (m/s)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig("profile.png", dpi=120)
    if len(errs) >= 2:
        errs.sort()
        order = np.log(errs[-1][1] / errs[0][1]) / np.log(errs[-1][0] / errs[0][0])
        print(f"observed order {order:.2f}")


if __name__ == "__main__":
    main()
