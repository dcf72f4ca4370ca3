#!/usr/bin/python3
"""Normal damping of LAMMPS' pair_style gran/hertz/history for a restitution coefficient e.

LAMMPS' Hertz law: m* d'' = -sqrt(R* d) (Kn d + m* gamma_n d'). With d = d0 u, t = (d0/v) s and
d0 = (m* v^2 / (Kn sqrt(R*)))^(2/5) it becomes u'' = -u^(3/2) - zeta u^(1/2) u', u(0) = 0, u'(0) = 1,
zeta = gamma_n sqrt(R* d0) d0 / v, so e depends on zeta alone (and, through zeta, weakly on the impact
speed v: zeta ~ v^(1/5) at fixed gamma_n). This script finds zeta for e (in.drum uses 0.09225 for
e = 0.9) and prints e at other impact speeds for the gamma_n that in.drum derives at vimp.

Usage: /usr/bin/python3 lammps_damping.py [e] [dg] [vimp]
"""
import math
import sys


def restitution(zeta, ds=2e-4):
    u, v, s = 0.0, 1.0, 0.0

    def acc(u, v):
        u = max(u, 0.0)
        return -u ** 1.5 - zeta * math.sqrt(u) * v

    while True:
        k1u, k1v = v, acc(u, v)
        k2u, k2v = v + 0.5 * ds * k1v, acc(u + 0.5 * ds * k1u, v + 0.5 * ds * k1v)
        k3u, k3v = v + 0.5 * ds * k2v, acc(u + 0.5 * ds * k2u, v + 0.5 * ds * k2v)
        k4u, k4v = v + ds * k3v, acc(u + ds * k3u, v + ds * k3v)
        un = u + ds / 6 * (k1u + 2 * k2u + 2 * k3u + k4u)
        vn = v + ds / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        s += ds
        if un < 0.0 and s > 0.1:
            return -vn
        u, v = un, vn


def zeta_for(e):
    lo, hi = 0.0, 5.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if restitution(mid) > e:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def main():
    e = float(sys.argv[1]) if len(sys.argv) > 1 else 0.9
    dg = float(sys.argv[2]) if len(sys.argv) > 2 else 0.0027
    vimp = float(sys.argv[3]) if len(sys.argv) > 3 else 0.5
    E, nu, rho = 1e8, 0.3, 2500.0
    z = zeta_for(e)
    print("e = %.3f  ->  zeta = %.5f" % (e, z))
    Kn = 4.0 / 3.0 * E / (2 * (1 - nu ** 2))
    Rs = dg / 4
    ms = rho * math.pi / 6 * dg ** 3 / 2

    def d0(v):
        return (ms * v * v / (Kn * math.sqrt(Rs))) ** 0.4

    gn = z * vimp / (d0(vimp) * math.sqrt(Rs * d0(vimp)))
    print("grain-grain, d = %g m, Kn = %.6g Pa, gamma_n = %.6g 1/(m s) (e = %.2f at %.2f m/s)" % (dg, Kn, gn, e, vimp))
    for v in (0.05, 0.1, 0.2, 0.5, 1.0, 2.0):
        zz = gn * math.sqrt(Rs * d0(v)) * d0(v) / v
        print("  impact speed %5.2f m/s: e = %.3f" % (v, restitution(zz)))


if __name__ == "__main__":
    main()
