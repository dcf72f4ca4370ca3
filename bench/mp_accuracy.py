#!/usr/bin/env python3
"""mp_accuracy.py - accuracy against cost of the multiphase fluid: velocity Verlet against
fourth-order Runge-Kutta, with and without the delta-plus terms (renormalised density diffusion and
particle shifting), at 20, 40 and 80 particles across the two-phase Poiseuille channel of Shi & Huang
§5.2 (mu_A/mu_B = 4, to the steady state at t = 5 s). Error: L2 against the steady two-layer solution
(paper eq. of §5.2); cost: wall-clock seconds per simulated second on the CPU backend.

  /usr/bin/python3 bench/mp_accuracy.py [--build build] [--out bench/out] [--threads 2]

Runs `verify_mp_poiseuille accuracy 5.0` (tests/verification/test_mp_poiseuille.c), which writes
mp_accuracy.csv; draws OUT/mp_accuracy.png (error against cost, one line per integrator and term set).
"""
import csv
import os
import subprocess

import benchlib


def main():
    ap = benchlib.parser(__doc__)
    ap.add_argument("--threads", default="2")
    ap.add_argument("--csv", help="plot an existing mp_accuracy.csv instead of running")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    path = a.csv
    if not path:
        exe = benchlib.test_exe(a.build, "verify_mp_poiseuille")
        subprocess.run([exe, "accuracy", "5.0"], cwd=a.out, check=True,
                       env=dict(os.environ, OMP_NUM_THREADS=a.threads))
        path = os.path.join(a.out, "mp_accuracy.csv")
    rows = list(csv.DictReader(open(path)))
    print("| integrator | terms | res | L2 error | wall s per simulated s |\n|---|---|---|---|---|")
    for r in rows:
        print("| %s | %s | %s | %.3f %% | %.2f |" % (r["integrator"], r["terms"], r["res"], 100 * float(r["l2"]),
                                                   float(r["wall_per_sim_s"])))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for integ, mk in [("verlet", "o"), ("rk4", "s")]:
        for terms, ls in [("plain", "-"), ("delta-plus", "--")]:
            rr = [r for r in rows if r["integrator"] == integ and r["terms"] == terms]
            if not rr:
                continue
            ax.loglog([float(r["wall_per_sim_s"]) for r in rr], [100 * float(r["l2"]) for r in rr], mk + ls,
                      label="%s, %s" % (integ, terms))
            for r in rr:
                ax.annotate(r["res"], (float(r["wall_per_sim_s"]), 100 * float(r["l2"])), fontsize=7,
                            xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("wall-clock s per simulated s (CPU backend)")
    ax.set_ylabel("L2 error of the steady profile (%)")
    ax.set_title("two-phase Poiseuille, $\\mu_A/\\mu_B$ = 4: accuracy against cost\n(labels: particles across)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = os.path.join(a.out, "mp_accuracy.png")
    fig.savefig(out, dpi=120)
    print("wrote", out)


if __name__ == "__main__":
    main()
