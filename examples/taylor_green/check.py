#!/usr/bin/env python3
"""Kinetic-energy decay of the Taylor-Green vortex (in.taylor_green) against the exact rate 16 pi^2 nu / L^2.

Reads the thermo table of a log (columns step, v_t, c_ke, ...), keeps the samples until the kinetic energy has
fallen to FLOOR (default 0.3) of its start, fits ln KE = a - rate t by least squares and prints the rate, the
exact rate and their relative difference; with --bound B it exits 1 when |difference| > B.
  usage: check.py LOG [--nu 0.01] [--L 1.0] [--floor 0.3] [--bound 0.05] [--plot decay.png]
"""
import argparse
import math
import sys


def thermo(path):
    """(t, ke) rows of the last thermo table whose header starts with 'Step v_t c_ke' ('Step t ke' in LIGGGHTS)."""
    rows, on = [], False
    for line in open(path):
        w = line.split()
        if w[:1] == ["Step"] and w[1:3] in (["v_t", "c_ke"], ["t", "ke"]):  # LIGGGHTS writes the names bare
            rows, on = [], True
            continue
        if on:
            try:
                rows.append((float(w[1]), float(w[2])))
            except (ValueError, IndexError):
                on = False
    return rows


def decay_rate(rows, floor):
    ke0 = rows[0][1]
    pts = [(t, math.log(k)) for t, k in rows if k >= floor * ke0 and k > 0]
    n = len(pts)
    if n < 3:
        raise SystemExit("check.py: fewer than 3 samples above the floor; run longer or sample more often")
    mt = sum(t for t, _ in pts) / n
    ml = sum(l for _, l in pts) / n
    s = sum((t - mt) * (l - ml) for t, l in pts) / sum((t - mt) ** 2 for t, _ in pts)
    reached = rows[-1][1] <= floor * ke0
    return -s, n, pts[-1][0], reached


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("log")
    ap.add_argument("--nu", type=float, default=0.01)
    ap.add_argument("--L", type=float, default=1.0)
    ap.add_argument("--floor", type=float, default=0.3)
    ap.add_argument("--bound", type=float)
    ap.add_argument("--plot")
    a = ap.parse_args()
    rows = thermo(a.log)
    if not rows:
        raise SystemExit(f"check.py: no thermo table 'Step v_t c_ke' (LIGGGHTS: 'Step t ke') in {a.log}")
    exact = 16.0 * math.pi ** 2 * a.nu / a.L ** 2
    rate, n, tlast, reached = decay_rate(rows, a.floor)
    err = rate / exact - 1.0
    print(f"TAYLOR_GREEN rate {rate:.5f} exact {exact:.5f} error {100 * err:+.2f} % "
          f"({n} samples to t = {tlast:.4g} s; KE fell to {rows[-1][1] / rows[0][1]:.3f}"
          f"{'' if reached else ', the floor was not reached'})")
    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        t = [r[0] for r in rows]
        plt.semilogy(t, [r[1] / rows[0][1] for r in rows], "o", ms=3, label="sphdem")
        plt.semilogy(t, [math.exp(-exact * x) for x in t], "-", label=r"exact $e^{-16\pi^2\nu t/L^2}$")
        plt.xlabel("t (s)"); plt.ylabel("KE / KE(0)"); plt.legend(); plt.title("Taylor-Green vortex, Re = 100, %d samples" % len(rows))
        plt.tight_layout()
        plt.savefig(a.plot, dpi=120)
    if a.bound is not None and not (abs(err) <= a.bound and reached):
        print(f"FAIL: |error| {abs(err):.4f} > {a.bound} or the floor was not reached")
        sys.exit(1)


if __name__ == "__main__":
    main()
