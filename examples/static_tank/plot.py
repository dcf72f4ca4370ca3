#!/usr/bin/env python3
"""plot.py - two-layer static tank (in.static_tank): probe pressures vs time and the final state.

Reads probes.txt (fix ave/time: t, PA, Pint, PB) and the last dump.static_tank.* file; writes
probes.png (the three probes against their hydrostatic values 2940, 5880, 11760 Pa) and
snapshot.png (particles coloured by phase, and the pressure profile on the centre column against
the layered hydrostatic profile). Prints the worst probe error from t = 1 s on.

  /usr/bin/python3 plot.py [--dir RUN_DIR]

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

G, HL, RHO_A, RHO_B = 9.8, 0.6, 2000.0, 1000.0
EXACT = {"PA": RHO_B * G * 0.3, "Pint": RHO_B * G * HL, "PB": RHO_B * G * HL + RHO_A * G * 0.3}


def hydrostatic(y):
    return np.where(y >= HL, RHO_B * G * np.clip(2 * HL - y, 0, None), RHO_B * G * HL + RHO_A * G * (HL - y))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dir", default=".")
    ap.add_argument("--tstart", type=float, default=1.0, help="start of the error window (s)")
    a = ap.parse_args()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pr = np.loadtxt(os.path.join(a.dir, "probes.txt"), comments="#")
    t = pr[:, 1]
    fig, ax = plt.subplots(figsize=(7, 4))
    for k, (name, col) in enumerate([("PA", 2), ("Pint", 3), ("PB", 4)]):
        line, = ax.plot(t, pr[:, col], lw=1, label=f"{name} (SPH)")
        ax.axhline(EXACT[name], color=line.get_color(), ls="--", lw=0.8)
        late = t >= a.tstart
        if late.any():
            err = np.abs(pr[late, col] - EXACT[name]).max() / EXACT[name]
            mean = (pr[late, col].mean() - EXACT[name]) / EXACT[name]
            print(f"{name}: worst error from t = {a.tstart} s {100 * err:.2f} %, mean {100 * mean:+.2f} %")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("pressure (Pa)")
    ax.set_title("Two-layer static tank (Shi & Huang 2022 §5.1); dashed: hydrostatic")
    ax.legend(fontsize=8, ncol=3)
    fig.tight_layout()
    fig.savefig(os.path.join(a.dir, "probes.png"), dpi=120)

    dumps = sorted(glob.glob(os.path.join(a.dir, "dump.static_tank.*")), key=natural_key)
    if not dumps:
        return
    s = list(read_dump(dumps[-1]))[-1]
    ty = s.col("type")
    fl = ty < 3
    x, y, p = s.col("x")[fl], s.col("y")[fl], s.col("f_tank[2]")[fl]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.5), gridspec_kw={"width_ratios": [1.3, 1]})
    a1.scatter(x, y, c=np.where(ty[fl] == 1, 0.2, 0.8), cmap="coolwarm", s=2, vmin=0, vmax=1)
    w = ty == 3
    a1.scatter(s.col("x")[w], s.col("y")[w], c="k", s=2)
    a1.set_aspect("equal")
    a1.set_title(f"phases at t = {s.step * 1.5e-4:.2f} s (blue A, red B)")
    col = np.abs(x - 0.6) < 0.05
    order = np.argsort(y[col])
    a2.plot(p[col][order], y[col][order], ".", ms=3, label="SPH particles |x - 0.6| < 0.05")
    yy = np.linspace(0, 2 * HL, 200)
    a2.plot(hydrostatic(yy), yy, "k-", lw=1, label="hydrostatic")
    a2.set_xlabel("pressure (Pa)")
    a2.set_ylabel("y (m)")
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.dir, "snapshot.png"), dpi=120)


if __name__ == "__main__":
    main()
