#!/usr/bin/env python3
"""plot.py - post-processing of examples/bubbling_bed (run in the directory of the run).

Reads gas_*.vti (fix cfd/grid vtk output: cell voidage, pressure, gas velocity), grains.dump (dump
custom id x y z vx vy vz radius) and bed.dat (fix print), and writes
  bubbling_snapshots.png  grains (x-z, coloured by vz) and the y-averaged gas voidage at 4 times
  bubbling_profiles.png   time-averaged voidage across the bed at z = 16.4 mm (cells of that row,
                          averaged over y) and time-averaged vertical grain velocity in the band
                          z = 10-20 mm, binned in x (Yu 2024 Fig. 12 / Mueller et al. 2008 trend:
                          up-flow in the centre, down-flow at the walls)
  bubbling_dp.png         pressure drop over the bed vs time, with the bed weight per area
Usage: /usr/bin/python3 plot.py [--tstart 0.3] [--out .]
"""
import argparse
import glob
import os
import re
import xml.etree.ElementTree as ET

import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

LX, LY, LZ = 0.044, 0.010, 0.200
NGRAIN, DP, RHOP, G = 9240, 0.0012, 1000.0, 9.81


def read_vti(path):
    root = ET.parse(path).getroot()
    img = root.find("ImageData")
    ext = [int(v) for v in img.get("WholeExtent").split()]
    nc = (ext[1] - ext[0], ext[3] - ext[2], ext[5] - ext[4])
    t = None
    out = {}
    for da in root.iter("DataArray"):
        vals = np.array(da.text.split(), dtype=float)
        if da.get("Name") == "TIME":
            t = vals[0]
            continue
        ncomp = int(da.get("NumberOfComponents", "1"))
        out[da.get("Name")] = vals.reshape((nc[2], nc[1], nc[0], ncomp)) if ncomp > 1 else vals.reshape(
            (nc[2], nc[1], nc[0]))
    return t, nc, out


def read_dumps(path):
    frames = []
    with open(path) as f:
        lines = f.readlines()
    i = 0
    while i < len(lines):
        step = int(lines[i + 1])
        n = int(lines[i + 3])
        cols = lines[i + 8].split()[2:]
        data = np.array([l.split() for l in lines[i + 9:i + 9 + n]], dtype=float)
        frames.append((step, dict(zip(cols, data.T))))
        i += 9 + n
    return frames


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tstart", type=float, default=0.3, help="start of the time average (s)")
    ap.add_argument("--dt", type=float, default=4e-6, help="DEM step of the run (s)")
    ap.add_argument("--out", default=".")
    a = ap.parse_args()

    vtis = sorted(glob.glob("gas_*.vti"), key=lambda p: int(re.findall(r"_(\d+)\.vti", p)[0]))
    gas = [read_vti(p) for p in vtis]
    frames = read_dumps("grains.dump")
    print(f"{len(gas)} gas files, {len(frames)} grain frames")

    # ---- snapshots -------------------------------------------------------------------------------
    tlast = frames[-1][0] * a.dt
    want = np.linspace(min(0.1, tlast), tlast, 4)
    fig, axs = plt.subplots(1, 8, figsize=(14, 6), sharey=True)
    for k, tw in enumerate(want):
        step, fr = min(frames, key=lambda f: abs(f[0] * a.dt - tw))
        ax = axs[2 * k]
        sc = ax.scatter(fr["x"] * 1e3, fr["z"] * 1e3, c=fr["vz"], s=1.0, cmap="coolwarm", vmin=-0.3, vmax=0.3)
        ax.set_title(f"t = {step * a.dt:.2f} s\ngrains, vz", fontsize=8)
        ax.set_xlim(0, LX * 1e3)
        ax.set_aspect("equal")
        tg, nc, f = min(gas, key=lambda g: abs(g[0] - step * a.dt))
        eps = f["voidage"].mean(axis=1)
        ax2 = axs[2 * k + 1]
        im = ax2.imshow(eps, origin="lower", extent=(0, LX * 1e3, 0, LZ * 1e3), cmap="viridis", vmin=0.35, vmax=1.0)
        ax2.set_title(f"t = {tg:.2f} s\nvoidage", fontsize=8)
        ax2.set_aspect("equal")
    axs[0].set_ylabel("z (mm)")
    axs[0].set_ylim(0, 120)
    fig.colorbar(sc, ax=axs[:2], orientation="horizontal", fraction=0.04, label="grain vz (m/s)")
    fig.colorbar(im, ax=axs[2:], orientation="horizontal", fraction=0.04, label="gas voidage (y-average)")
    fig.savefig(os.path.join(a.out, "bubbling_snapshots.png"), dpi=130)

    # ---- time-averaged profiles ------------------------------------------------------------------
    late = [g for g in gas if g[0] >= a.tstart]
    nc = gas[0][1]
    hz = LZ / nc[2]
    kz = int(0.0164 / hz)
    xc = (np.arange(nc[0]) + 0.5) * LX / nc[0]
    eps_prof = np.mean([g[2]["voidage"][kz].mean(axis=0) for g in late], axis=0) if late else None
    nb = 15
    edges = np.linspace(0, LX, nb + 1)
    vs, cnt = np.zeros(nb), np.zeros(nb)
    nfr = 0
    for step, fr in frames:
        if step * a.dt < a.tstart:
            continue
        nfr += 1
        sel = (fr["z"] > 0.010) & (fr["z"] < 0.020)
        idx = np.clip(np.digitize(fr["x"][sel], edges) - 1, 0, nb - 1)
        np.add.at(vs, idx, fr["vz"][sel])
        np.add.at(cnt, idx, 1)
    vz_prof = vs / np.maximum(cnt, 1)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    if eps_prof is not None:
        a1.plot(xc * 1e3, eps_prof, "o-")
    a1.set_xlabel("x (mm)")
    a1.set_ylabel("time-averaged voidage")
    a1.set_title(f"z = {(kz + 0.5) * hz * 1e3:.1f} mm (cell row of 16.4 mm), {len(late)} fields, t >= {a.tstart} s",
                 fontsize=9)
    xm = 0.5 * (edges[1:] + edges[:-1])
    a2.plot(xm * 1e3, vz_prof, "s-")
    a2.axhline(0, color="k", lw=0.5)
    a2.set_xlabel("x (mm)")
    a2.set_ylabel("time-averaged grain vz (m/s)")
    a2.set_title(f"grains in 10 < z < 20 mm, {nfr} frames, t >= {a.tstart} s", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "bubbling_profiles.png"), dpi=130)
    np.savetxt(os.path.join(a.out, "profiles.dat"),
               np.column_stack([xm, vz_prof, xc, eps_prof if eps_prof is not None else np.zeros(nc[0])]),
               header="x_bin(m) vz_grain(m/s) x_cell(m) voidage_z16.4mm")
    centre = vz_prof[nb // 3:2 * nb // 3].mean()
    wall = 0.5 * (vz_prof[:2].mean() + vz_prof[-2:].mean())
    print(f"time-averaged grain vz at 10-20 mm: centre third {centre:+.4f} m/s, two bins at each wall {wall:+.4f} m/s")

    # ---- pressure drop ---------------------------------------------------------------------------
    d = np.loadtxt("bed.dat")
    w = NGRAIN * RHOP * np.pi / 6 * DP ** 3 * G * (1 - 1.225 / RHOP) / (LX * LY)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(d[:, 0], d[:, 1] - 1.225 * G * (LZ - LZ / nc[2]), lw=0.8, label="gas: first - last cell layer, less gas weight")
    ax.axhline(w, color="k", ls="--", label=f"bed weight / area = {w:.1f} Pa")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("pressure drop (Pa)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "bubbling_dp.png"), dpi=130)
    late_dp = d[d[:, 0] >= a.tstart, 1] - 1.225 * G * (LZ - LZ / nc[2])
    if len(late_dp):
        print(f"mean pressure drop for t >= {a.tstart}: {late_dp.mean():.1f} Pa (bed weight/area {w:.1f} Pa)")


if __name__ == "__main__":
    main()
