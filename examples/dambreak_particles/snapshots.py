#!/usr/bin/env python3
"""snapshots.py - side views (x-z, all y) of water and beads from dumps of in.dambreak_particles.

  python3 snapshots.py dump.dambreak_particles.0 dump.dambreak_particles.12190 ... -o snapshots.png

The gate (x = 51 mm, lifted at 0.68 m/s) is drawn from the time step number and --dt (the DEM
timestep of the input, 4.10165e-6 s by default). Needs numpy and matplotlib (/usr/bin/python3).
"""
import argparse

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dumps", nargs="+")
    ap.add_argument("-o", "--output", default="snapshots.png")
    ap.add_argument("--dt", type=float, default=4.10165e-06)
    ap.add_argument("--zmax", type=float, default=110.0, help="top of the plotted height range in mm (default 110)")
    args = ap.parse_args()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(len(args.dumps), 1, figsize=(7, 2.3 * len(args.dumps)), sharex=True, squeeze=False)
    for ax, path in zip(axes[:, 0], args.dumps):
        lines = open(path).read().splitlines()
        step = int(lines[1])
        i = next(k for k, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
        cols = lines[i].split()[2:]
        a = np.array([[float(w) for w in l.split()] for l in lines[i + 1:] if l.strip()])
        typ, x, z = a[:, cols.index("type")], a[:, cols.index("x")], a[:, cols.index("z")]
        w, b = typ == 1, typ == 3
        ax.scatter(x[w] * 1e3, z[w] * 1e3, s=1, c="tab:blue", alpha=0.15, lw=0)
        ax.scatter(x[b] * 1e3, z[b] * 1e3, s=1, c="tab:orange", lw=0)
        t = step * args.dt
        ax.plot([51, 51], [680 * t, 680 * t + 150], color="k", lw=2)
        ax.set_xlim(-2, 202)
        ax.set_ylim(-2, args.zmax)
        ax.set_aspect("equal")
        ax.set_ylabel("z (mm)")
        ax.set_title("t = %.3f s: water (blue), beads (orange), gate (black); side view, all y" % t, fontsize=9)
    axes[-1, 0].set_xlabel("x (mm)")
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)
    print("wrote", args.output)


if __name__ == "__main__":
    main()
