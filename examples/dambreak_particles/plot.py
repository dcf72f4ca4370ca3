#!/usr/bin/env python3
"""plot.py - leading fronts of water and beads in the two-phase dam break (in.dambreak_particles).

Reads front.csv of one or more runs (written by 'fix print' in in.dambreak_particles: step, t,
T = t sqrt(2g/a), x_water, x_beads, Z_water = x_water/a, Z_beads = x_beads/a, a = 50 mm the
initial column length; x is the largest x of the water / of the beads plus half a particle) and
writes fronts.png: Z against T for water and beads, and prints the fronts at a few times.
No experimental data of Sun et al. (2013) are in this repository; He 2018 Fig. 14 shows them.

  python3 plot.py                                     # front.csv in the current directory
  python3 plot.py run_lmp/front.csv run_lig/front.csv --labels LAMMPS LIGGGHTS -o fronts.png

Needs numpy and matplotlib (/usr/bin/python3 on Debian).
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import plotlib  # noqa: E402


def read(path):
    a = np.genfromtxt(path, delimiter=",", names=True)
    return a


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*", default=["front.csv"])
    ap.add_argument("--labels", nargs="*")
    ap.add_argument("-o", "--output", default="fronts.png")
    args = ap.parse_args()
    labels = args.labels or args.files
    plt = plotlib.pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for path, lab in zip(args.files, labels):
        a = read(path)
        ax.plot(a["T"], a["Z_water"], "-", label="water (%s)" % lab)
        ax.plot(a["T"], a["Z_beads"], "--", label="beads (%s)" % lab)
        print("%s: %d rows, t = %.4f ... %.4f s" % (lab, len(a), a["t"][0], a["t"][-1]))
        for tq in (0.025, 0.05, 0.075, 0.1, 0.125, 0.15, 0.2, 0.3, 0.4):
            if tq <= a["t"][-1] + 1e-9:
                k = int(np.argmin(abs(a["t"] - tq)))
                print("  t = %.3f s (T = %.3f): water front x = %.1f mm (Z %.3f), beads x = %.1f mm (Z %.3f)" %
                      (a["t"][k], a["T"][k], 1e3 * a["x_water"][k], a["Z_water"][k], 1e3 * a["x_beads"][k],
                       a["Z_beads"][k]))
    ax.axhline(4.0, color="grey", lw=0.8, ls=":", label="far wall (x = 200 mm)")
    plotlib.axes(ax, "T = t sqrt(2 g / a)", "Z = leading front x / a",
                 "two-phase dam break, a = 50 mm, gate lifted at 0.68 m/s")
    plotlib.save(fig, args.output)


if __name__ == "__main__":
    main()
