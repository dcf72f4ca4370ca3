#!/usr/bin/env python3
"""test_fluid_model.py - engine tests of the delta-plus terms of fix sph/fluid for one fluid (no phase keyword).

  taylor_green EXE ENGINE RES  examples/taylor_green (2D periodic, Re = 100, shifting yes diffusion renorm 0.1,
                               visc morris, no phase) at RES particles along L: the kinetic energy's decay rate,
                               fitted from t = 0 until KE has fallen to 30 %, within 5 % of 16 pi^2 nu / L^2
  badkw        EXE ENGINE      the delta-plus keywords without phase refuse visc artificial, delta, tensile and
                               fix sph/couple, each with a message that says why
Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "examples", "taylor_green"))
import engine_test as E  # noqa: E402  (the shared helpers)
import check as TG  # noqa: E402  (examples/taylor_green/check.py: the log reader and the fit)

NU, L, FLOOR, BOUND = 0.01, 1.0, 0.3, 0.05


def test_taylor_green(exe, engine, res):
    wd = os.path.abspath("taylor_green_%s_%s" % (engine, res))
    with open(os.path.join(ROOT, "examples", "taylor_green", "in.taylor_green")) as f:
        text = f.read()
    # no dumps in the test (the example writes them for ParaView)
    text = "\n".join(l for l in text.splitlines() if not l.startswith("dump "))
    rc, out = E.run([exe, "-var", "res", str(res), "-var", "tend", "0.8"], wd, text, timeout=1500,
                    env_extra={"OMP_WAIT_POLICY": "passive"})
    if rc != 0:
        print("FAIL: the example exited %d:\n%s" % (rc, out[-3000:]))
        return 1
    rows = TG.thermo(os.path.join(wd, "log.test"))
    exact = 16.0 * 3.141592653589793 ** 2 * NU / L ** 2
    rate, n, tlast, reached = TG.decay_rate(rows, FLOOR)
    err = rate / exact - 1.0
    ok = reached and abs(err) <= BOUND
    print("%s Taylor-Green vortex through %s at %s particles along L: decay rate %.4f, exact %.4f, error %+.2f %% "
          "(bound %.0f %%; %d samples to t = %.3f s, KE fell to %.3f)" %
          ("PASS" if ok else "FAIL", engine, res, rate, exact, 100 * err, 100 * BOUND, n, tlast,
           rows[-1][1] / rows[0][1]))
    return 0 if ok else 1


BAD_HEAD = """dimension 2
units si
atom_style sphere
boundary p p p
atom_modify map array sort 0 0.0
lattice sq 0.05 origin 0.5 0.5 0.0
region box block 0 1 0 1 -0.025 0.025 units box
create_box 2 box
create_atoms 1 region box
group fluid type 1
set group all diameter 0.05
set group all mass 0.0025
timestep 1e-4
pair_style none
neighbor 0.05 nsq
"""
FLUID = "fix f fluid sph/fluid rho0 1.0 h 0.075 c0 10 "


def test_badkw(exe, engine):
    cases = [
        ("visc artificial with shifting", FLUID + "visc artificial 0.1 shifting yes\nrun 1\n",
         "visc artificial is not defined with the delta-plus terms"),
        ("delta with diffusion", FLUID + "visc morris 0.01 delta 0.1 diffusion renorm 0.1\nrun 1\n",
         "are two density-diffusion terms; give one"),
        ("tensile with shifting", FLUID + "visc morris 0.01 tensile 0.2 shifting yes\nrun 1\n",
         "are two cures for tensile instability"),
        ("shifting with fix sph/couple",
         "create_atoms 2 single 0.5 0.5 0\ngroup grains type 2\nset group grains diameter 0.02\n" + FLUID +
         "visc morris 0.01 shifting yes\nfix c grains sph/couple f\nfix g grains nve/sphere\nrun 1\n",
         "the delta-plus terms (shifting, diffusion, les, eos, p0) are not defined for the coupled fluid"),
    ]
    fails = 0
    for what, body, want in cases:
        wd = os.path.abspath("fluid_model_badkw_" + engine)
        if not E.refused(exe, wd, "%s (%s)" % (what, engine), BAD_HEAD + body, want, crash_codes=[134, 139]):
            fails += 1
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(E.dispatch(sys.argv, globals(), __doc__))
