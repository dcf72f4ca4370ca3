#!/usr/bin/python3
"""plot_dem_oblique.py - oblique sphere-plane impact (verify_dem_oblique): normalised rebound Psi2 of the
contact point vs normalised incidence Psi1 (Thornton's form of Maw, Barber & Fawcett 1976) for the
Hertz-Mindlin and LIGGGHTS hertz models, e = 1 and 0.7, beside the rigid-body gross-sliding line
Psi2 = Psi1 - 7, the analytic transitions Psi* and the no-slip (sticking) slope.
Usage: /usr/bin/python3 tests/verification/plot_dem_oblique.py [build-dir/tests/dem_oblique.csv] [out.png]"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import plotlib  # noqa: E402

plt, rows, out = plotlib.csv_plot("dem_oblique.csv", "examples/dem_drop/dem_oblique.png")
series = {}
for r in rows:
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
plotlib.axes(ax, "Psi1 = 2 w_in / (mu (1+e) v_n)", "Psi2 = 2 w_out / (mu (1+e) v_n)",
             "contact-point rebound (nu = 0.3, mu = 0.3, solid sphere)", fontsize=7)
plotlib.axes(bx, "Psi1", "J_t / (mu J_n)", "tangential impulse (1 = sliding throughout)", fontsize=7)
plotlib.save(fig, out, dpi=110)
