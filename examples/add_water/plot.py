#!/usr/bin/env python3
"""plot.py - the grains of add_water, dry against wet: mean grain height and grain kinetic energy over time.

  /usr/bin/python3 plot.py [--dry LOG ...] [--wet GRAINS_DAT ...] [--labels ...] [--dt 2e-5] [-o add_water.png]

--dry: engine logs (log file or screen output) of in.dem / in.dem.lmp: thermo columns step atoms ke rke zg (the
       grains are every atom there). --wet: the grains.dat files of in.dem_water / in.dem_water.lmp
       (fix ave/time: step, grain kinetic energy, grain rotational energy, mean grain height).
Prints one row per run (final mean height, final kinetic energy, time the mean height needs to come within
1 mm of its final value) and writes the figure when matplotlib is there.
"""
import argparse
import sys


def read_thermo(path):
    """thermo rows (step, atoms, ke, rke, zg) of the last run in a log: lines of 5 numbers after a 'Step' header"""
    rows, on = [], False
    for line in open(path, errors="replace"):
        w = line.split()
        if w and w[0] == "Step":
            rows, on = [], True
            continue
        if on and len(w) == 5:
            try:
                rows.append([float(x) for x in w])
            except ValueError:
                on = False
        elif on and w and w[0] == "Loop":
            on = False
    return [(r[0], r[2], r[3], r[4]) for r in rows]


def read_grains_dat(path):
    rows = []
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        w = [float(x) for x in line.split()]
        rows.append((w[0], w[1], w[2], w[3]))
    return rows


def summary(rows, dt):
    """final height, final KE, settling time (first t after which zg stays within 1 mm of the final value)"""
    rows = [r for r in rows if r[0] > 0]
    if not rows:
        return None
    zf, kf = rows[-1][3], rows[-1][1] + rows[-1][2]
    ts = None
    for i in range(len(rows)):
        if all(abs(r[3] - zf) < 1e-3 for r in rows[i:]):
            ts = rows[i][0] * dt
            break
    return zf, kf, ts


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dry", nargs="*", default=[])
    ap.add_argument("--wet", nargs="*", default=[])
    ap.add_argument("--labels", nargs="*", default=None)
    ap.add_argument("--dt", type=float, default=2e-5)
    ap.add_argument("-o", default="add_water.png")
    a = ap.parse_args()
    runs = [("dry", p, read_thermo(p)) for p in a.dry] + [("wet", p, read_grains_dat(p)) for p in a.wet]
    if not runs:
        ap.error("give --dry and/or --wet files")
    labels = a.labels if a.labels and len(a.labels) == len(runs) else ["%s %s" % (k, p) for k, p, _ in runs]
    print("%-28s %14s %16s %18s" % ("run", "final z (mm)", "final KE (J)", "settled at (s)"))
    bad = 0
    for lab, (kind, p, rows) in zip(labels, runs):
        s = summary(rows, a.dt)
        if s is None:
            print("%-28s no data in %s" % (lab, p))
            bad = 1
            continue
        print("%-28s %14.2f %16.3e %18s" % (lab, 1e3 * s[0], s[1], "%.2f" % s[2] if s[2] is not None else "-"))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not found: no figure")
        return bad
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for lab, (kind, p, rows) in zip(labels, runs):
        rows = [r for r in rows if r[0] > 0]
        t = [r[0] * a.dt for r in rows]
        ls = "-" if kind == "wet" else "--"
        ax[0].plot(t, [1e3 * r[3] for r in rows], ls, marker="o", ms=3, label=lab)
        ax[1].semilogy(t, [max(r[1] + r[2], 1e-12) for r in rows], ls, marker="o", ms=3, label=lab)
    ax[0].set_xlabel("t (s)")
    ax[0].set_ylabel("mean grain height (mm)")
    ax[1].set_xlabel("t (s)")
    ax[1].set_ylabel("grain kinetic energy, translation + rotation (J)")
    for x in ax:
        x.grid(True, alpha=0.3)
        x.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.o, dpi=120)
    print("wrote", a.o)
    return bad


if __name__ == "__main__":
    sys.exit(main())
