#!/usr/bin/env python3
"""mp_stability.py - where the multiphase methods fail: the stability matrix of the multiphase fluid.

Runs the two-layer static tank and a multiphase dam break (tests/verification/test_static_tank.c,
`verify_static_tank`, 2D, dx = 0.04 m, to t = 0.5 s) over
  density diffusion  none | renormalised (Shi & Huang eqs 16-19)
  particle shifting  off | on (eqs 27-29)
  EOS                linear (eq 4) | Tait (per phase)
  density ratio      1:2 (mud/water, the paper's Table 1) | 1:1000 (water/air-like)
  time step          0.5x | 2x the stable limit of the fix (CFL 0.25 h/(c0 + vmax), viscous, force)
  sound speed        one c0 = 10 sqrt(p_max / rho_light) | each phase its own 10 sqrt(p_max / rho_k)
                     (the second only at 1:1000; at 1:2 the two are close)
and records for each: stable or not (and the core's stop message), pressure noise (rms of particle
pressure minus the kernel average at its position, / rho g H), particle disorder (coefficient of
variation of the nearest-neighbour distance), interface crossings (tank). c0 = 10 sqrt(p_max / rho_light).

  /usr/bin/python3 bench/mp_stability.py [--build build] [--out bench/out]

Writes OUT/mp_stability.csv, OUT/mp_stability.md (the table) and OUT/mp_stability.png (chart).
"""
import itertools
import os
import subprocess

import benchlib


def run(exe, args, wd):
    p = subprocess.run([exe] + args, cwd=wd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       env=dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "2")), timeout=3600)
    out = p.stdout.decode(errors="replace")
    line = next((l for l in out.splitlines() if l.startswith("RESULT")), None)
    if line is None:
        return {"stable": "0", "reason": "driver failed: " + out[-200:].replace("\n", " ")}
    import re
    # values may contain spaces (the stop reason): a value runs to the next " key="
    return dict(re.findall(r"(\w+)=(.*?)(?= \w+=|$)", line[len("RESULT "):]))


def main():
    ap = benchlib.parser(__doc__)
    ap.add_argument("--tend", default="0.5")
    ap.add_argument("--dx", default="0.04")
    a = ap.parse_args()
    exe = benchlib.test_exe(a.build, "verify_static_tank")
    os.makedirs(a.out, exist_ok=True)
    wd = os.path.abspath(os.path.join(a.out, "mp_stability_runs"))
    os.makedirs(wd, exist_ok=True)
    rows = []
    combos = [c for c in itertools.product(["tank", "dambreak"], ["2", "1000"], ["single", "phase"],
                                           ["none", "renorm"], ["0", "1"], ["linear", "tait"], ["0.5", "2"])
              if c[2] == "single" or c[1] == "1000"]
    for scene, ratio, c0, diff, shift, eos, dtf in combos:
        args = ["scene=" + scene, "ratio=" + ratio, "c0=" + c0, "diffusion=" + diff, "shifting=" + shift,
                "eos=" + eos, "dtfac=" + dtf, "dx=" + a.dx, "tend=" + a.tend, "check=0",
                "out=%s_%s_%s_%s_%s_%s_%s" % (scene, ratio, c0, diff, shift, eos, dtf)]
        r = run(exe, args, wd)
        row = dict(scene=scene, ratio="1:" + ratio if ratio != "2" else "1:2", c0=c0, diffusion=diff,
                   shifting="on" if shift == "1" else "off", eos=eos, dt=dtf + "x", **r)
        rows.append(row)
        print("%-8s %-6s c0 %-6s diff %-6s shift %-3s %-6s dt %-4s -> %s" % (scene, row["ratio"], c0, diff,
              row["shifting"], eos,
              row["dt"], "stable" if r.get("stable") == "1" else "STOPS (%s at t = %s)" %
              (r.get("reason", "?"), r.get("t", "?"))), flush=True)
    keys = ["scene", "ratio", "c0", "diffusion", "shifting", "eos", "dt", "stable", "reason", "t", "noise", "disorder",
            "crossings", "vrms"]
    with open(os.path.join(a.out, "mp_stability.csv"), "w") as f:
        f.write(",".join(keys) + "\n")
        for r in rows:
            f.write(",".join(str(r.get(k, "")).replace(",", ";") for k in keys) + "\n")
    with open(os.path.join(a.out, "mp_stability.md"), "w") as f:
        f.write("| scene | ratio | c0 | diffusion | shifting | EOS | dt | result | pressure noise | disorder | "
                "crossings | v rms (m/s) |\n|" + "---|" * 12 + "\n")
        for r in rows:
            ok = r.get("stable") == "1"
            res = "stable to %s s" % r.get("t") if ok else "stops at t = %s s: %s" % (r.get("t"), r.get("reason"))
            f.write("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n" % (
                r["scene"], r["ratio"], r["c0"], r["diffusion"], r["shifting"], r["eos"], r["dt"], res,
                r.get("noise", "-") if ok else "-", r.get("disorder", "-") if ok else "-",
                r.get("crossings", "-") if ok and r["scene"] == "tank" else "-", r.get("vrms", "-") if ok else "-"))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
    except ImportError:
        print("no matplotlib: table only")
        return
    cols = [(s, q, c, d) for s in ["tank", "dambreak"] for q, c in [("1:2", "single"), ("1:1000", "single"),
                                                                    ("1:1000", "phase")] for d in ["0.5x", "2x"]]
    rlab = [(df, sh, e) for df in ["none", "renorm"] for sh in ["off", "on"] for e in ["linear", "tait"]]
    M = np.full((len(rlab), len(cols)), np.nan)
    for r in rows:
        i = rlab.index((r["diffusion"], r["shifting"], r["eos"]))
        j = cols.index((r["scene"], r["ratio"], r["c0"], r["dt"]))
        M[i, j] = float(r["noise"]) if r.get("stable") == "1" else -1
    fig, ax = plt.subplots(figsize=(13, 4.8))
    shown = np.where(M < 0, np.nan, M)
    im = ax.imshow(np.log10(np.maximum(shown, 1e-5)), cmap="viridis", aspect="auto")
    for i in range(M.shape[0]):
        for j in range(M.shape[1]):
            ax.text(j, i, "STOP" if M[i, j] < 0 else "%.1e" % M[i, j], ha="center", va="center", fontsize=7,
                    color="red" if M[i, j] < 0 else "white")
    ax.set_xticks(range(len(cols)))
    ax.set_xticklabels(["%s %s\nc0 %s\ndt %s" % c for c in cols], fontsize=7)
    ax.set_yticks(range(len(rlab)))
    ax.set_yticklabels(["diff %s, shift %s, %s" % r for r in rlab], fontsize=7)
    fig.colorbar(im, label="log10 pressure noise (rms / rho g H)")
    ax.set_title("multiphase delta-plus SPH: stability and pressure noise (t = %s s, dx = %s m)" % (a.tend, a.dx))
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "mp_stability.png"), dpi=120)
    print("wrote", os.path.join(a.out, "mp_stability.png"))


if __name__ == "__main__":
    main()
