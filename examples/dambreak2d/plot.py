#!/usr/bin/env python3
"""plot.py - surge front of the 2D dam break (in.dambreak2d) vs Martin & Moyce (1952).

Reads the run's front.dat (columns: step, t, T = t sqrt(2g/a), Z = front/a; written by
'fix print' in in.dambreak2d) and the a = 2.25 in and a = 1.125 in series of
data/reference/martin_moyce_1952.dat, writes front.png and prints the deviation from both
series at their tabulated times T <= 3.

  python3 plot.py                        # front.dat in the current directory
  python3 plot.py run_lmp/front.dat run_lig/front.dat --labels LAMMPS LIGGGHTS
  python3 plot.py --reference /path/to/martin_moyce_1952.dat -o front.png

Needs python3, numpy and matplotlib (Debian: python3-numpy, python3-matplotlib).
"""
import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_REF = os.path.normpath(os.path.join(HERE, "..", "..", "data", "reference", "martin_moyce_1952.dat"))


def read_front(path):
    """front.dat: '# ...' header lines, then step t T Z per line."""
    data = np.loadtxt(path, comments="#", ndmin=2)
    if data.shape[1] < 4:
        sys.exit("%s: expected 4 columns (step t T Z), found %d" % (path, data.shape[1]))
    order = np.argsort(data[:, 2])
    return data[order, 2], data[order, 3]


def read_table(path, width_in):
    """The series of martin_moyce_1952.dat (columns a_in T Z) with column width a = width_in inches -> T, Z."""
    data = np.loadtxt(path, comments="#", ndmin=2)
    rows = data[np.isclose(data[:, 0], width_in)]
    if len(rows) == 0:
        sys.exit("%s: no rows with a = %g in" % (path, width_in))
    return rows[:, 1], rows[:, 2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("fronts", nargs="*", default=["front.dat"], help="front.dat file(s) of runs (default front.dat)")
    ap.add_argument("--labels", nargs="*", help="legend label per front file")
    ap.add_argument("--reference", default=DEFAULT_REF,
                    help="martin_moyce_1952.dat, or its folder (default %(default)s)")
    ap.add_argument("-o", "--output", default="front.png")
    ap.add_argument("--tmax", type=float, default=3.0, help="compare at tabulated T <= TMAX (default 3)")
    args = ap.parse_args()

    ref = args.reference
    if os.path.isdir(ref):
        ref = os.path.join(ref, "martin_moyce_1952.dat")
    if not os.path.exists(ref):
        sys.exit("reference data not found at %s; pass --reference PATH" % ref)
    series = [("Martin & Moyce 1952, a = 2.25 in", 2.25, "s"),
              ("Martin & Moyce 1952, a = 1.125 in", 1.125, "^")]
    tables = [(name, marker) + read_table(ref, head) for name, head, marker in series]

    labels = args.labels or []
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.6), dpi=110)
    tlim = 0.0
    for k, path in enumerate(args.fronts):
        T, Z = read_front(path)
        label = labels[k] if k < len(labels) else ("SPH (sphdem), " + os.path.relpath(path))
        ax.plot(T, Z, ("-", "--", ":", "-.")[k % 4], lw=1.8, label=label)
        tlim = max(tlim, T.max())
        print("%s: %d samples, T up to %.3f" % (path, len(T), T.max()))
        for name, _, Tr, Zr in tables:
            sel = Tr <= min(args.tmax, T.max())
            if not sel.any():
                continue
            Zs = np.interp(Tr[sel], T, Z)
            err = (Zs - Zr[sel]) / Zr[sel]
            print("  vs %s:" % name)
            for tr, zr, zs, e in zip(Tr[sel], Zr[sel], Zs, err):
                print("    T %.3f  Z_sim %.3f  Z_exp %.3f  %+6.1f%%" % (tr, zs, zr, 100 * e))
            i = int(np.argmax(np.abs(err)))
            print("    largest deviation %+.1f%% at T = %.3f; mean |deviation| %.1f%%"
                  % (100 * err[i], Tr[sel][i], 100 * np.mean(np.abs(err))))
    for name, marker, Tr, Zr in tables:
        sel = Tr <= max(tlim, 1.0) * 1.15
        ax.plot(Tr[sel], Zr[sel], marker, ms=7, mfc="none", mew=1.5, label=name)
    ax.set_xlabel(r"$T = t\,\sqrt{2g/a}$")
    ax.set_ylabel(r"$Z = z/a$  (surge front from the far wall)")
    ax.set_title("2D dam break, column a = 0.1 m, height 2a: surge front")
    ax.set_xlim(0, max(tlim, 1.0) * 1.05)
    ax.set_ylim(bottom=0.8)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=9)
    fig.tight_layout()
    fig.savefig(args.output)
    print("wrote %s" % args.output)


if __name__ == "__main__":
    main()
