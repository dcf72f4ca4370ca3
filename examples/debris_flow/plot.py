#!/usr/bin/env python3
"""plot.py - submarine debris flow (in.debris_flow): free surface and snapshots at t = 0.4 and 0.8 s.

Reads the dumps dump.debris_flow.* of a run (one every 0.1 s) and writes
  surface.png   free-surface profile of the water (highest water particle in x bins of 2 dx) at
                t = 0.4 s and 0.8 s, with the initial still-water level 1.6 m;
  snapshot.png  particles at t = 0.4 s and 0.8 s: mud (phase B) in brown, walls in grey, water
                (phase A) coloured by its pressure.
Prints, for each time, the surface elevation maximum and minimum (relative to 1.6 m) and the mud
front (largest x of a mud particle). With --vtk it also converts every dump to a legacy VTK
PolyData file vtk/debris_flow_NNNNNN.vtk (points; point data type, velocity, pressure, density,
viscosity) plus vtk/debris_flow.vtk.series for ParaView, with the writer of tools/dump2vtk.py.

  /usr/bin/python3 plot.py [--dir RUN_DIR] [--vtk]

Needs python3, numpy and matplotlib (Debian: python3-numpy, python3-matplotlib).
"""
import argparse
import glob
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tools"))
from dumputil import natural_key, read_dump  # noqa: E402

DX, H, DT_SNAP = 0.02, 1.6, 0.1          # particle spacing, still-water depth, dump interval (s)
FIX = "f_flow"                            # fix ID of in.debris_flow
TIMES = (0.4, 0.8)


def load(run_dir):
    """{t: snapshot} of the dumps; t = 0.1 s x the dump's index in step order."""
    dumps = sorted(glob.glob(os.path.join(run_dir, "dump.debris_flow.*")), key=natural_key)
    dumps = [d for d in dumps if not d.endswith(".vtk")]
    if not dumps:
        sys.exit("no dump.debris_flow.* in %s: run lmp_sphdem -in in.debris_flow there first" % run_dir)
    snaps = [s for d in dumps for s in read_dump(d)]
    snaps.sort(key=lambda s: s.step)
    steps = [s.step for s in snaps if s.step > 0]
    if not steps:
        sys.exit("only the initial dump in %s: the run did not reach t = 0.1 s" % run_dir)
    step0 = min(steps)                    # steps per 0.1 s
    return {round(s.step / step0 * DT_SNAP, 6): s for s in snaps}, snaps, step0


def surface(s, dx=DX):
    """x bin centres and the highest water particle of each bin (bins of 2 dx over 0..4 m)."""
    w = s.col("type") == 1
    x, y = s.col("x")[w], s.col("y")[w]
    edges = np.arange(0.0, 4.0 + 1e-9, 2 * dx)
    idx = np.digitize(x, edges) - 1
    top = np.full(len(edges) - 1, np.nan)
    for k in range(len(top)):
        sel = idx == k
        if sel.any():
            top[k] = y[sel].max()
    return 0.5 * (edges[1:] + edges[:-1]), top


def write_vtk(snaps, step0, outdir):
    from dump2vtk import write_legacy  # tools/dump2vtk.py
    os.makedirs(outdir, exist_ok=True)
    files = []
    for s in snaps:
        n = len(s.data)
        xyz = np.column_stack([s.col("x"), s.col("y"), np.zeros(n)])
        vel = np.column_stack([s.col("vx"), s.col("vy"), np.zeros(n)])
        scalars = [("type", s.col("type"), True), ("pressure", s.col(FIX + "[2]"), False),
                   ("density", s.col(FIX + "[1]"), False), ("viscosity", s.col(FIX + "[4]"), False)]
        base = "debris_flow_%06d.vtk" % s.step
        write_legacy(os.path.join(outdir, base), s, xyz, scalars, [("velocity", vel)], True)
        files.append({"name": base, "time": round(s.step / step0 * DT_SNAP, 6)})
    with open(os.path.join(outdir, "debris_flow.vtk.series"), "w") as f:
        json.dump({"file-series-version": "1.0", "files": files}, f, indent=1)
    print("wrote %d VTK files and debris_flow.vtk.series to %s (open the .series in ParaView)"
          % (len(files), outdir))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dir", default=".", help="run directory with the dumps (default: .)")
    ap.add_argument("--out", default=None, help="folder of the png files (default: --dir)")
    ap.add_argument("--vtk", action="store_true", help="also write legacy VTK files to RUN_DIR/vtk")
    a = ap.parse_args()
    out = a.out or a.dir
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bytime, snaps, step0 = load(a.dir)
    if a.vtk:
        write_vtk(snaps, step0, os.path.join(a.dir, "vtk"))
    times = [t for t in TIMES if t in bytime]
    if not times:
        sys.exit("no dump at t = 0.4 or 0.8 s (times found: %s)" % sorted(bytime))

    fig, axs = plt.subplots(len(times), 1, figsize=(8, 2.6 * len(times)), squeeze=False)
    for ax, t in zip(axs[:, 0], times):
        s = bytime[t]
        xc, top = surface(s)
        ax.plot(xc, top, "b-", lw=1.2, label="SPH water surface (highest water particle per 2 dx)")
        ax.axhline(H, color="k", ls="--", lw=0.8, label="initial level 1.6 m")
        ok = ~np.isnan(top)
        kmax, kmin = np.nanargmax(top), np.nanargmin(np.where(ok & (xc > 0.5), top, np.nan))
        mud = s.col("type") == 2
        front = s.col("x")[mud].max()
        print("t = %.1f s: surface max %+.3f m (y = %.3f m at x = %.2f m), min %+.3f m (y = %.3f m at "
              "x = %.2f m); mud front x = %.3f m"
              % (t, top[kmax] - H, top[kmax], xc[kmax], top[kmin] - H, top[kmin], xc[kmin], front))
        ax.set_xlim(0, 4)
        ax.set_ylim(1.2, 1.9)
        ax.set_ylabel("y (m)")
        ax.set_title("t = %.1f s" % t, fontsize=10)
        ax.legend(fontsize=7, loc="upper right")
    axs[-1, 0].set_xlabel("x (m)")
    fig.suptitle("Submarine debris flow (Shi & Huang 2022 §5.3): free surface", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "surface.png"), dpi=120)

    fig, axs = plt.subplots(len(times), 1, figsize=(9, 4.2 * len(times)), squeeze=False)
    for ax, t in zip(axs[:, 0], times):
        s = bytime[t]
        ty, x, y, p = s.col("type"), s.col("x"), s.col("y"), s.col(FIX + "[2]")
        w, m, b = ty == 1, ty == 2, ty == 3
        sc = ax.scatter(x[w], y[w], c=p[w] / 1e3, cmap="viridis", s=1.6, vmin=0, vmax=17, linewidths=0)
        ax.scatter(x[m], y[m], c="saddlebrown", s=1.6, linewidths=0, label="mud (phase B)")
        ax.scatter(x[b], y[b], c="0.5", s=1.6, linewidths=0, label="walls")
        ax.set_aspect("equal")
        ax.set_xlim(-0.1, 4.1)
        ax.set_ylim(-0.1, 2.05)
        ax.set_title("t = %.1f s: water coloured by pressure" % t, fontsize=10)
        ax.legend(fontsize=7, loc="upper right", markerscale=8)
        fig.colorbar(sc, ax=ax, label="water pressure (kPa)", shrink=0.8)
    axs[-1, 0].set_xlabel("x (m)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "snapshot.png"), dpi=90)


if __name__ == "__main__":
    main()
