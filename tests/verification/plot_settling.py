#!/usr/bin/python3
"""plot_settling.py - settling velocity of one sphere: SPH-DEM (verify_settling) vs the Schiller-Naumann ODE
(closed form of data/reference/closed_forms.md, "Single sphere settling").
Usage: /usr/bin/python3 tests/verification/plot_settling.py [build-dir/tests/settling_v.csv] [out.png]"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import plotlib  # noqa: E402

plt, rows, out = plotlib.csv_plot("settling_v.csv", "settling.png")
cases = {}
for r in rows:
    c = cases.setdefault(int(r["case"]), {"d": float(r["d"]), "rho": float(r["rho_p"]), "t": [], "v": [], "ode": [], "u": []})
    c["t"].append(1e3 * float(r["t"]))
    c["v"].append(1e3 * float(r["v_sim"]))
    c["ode"].append(1e3 * float(r["v_ode"]))
    c["u"].append(1e3 * float(r["u_fluid"]))
fig, ax = plt.subplots(figsize=(7, 4.5))
for k, c in sorted(cases.items()):
    lab = "d = %.1f mm, rho_p/rho_f = %.1f" % (1e3 * c["d"], c["rho"] / 1000)
    line, = ax.plot(c["t"], c["v"], "-", lw=2, label=lab + " (SPH-DEM)")
    ax.plot(c["t"], c["ode"], "--", color=line.get_color(), lw=1, label="Schiller-Naumann ODE")
    ax.plot(c["t"], c["u"], ":", color=line.get_color(), lw=1)
plotlib.axes(ax, "t after release (ms)", "settling velocity (mm/s)",
             "Single sphere settling in water (dotted: fluid velocity at the grain)", fontsize=7, ncol=2)
plotlib.save(fig, out)
