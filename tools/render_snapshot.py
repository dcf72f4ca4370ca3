#!/usr/bin/env python3
"""render_snapshot.py - render one LAMMPS / LIGGGHTS 'dump custom' snapshot to PNG with matplotlib.

2D (all z equal): scatter x-y coloured by the velocity magnitude |v| (or --color COLUMN).
3D: projection on the x-z plane (--view xz, default; atoms nearest the viewer at y = min drawn
last), x-y (--view xy), or a perspective 3D scatter (--view 3d). Wall atoms (--wall-types,
default 2) are drawn grey, behind the fluid.

  python3 tools/render_snapshot.py dump.dambreak2d.2584 --dt 3.867e-5 -o snap.png
  python3 tools/render_snapshot.py dump.3d.200 --color 'f_water[2]' --label 'pressure (Pa)'
  python3 tools/render_snapshot.py 'dump.*' --step last        # pick a snapshot from a series

Standard library + numpy + matplotlib only.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dumputil import read_all  # noqa: E402


def pick(patterns, step):
    snaps = None
    for snap in read_all(patterns):
        if step == "last":
            snaps = snap
        elif step == "first" or snap.step == int(step):
            return snap
    if snaps is None:
        sys.exit("no snapshot%s found in %s" % ("" if step in ("first", "last") else " at step %s" % step,
                                                " ".join(patterns)))
    return snaps


def lattice_spacing(pts):
    """Spacing of atoms on a lattice (the walls): smallest gap between distinct coordinates."""
    best = np.inf
    for d in range(pts.shape[1]):
        u = np.unique(np.round(pts[:, d], 9))
        if len(u) > 1:
            best = min(best, np.diff(u).min())
    return best if np.isfinite(best) else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("dumps", nargs="+", help="dump file(s) or quoted glob pattern")
    ap.add_argument("--step", default="first", help="timestep to render, or first / last (default first)")
    ap.add_argument("-o", "--output", default="snapshot.png")
    ap.add_argument("--color", help="column to colour by (default: |v| from vx vy vz)")
    ap.add_argument("--label", help="colour bar label (default: the column name)")
    ap.add_argument("--clim", nargs=2, type=float, metavar=("MIN", "MAX"), help="colour range")
    ap.add_argument("--cmap", default="viridis")
    ap.add_argument("--wall-types", default="2", help="comma-separated wall atom types, or 'none' (default 2)")
    ap.add_argument("--view", choices=("xz", "xy", "3d"), help="3D dumps: xz (default), xy or 3d")
    ap.add_argument("--dt", type=float, help="timestep size, to print the time in the title")
    ap.add_argument("--dx", type=float, help="particle spacing for the marker size (default: from the wall lattice)")
    ap.add_argument("--title", help="plot title (default: file, step, time)")
    ap.add_argument("--dpi", type=int, default=110)
    ap.add_argument("--width", type=float, default=7.5, help="figure width in inches")
    args = ap.parse_args()

    snap = pick(args.dumps, args.step)
    xyz = snap.positions()
    n = len(xyz)
    wall = np.zeros(n, bool)
    if args.wall_types != "none" and snap.has("type"):
        wtypes = [int(t) for t in args.wall_types.split(",") if t]
        wall = np.isin(snap.col("type").astype(int), wtypes)
    fluid = ~wall

    if args.color:
        if not snap.has(args.color):
            sys.exit("column '%s' is not in the dump (columns: %s)" % (args.color, " ".join(snap.columns)))
        c = snap.col(args.color)
        clabel = args.label or args.color
    elif all(snap.has(k) for k in ("vx", "vy", "vz")):
        c = np.sqrt(snap.col("vx") ** 2 + snap.col("vy") ** 2 + snap.col("vz") ** 2)
        clabel = args.label or "|v| (m/s)"
    else:
        c = np.zeros(n)
        clabel = args.label or ""

    is2d = np.ptp(xyz[:, 2]) == 0.0
    view = "xy" if is2d else (args.view or "xz")
    axes = {"xy": (0, 1, 2), "xz": (0, 2, 1)}.get(view)

    dx = args.dx or (lattice_spacing(xyz[wall]) if wall.any() else None)
    if dx is None:
        span = np.ptp(xyz[fluid][:, :2 if is2d else 3], axis=0)
        dx = (np.prod(span[span > 0]) / max(fluid.sum(), 1)) ** (1.0 / max((span > 0).sum(), 1))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tstr = ""
    if snap.time is not None:
        tstr = ", t = %.4g s" % snap.time
    elif args.dt:
        tstr = ", t = %.4g s" % (snap.step * args.dt)
    title = args.title or "%s, step %d%s (%d fluid, %d wall atoms)" % (
        os.path.basename(snap.path), snap.step, tstr, fluid.sum(), wall.sum())
    cf = c[fluid]
    vmin, vmax = args.clim if args.clim else (np.nanmin(cf) if cf.size else 0, np.nanmax(cf) if cf.size else 1)
    if vmax <= vmin:
        vmax = vmin + 1e-12

    if view == "3d":
        fig = plt.figure(figsize=(args.width, 0.75 * args.width), dpi=args.dpi)
        ax = fig.add_subplot(projection="3d")
        if wall.any():
            ax.scatter(*xyz[wall].T, s=0.3, c="0.75", alpha=0.15, depthshade=False, linewidths=0)
        sc = ax.scatter(*xyz[fluid].T, s=1.0, c=cf, cmap=args.cmap, vmin=vmin, vmax=vmax, linewidths=0)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
        span = np.ptp(xyz, axis=0)
        ax.set_box_aspect(span / span.max())
        fig.colorbar(sc, ax=ax, shrink=0.6, label=clabel)
    else:
        i, j, k = axes
        lo, hi = xyz.min(axis=0), xyz.max(axis=0)
        pad = 2 * dx
        xr, yr = (lo[i] - pad, hi[i] + pad), (lo[j] - pad, hi[j] + pad)
        aspect = (yr[1] - yr[0]) / (xr[1] - xr[0])
        axw = 0.78 * args.width
        fig, ax = plt.subplots(figsize=(args.width, max(2.5, axw * aspect + 1.3)), dpi=args.dpi)
        # marker diameter ~ dx in data units (points: 72 per inch)
        s = (dx * axw * 72.0 / (xr[1] - xr[0])) ** 2
        if wall.any():
            ax.scatter(xyz[wall, i], xyz[wall, j], s=1.6 * s, c="0.6", marker="s", linewidths=0, label="wall")
        fidx = np.where(fluid)[0]
        if not is2d:  # nearest the viewer (smallest depth coordinate) drawn last
            fidx = fidx[np.argsort(-xyz[fidx, k])]
        sc = ax.scatter(xyz[fidx, i], xyz[fidx, j], s=s, c=c[fidx], cmap=args.cmap, vmin=vmin, vmax=vmax,
                        linewidths=0)
        ax.set_xlim(*xr)
        ax.set_ylim(*yr)
        ax.set_aspect("equal")
        names = "xyz"
        ax.set_xlabel("%s (m)" % names[i])
        ax.set_ylabel("%s (m)" % names[j])
        fig.colorbar(sc, ax=ax, label=clabel, fraction=0.046, pad=0.02)
        if not is2d:
            title += "\nprojection on the %s-%s plane" % (names[i], names[j])
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(args.output)
    print("wrote %s: step %d, %d atoms, colour %s in [%.4g, %.4g]" % (args.output, snap.step, n, clabel, vmin, vmax))


if __name__ == "__main__":
    main()
