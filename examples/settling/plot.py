#!/usr/bin/env python3
"""plot.py - settling velocity of one sphere (in.settling) vs the Schiller-Naumann ODE.

Reads settling.dat (written by 'fix print' in in.settling: step t z vz Fz_fluid Fz_drag Fz_pressure
eps_min Fz_grains Fz_net) of one or more runs, integrates the single-sphere ODE of
data/reference/closed_forms.md ("Single sphere settling"),
    dv/dt = g (rho_p - rho_f)/rho_p - 3/4 rho_f |v| v C_D / (d rho_p),  C_D = 24/Re (1 + 0.15 Re^0.687),
with RK4 (dt 1e-6 s), writes settling.png (v(t) and the force split) and prints the terminal velocity,
the velocity error at a few times and the largest |Fz_net| / |Fz_grains| (momentum balance).

  python3 plot.py                                   # settling.dat in the current directory
  python3 plot.py run_lmp/settling.dat run_lig/settling.dat --labels LAMMPS LIGGGHTS -o settling.png

Parameters default to those of in.settling (d 1 mm, rho_p 2500, water rho_f 1000, mu 8.9e-4).
Needs numpy and matplotlib (/usr/bin/python3 on Debian).
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import plotlib  # noqa: E402


def ode(d, rhop, rhof, mu, g, tend, dt=1e-6):
    """RK4 of the Schiller-Naumann ODE for the downward speed v >= 0 (C_D = 0.44 above Re 1000)."""
    def acc(v):
        w = abs(v)
        re = rhof * d * w / mu
        if re < 1e-300:
            cdw = 24.0 * mu / (rhof * d)
        elif re <= 1000.0:
            cdw = 24.0 * (1.0 + 0.15 * re ** 0.687) * mu / (rhof * d)
        else:
            cdw = 0.44 * w
        return g * (rhop - rhof) / rhop - 0.75 * rhof * v * cdw / (d * rhop)
    n = int(round(tend / dt))
    t = np.empty(n + 1)
    v = np.empty(n + 1)
    t[0], v[0] = 0.0, 0.0
    for i in range(n):
        y = v[i]
        k1 = acc(y)
        k2 = acc(y + 0.5 * dt * k1)
        k3 = acc(y + 0.5 * dt * k2)
        k4 = acc(y + dt * k3)
        v[i + 1] = y + dt * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
        t[i + 1] = t[i] + dt
    return t, v


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*", default=["settling.dat"])
    ap.add_argument("--labels", nargs="*")
    ap.add_argument("-o", "--output", default="settling.png")
    ap.add_argument("--d", type=float, default=0.001)
    ap.add_argument("--rhop", type=float, default=2500.0)
    ap.add_argument("--rhof", type=float, default=1000.0)
    ap.add_argument("--mu", type=float, default=8.9e-4)
    ap.add_argument("--g", type=float, default=9.81)
    args = ap.parse_args()
    labels = args.labels or args.files
    runs = []
    for path in args.files:
        a = np.loadtxt(path, comments="#", ndmin=2)
        if a.shape[1] < 10:
            sys.exit("%s: expected 10 columns, found %d" % (path, a.shape[1]))
        runs.append(a)
    tend = max(a[-1, 1] for a in runs)
    t_ode, v_ode = ode(args.d, args.rhop, args.rhof, args.mu, args.g, tend)
    vt = v_ode[-1]
    print("Schiller-Naumann ODE: v(%.3f s) = %.5f m/s (Re %.1f)" % (tend, vt, args.rhof * args.d * vt / args.mu))

    plt = plotlib.pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(t_ode, v_ode, "k-", lw=2, label="Schiller-Naumann ODE")
    for a, lab in zip(runs, labels):
        t, v = a[:, 1], -a[:, 3]
        ax1.plot(t, v, "--", label=lab)
        vi = np.interp(t, t_ode, v_ode)
        for tq in (0.02, 0.05, 0.1, 0.15, 0.2, 0.25):
            if tq <= t[-1] + 1e-12:
                k = int(np.argmin(abs(t - tq)))
                print("%-10s t = %.3f s: v = %.5f m/s, ODE %.5f, error %+.2f%%" %
                      (lab, t[k], v[k], vi[k], 100 * (v[k] - vi[k]) / vi[k]))
        late = t >= 0.5 * t[-1]
        print("%-10s mean |v - ODE| / v_ODE over t >= %.3f s: %.2f%%" %
              (lab, 0.5 * t[-1], 100 * np.mean(abs(v[late] - vi[late]) / vi[late])))
        ratio = np.max(abs(a[:, 9])) / np.max(abs(a[:, 8]))
        print("%-10s max |Fz_net| / max |Fz_grains| = %.2e; min porosity %.4f" % (lab, ratio, a[:, 7].min()))
        if a is runs[0]:  # the force split of the first run
            ax2.plot(t, a[:, 5] * 1e6, label="drag (%s)" % lab)
            ax2.plot(t, a[:, 6] * 1e6, label="pressure gradient (%s)" % lab)
    w_net = (args.rhop - args.rhof) * np.pi / 6 * args.d ** 3 * args.g
    ax2.axhline(args.rhof * np.pi / 6 * args.d ** 3 * args.g * 1e6, color="k", lw=0.8, ls=":",
                label="buoyancy rho_f V g")
    ax2.axhline(w_net * 1e6, color="k", lw=0.8, ls="--", label="weight - buoyancy")
    plotlib.axes(ax1, "t (s)", "settling speed (m/s)",
                 "sphere d = %g mm, rho_p = %g kg/m^3 in water" % (args.d * 1e3, args.rhop))
    plotlib.axes(ax2, "t (s)", "upward fluid force on the sphere (uN)", fontsize=7)
    plotlib.save(fig, args.output)


if __name__ == "__main__":
    main()
