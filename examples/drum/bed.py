#!/usr/bin/python3
"""Bed width and height of the rotating drum (He 2018 §3.2.2, Table 3) from the grain dumps of in.drum.

Definition (He 2018 gives none beyond "average height and width of the bed, averaged over 50 equally
spaced sample times over a period of 10 s"; Sun et al. 2013 measured the bed in the end-view photographs):
  1. every grain is projected onto the drum cross-section (x, z): the view through the end wall;
  2. the cross-section is cut into square cells of one grain diameter d; the solid fraction of a cell
     is the volume of the grains whose centres lie in it divided by d^2 * L (L = drum length);
  3. bed cells are cells with solid fraction >= PHI (default 0.25, about half the packed value), and
     only the largest 8-connected group of bed cells counts (grains thrown off the bed do not);
  4. bed grains are the grains in those cells; the bed width is the horizontal extent of the bed
     grains, max x - min x + d, and the bed height the vertical extent, max z - min z + d (the bed
     touches the drum bottom, so this is the height above the lowest point of the drum);
  5. both are averaged over the dumps of the last TAVG seconds (mean and standard deviation).

Usage:  /usr/bin/python3 bed.py [DIR] [--dt 2.5e-6] [--tavg 10] [--L 0.099] [--phi 0.25] [--png snap.png]
DIR holds dump.grains.STEP (and dump.fluid.STEP, dump.wall.STEP for the picture).
"""
import argparse
import glob
import os
import sys

import numpy as np

TABLE3 = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data", "reference",
                      "he2018_table3_drum.dat")


def read_table3(path=TABLE3):
    """He 2018 Table 3: source -> (width, width sd, height, height sd) in mm."""
    out = {}
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                name, *vals = line.split()
                out[name] = tuple(float(v) for v in vals)
    return out


_T3 = read_table3()
EXP = _T3["sun2013_experiment"]    # Sun et al. 2013 experiment: width (sd), height (sd), mm
SUN = _T3["sun2013_simulation"]    # Sun et al. 2013 simulation
HE = _T3["he2018_simulation"]      # He et al. 2018


def read_dump(path):
    with open(path) as f:
        lines = f.read().split("\n")
    k = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    cols = lines[k].split()[2:]
    rows = [l.split() for l in lines[k + 1:] if l.strip()]
    a = np.array(rows, dtype=float) if rows else np.zeros((0, len(cols)))
    return {c: a[:, i] for i, c in enumerate(cols)}


def steps_of(d, what):
    out = []
    for f in glob.glob(os.path.join(d, "dump.%s.*" % what)):
        try:
            out.append(int(f.rsplit(".", 1)[1]))
        except ValueError:
            pass
    return sorted(out)


def bed(g, L, phi):
    x, z, r = g["x"], g["z"], g["radius"]
    d = 2 * r.max()
    ix = np.floor(x / d).astype(int)
    iz = np.floor(z / d).astype(int)
    ox, oz = ix.min(), iz.min()
    nx, nz = ix.max() - ox + 1, iz.max() - oz + 1
    vol = np.zeros((nx, nz))
    np.add.at(vol, (ix - ox, iz - oz), 4.0 / 3.0 * np.pi * r ** 3)
    frac = vol / (d * d * L)
    on = frac >= phi
    # largest 8-connected group of bed cells
    lab = -np.ones((nx, nz), dtype=int)
    best, bestn, n = -1, 0, 0
    for i in range(nx):
        for j in range(nz):
            if on[i, j] and lab[i, j] < 0:
                stack, cnt = [(i, j)], 0
                lab[i, j] = n
                while stack:
                    a, b = stack.pop()
                    cnt += 1
                    for da in (-1, 0, 1):
                        for db in (-1, 0, 1):
                            p, q = a + da, b + db
                            if 0 <= p < nx and 0 <= q < nz and on[p, q] and lab[p, q] < 0:
                                lab[p, q] = n
                                stack.append((p, q))
                if cnt > bestn:
                    best, bestn = n, cnt
                n += 1
    sel = lab[ix - ox, iz - oz] == best
    if not sel.any():
        return None
    w = x[sel].max() - x[sel].min() + d
    h = z[sel].max() - z[sel].min() + d
    return w, h, sel


def picture(d, step, g, sel, w, h, png, title, L):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 6))
    fl = [s for s in steps_of(d, "fluid") if s <= step]
    if fl:
        f = read_dump(os.path.join(d, "dump.fluid.%d" % fl[-1]))
        ax.scatter(f["x"] * 1e3, f["z"] * 1e3, s=4, c="#7fb3e6", alpha=0.25, lw=0, label="fluid (all y)")
    wl = [s for s in steps_of(d, "wall") if s <= step]
    if wl:
        wa = read_dump(os.path.join(d, "dump.wall.%d" % wl[-1]))
        sh = (wa["y"] > 0) & (wa["y"] < L)   # the inner shell (the end caps would cover the picture)
        ax.scatter(wa["x"][sh] * 1e3, wa["z"][sh] * 1e3, s=3, c="0.4", lw=0, label="drum wall (inner shell)")
    v = np.sqrt(g["vx"] ** 2 + g["vy"] ** 2 + g["vz"] ** 2)
    sc = ax.scatter(g["x"] * 1e3, g["z"] * 1e3, s=6, c=v, cmap="viridis", lw=0, vmin=0, vmax=max(v.max(), 1e-9))
    x, z = g["x"][sel], g["z"][sel]
    dd = 2e3 * g["radius"].max()
    x0, z0 = x.min() * 1e3 - dd / 2, z.min() * 1e3 - dd / 2
    ax.add_patch(plt.Rectangle((x0, z0), w * 1e3, h * 1e3, fill=False, ec="r", lw=1.2,
                               label="bed extent %.1f x %.1f mm" % (w * 1e3, h * 1e3)))
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title(title, fontsize=9)
    fig.colorbar(sc, ax=ax, shrink=0.7, label="grain speed (m/s)")
    ax.legend(loc="upper left", fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=130)
    print("wrote", png)


def series(a, steps, use):
    """Width and height of the bed at every sample of the run, the averaging window shaded, Table 3 as lines."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t, W, H = [], [], []
    for s in steps:
        res = bed(read_dump(os.path.join(a.dir, "dump.grains.%d" % s)), a.L, a.phi)
        if res is not None:
            t.append(s * a.dt); W.append(res[0] * 1e3); H.append(res[1] * 1e3)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for k, (vals, name, col) in enumerate(((W, "width", 0), (H, "height", 2))):
        x = ax[k]
        x.plot(t, vals, "o-", ms=3, lw=1, label="this run (each sample)")
        x.axvspan(use[0] * a.dt, use[-1] * a.dt, color="0.9", label="averaging window")
        sel = [v for ti, v in zip(t, vals) if ti >= use[0] * a.dt - 1e-12]
        if sel:
            x.axhline(np.mean(sel), color="C0", ls=":", label="this run, mean in window %.1f mm" % np.mean(sel))
        x.axhline(EXP[col], color="k", label="experiment (Sun 2013) %.2f mm" % EXP[col])
        x.axhspan(EXP[col] - EXP[col + 1], EXP[col] + EXP[col + 1], color="k", alpha=0.12)
        x.axhline(HE[col], color="C3", ls="--", label="He et al. 2018 %.2f mm" % HE[col])
        x.set_xlabel("time since the drum started (s)")
        x.set_ylabel("bed %s (mm)" % name)
        x.grid(alpha=0.3)
        x.legend(fontsize=7, loc="best")
    fig.suptitle(a.title or "rotating drum: bed width and height over the run")
    fig.tight_layout()
    fig.savefig(a.series, dpi=110)
    print("wrote", a.series)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("dir", nargs="?", default=".")
    p.add_argument("--dt", type=float, default=2.5e-6, help="engine time step of the run (s)")
    p.add_argument("--tavg", type=float, default=10.0, help="averaging window at the end of the run (s)")
    p.add_argument("--L", type=float, default=0.099, help="drum length (m): Ny dx of in.drum")
    p.add_argument("--phi", type=float, default=0.25, help="solid fraction threshold of a bed cell")
    p.add_argument("--png", default="", help="write a cross-section picture of the last sample")
    p.add_argument("--title", default="")
    p.add_argument("--series", default="", help="write width and height of every sample against time (PNG), "
                   "with Table 3's values and the averaging window")
    a = p.parse_args()
    steps = [s for s in steps_of(a.dir, "grains") if s > 0]
    if not steps:
        sys.exit("no dump.grains.STEP files with STEP > 0 in %s" % a.dir)
    tend = steps[-1] * a.dt
    use = [s for s in steps if s * a.dt >= tend - a.tavg - 1e-12]
    W, H = [], []
    last = None
    for s in use:
        g = read_dump(os.path.join(a.dir, "dump.grains.%d" % s))
        res = bed(g, a.L, a.phi)
        if res is None:
            continue
        W.append(res[0] * 1e3)
        H.append(res[1] * 1e3)
        last = (s, g, res)
        print("t = %8.4f s  width %6.2f mm  height %6.2f mm  (%d of %d grains in the bed)"
              % (s * a.dt, W[-1], H[-1], res[2].sum(), len(g["x"])))
    W, H = np.array(W), np.array(H)
    print("\n%d samples over t = %.4f .. %.4f s" % (len(W), use[0] * a.dt, use[-1] * a.dt))
    print("%-22s %16s %16s" % ("bed dimension, mm", "width (sd)", "height (sd)"))
    print("%-22s %9.2f (%4.2f) %9.2f (%4.2f)" % ("this run", W.mean(), W.std(), H.mean(), H.std()))
    for name, ref in (("experiment [Sun 2013]", EXP), ("simulation [Sun 2013]", SUN), ("He et al. 2018", HE)):
        print("%-22s %9.2f (%4.2f) %9.2f (%4.2f)   this run vs it: width %+.1f %%, height %+.1f %%"
              % (name, ref[0], ref[1], ref[2], ref[3], 100 * (W.mean() / ref[0] - 1), 100 * (H.mean() / ref[2] - 1)))
    if a.series:
        series(a, steps, use)
    if a.png and last:
        s, g, (w, h, sel) = last
        title = a.title or "drum cross-section, t = %.3f s (projection of all grains)" % (s * a.dt)
        picture(a.dir, s, g, sel, w, h, a.png, title, a.L)


if __name__ == "__main__":
    main()
