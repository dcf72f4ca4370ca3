#!/usr/bin/python3
"""plot_dem_oblique.py - oblique sphere-plane impact (verify_dem_oblique): normalised rebound Psi2 of the
contact point vs normalised incidence Psi1 (Thornton's form of Maw, Barber & Fawcett 1976) for the
Hertz-Mindlin and LIGGGHTS hertz models, e = 1 and 0.7, beside the rigid-body gross-sliding line
Psi2 = Psi1 - 7, the analytic transitions Psi* and the no-slip (sticking) slope.
Usage: /usr/bin/python3 tests/verification/plot_dem_oblique.py [build-dir/tests/dem_oblique.csv] [out.png]"""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = sys.argv[1] if len(sys.argv) > 1 else "dem_oblique.csv"
out = sys.argv[2] if len(sys.argv) > 2 else "examples/dem_drop/dem_oblique.png"
series = {}
for r in csv.DictReader(open(src)):
    s = series.setdefault((r["model"], float(r["en_set"])), {"p1": [], "p2": [], "jt": []})
    s["p1"].append(float(r["psi1"]))
    s["p2"].append(float(r["psi2"]))
    s["jt"].append(float(r["jt_ratio"]))
nu = 0.3
k = 2 * (1 - nu) / (2 - nu)
pstar = {"hertz_mindlin": 7 - 1 / k, "liggghts_hertz": 7 - 2 / (3 * k)}
noslip = 0.9548  # printed by verify_dem_oblique (RK4 no-slip limit for k = 0.8235)
fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.5))
style = {("hertz_mindlin", 1.0): "o-", ("liggghts_hertz", 1.0): "s-", ("hertz_mindlin", 0.7): "o--",
         ("liggghts_hertz", 0.7): "s--"}
for key, s in sorted(series.items()):
    pts = [(a, b, c) for a, b, c in zip(s["p1"], s["p2"], s["jt"]) if a <= 12]
    lab = "%s, e = %g" % key
    col = "C0" if key[0] == "hertz_mindlin" else "C3"
    ax.plot([p[0] for p in pts], [p[1] for p in pts], style.get(key, "-"), color=col, ms=3, lw=1, label=lab)
    bx.plot([p[0] for p in pts], [p[2] for p in pts], style.get(key, "-"), color=col, ms=3, lw=1, label=lab)
ax.plot([0, 12], [-7, 5], "k:", lw=1.5, label="gross sliding (rigid body): Psi2 = Psi1 - 7")
ax.plot([0, 2], [0, 2 * noslip], "k-.", lw=1, label="no-slip limit Psi2 = %.3f Psi1" % noslip)
for m, c in (("hertz_mindlin", "C0"), ("liggghts_hertz", "C3")):
    ax.axvline(pstar[m], color=c, lw=0.8, alpha=0.6)
    bx.axvline(pstar[m], color=c, lw=0.8, alpha=0.6, label="Psi* %s = %.2f" % (m, pstar[m]))
ax.axhline(0, color="grey", lw=0.5)
ax.set_xlabel("Psi1 = 2 w_in / (mu (1+e) v_n)")
ax.set_ylabel("Psi2 = 2 w_out / (mu (1+e) v_n)")
ax.set_title("contact-point rebound (nu = 0.3, mu = 0.3, solid sphere)")
ax.legend(fontsize=7)
ax.grid(alpha=0.3)
bx.set_xlabel("Psi1")
bx.set_ylabel("J_t / (mu J_n)")
bx.set_title("tangential impulse (1 = sliding throughout)")
bx.legend(fontsize=7)
bx.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(out, dpi=110)
print("wrote", out)
