#!/usr/bin/env python3
"""plot.py - pressure profile of the still-water example (in.hydrostatic) vs rho0 g (H - z).

Reads the dumps of the run (default: the last four dump.hydrostatic.* files, t = 0.45 ... 0.6 s),
averages the fluid pressure f_water[2] in rows of height dx over those snapshots, writes
pressure.png and prints the bottom-row error and the largest deviation (as % of rho0 g H).

  python3 plot.py                                   # dump.hydrostatic.* in the current directory
  python3 plot.py --last 1                          # the final dump only
  python3 plot.py run_lig/dump.hydrostatic.* --label LIGGGHTS --compare run_lmp/dump.hydrostatic.*

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


def profile(files, dx, H, pcol):
    """Row-averaged pressure over all snapshots of files -> z (row centres), p, samples per row."""
    nrows = int(round(H / dx))
    psum, cnt = np.zeros(nrows), np.zeros(nrows)
    nsnap = 0
    for path in files:
        for s in read_dump(path):
            fl = s.col("type") == 1
            y, p = s.col("y")[fl], s.col(pcol)[fl]
            r = np.floor(y / dx).astype(int)
            ok = (r >= 0) & (r < nrows)
            np.add.at(psum, r[ok], p[ok])
            np.add.at(cnt, r[ok], 1)
            nsnap += 1
    z = (np.arange(nrows) + 0.5) * dx
    with np.errstate(invalid="ignore"):
        return z, psum / cnt, nsnap


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dumps", nargs="*", help="dump files (default: dump.hydrostatic.* here)")
    ap.add_argument("--last", type=int, default=4, help="use the last N dump files (default 4)")
    ap.add_argument("--label", default="SPH (sphdem)")
    ap.add_argument("--compare", nargs="*", help="dumps of a second run (e.g. the other engine)")
    ap.add_argument("--compare-label", default="second run")
    ap.add_argument("--dx", type=float, default=0.0025)
    ap.add_argument("--depth", type=float, default=0.2, help="water depth H (m)")
    ap.add_argument("--rho0", type=float, default=1000.0)
    ap.add_argument("--g", type=float, default=9.81)
    ap.add_argument("--pressure-column", default="f_water[2]")
    ap.add_argument("-o", "--output", default="pressure.png")
    args = ap.parse_args()

    def files_of(lst):
        files = sorted(lst or glob.glob("dump.hydrostatic.*"), key=natural_key)
        if not files:
            sys.exit("no dump files (run in.hydrostatic first, or name them)")
        return files[-args.last:]

    H, dx = args.depth, args.dx
    runs = [(args.label, files_of(args.dumps))]
    if args.compare:
        runs.append((args.compare_label, files_of(args.compare)))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(9, 5), dpi=110, sharey=True)
    zz = np.linspace(0, H, 50)
    pref = args.rho0 * args.g * H
    ax.plot(args.rho0 * args.g * (H - zz), zz, "k-", lw=1.2, label=r"$\rho_0 g (H - z)$")
    ax2.axvline(0, color="k", lw=0.8)
    for k, (label, files) in enumerate(runs):
        z, p, nsnap = profile(files, dx, H, args.pressure_column)
        exact = args.rho0 * args.g * (H - z)
        err = (p - exact) / pref
        eb = (p[0] - exact[0]) / exact[0]
        i = int(np.nanargmax(np.abs(err)))
        print("%s: %d snapshots (%s ... %s)" % (label, nsnap, os.path.basename(files[0]), os.path.basename(files[-1])))
        print("  bottom row (z = %.5f m): p = %.1f Pa vs rho0 g (H - z) = %.1f Pa: error %+.2f%%"
              % (z[0], p[0], exact[0], 100 * eb))
        print("  largest deviation %+.2f%% of rho0 g H at z = %.4f m (mean |dev| %.2f%%)"
              % (100 * err[i], z[i], 100 * np.nanmean(np.abs(err))))
        mk = ("o", "x")[k % 2]
        ax.plot(p, z, mk, ms=4, mfc="none", label="%s (bottom row %+.2f%%)" % (label, 100 * eb))
        ax2.plot(100 * err, z, mk + "-", ms=3, lw=0.8, mfc="none", label=label)
    ax.set_xlabel("pressure p (Pa), averaged in rows of height dx")
    ax.set_ylabel("height above the tank bottom z (m)")
    ax.set_title("Still water, H = %.2f m, dx = %.4g m" % (H, dx), fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax2.set_xlabel(r"$(p - \rho_0 g (H - z)) / \rho_0 g H$  (%)")
    ax2.set_title("deviation from hydrostatic", fontsize=10)
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    ax.set_ylim(0, H * 1.02)
    fig.tight_layout()
    fig.savefig(args.output)
    print("wrote %s" % args.output)


if __name__ == "__main__":
    main()
