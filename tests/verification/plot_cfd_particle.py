#!/usr/bin/env python3
"""plot_cfd_particle.py - v(t) of one grain in an upward gas flow (Yu 2024 §3.3): simulation (gas grid,
three model options) vs the ODE of eqs 20-22, and the relative error. Reads cfd_particle.csv written by
verify_cfd_particle (run it in its build dir), writes cfd_particle.png.
Usage: plot_cfd_particle.py [cfd_particle.csv] [cfd_particle.png]"""
import sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = sys.argv[1] if len(sys.argv) > 1 else "cfd_particle.csv"
out = sys.argv[2] if len(sys.argv) > 2 else "cfd_particle.png"
d = np.genfromtxt(src, delimiter=",", names=True)
t, vo = d["t"], d["v_ode"]
cases = [n for n in d.dtype.names if n.startswith("v_") and n != "v_ode"]
fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
a1.plot(t, vo, "k-", lw=2.5, label="ODE eqs 20-22 (RK4)")
for n, st in zip(cases, ["--", ":", "-."]):
    a1.plot(t, d[n], st, lw=1.5, label="gas grid: " + n[2:].replace("_", ", "))
a1.set_ylabel("grain velocity v_z (m/s)")
a1.set_title("One grain (d 0.1 mm, rho 2000) in 0.5 m/s upward gas flow")
a1.legend()
m = t > 0.05
for n, st in zip(cases, ["--", ":", "-."]):
    a2.plot(t[m], 100 * np.abs(d[n][m] - vo[m]) / np.abs(vo[m]), st, label=n[2:])
a2.axhline(1.25, color="r", lw=1, label="bound 1.25 %")
a2.set_xlabel("t (s)")
a2.set_ylabel("|v - v_ode| / |v_ode| (%)")
a2.legend()
fig.tight_layout()
fig.savefig(out, dpi=120)
print("wrote", out)
