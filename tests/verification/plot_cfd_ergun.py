#!/usr/bin/env python3
"""plot_cfd_ergun.py - pressure drop vs superficial velocity: (a) fixed beds against the Ergun equation,
(b) the mobile-bed sweep against the Ergun line of the settled bed and the bed weight - buoyancy per area.
Reads cfd_ergun.csv written by verify_cfd_ergun (run it in its build dir), writes cfd_ergun.png.
Usage: plot_cfd_ergun.py [cfd_ergun.csv] [cfd_ergun.png]"""
import sys
import csv
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = sys.argv[1] if len(sys.argv) > 1 else "cfd_ergun.csv"
out = sys.argv[2] if len(sys.argv) > 2 else "cfd_ergun.png"
rows = list(csv.DictReader(open(src)))
fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 5))
cases = sorted({r["case"] for r in rows if r["case"].startswith("fixed")})
for k, c in enumerate(cases):
    rr = [r for r in rows if r["case"] == c]
    U = np.array([float(r["U"]) for r in rr])
    a1.plot(U, [float(r["dP_sim"]) for r in rr], "os^v"[k % 4], label="gas grid: " + c.replace("fixed", "bed ").replace("_", " cells, "))
    a1.plot(U, [float(r["dP_ref"]) for r in rr], "k-" if k % 2 == 0 else "k--", lw=0.8,
            label="Ergun" if k < 2 else None)
a1.set_xlabel("superficial velocity U (m/s)")
a1.set_ylabel("pressure drop over the bed (Pa)")
a1.set_title("(a) fixed beds, eps 0.40, d 1 mm (bound 5 %)")
a1.legend(fontsize=8)
rr = [r for r in rows if r["case"] == "mobile"]
if rr:
    U = np.array([float(r["U"]) for r in rr])
    dP = np.array([float(r["dP_sim"]) for r in rr])
    W = float(rr[0]["dP_ref"])
    a2.plot(U, dP, "o-", label="gas grid + DEM (stage means)")
    a2.axhline(W, color="k", ls="--", label="(weight - buoyancy) / area")
    a2.set_xlabel("superficial velocity U (m/s)")
    a2.set_ylabel("pressure drop over the bed (Pa)")
    a2.set_title("(b) mobile bed, U sweep")
    meta = [r for r in rows if r["case"] == "mobile_meta"]
    if meta:
        aE, bE, umf, umfE = (float(meta[0][k]) for k in ("U", "dP_sim", "dP_ref", "extra"))
        uu = np.linspace(0, U.max(), 100)
        a2.plot(uu, np.minimum(aE * uu + bE * uu * uu, W), "k:", lw=1, label="Ergun at eps_mf, capped at the bed weight")
        a2.axvline(umfE, color="r", lw=0.8, label="U_mf Ergun %.3f m/s" % umfE)
        a2.axvline(umf, color="g", lw=0.8, label="U_mf from the sweep %.3f m/s" % umf)
    a2.legend(fontsize=8)
fig.tight_layout()
fig.savefig(out, dpi=120)
print("wrote", out)
