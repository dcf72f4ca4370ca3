#!/usr/bin/env python3
"""test_mp_engine.py - engine tests of the multiphase keywords of fix sph/fluid (Shi & Huang 2022).

  badkw      EXE ENGINE  bad multiphase input stops with a message naming the keyword and the choices
  restart    EXE ENGINE  two-layer tank (HB mud under water, shifting, renormalised diffusion): 200 steps ==
                         100 + write_restart + read_restart + 100 (x, v, rho to 1e-9), phases from atom types
  poiseuille EXE ENGINE  examples/poiseuille2phase at 20 particles across, mu_A/mu_B = 4, to t = 5 s:
                         L2 error against the two-layer steady solution below 2 % (the core test measures 1.16 %)
  same       LMP LIG     the two-layer tank for 200 steps: LAMMPS and LIGGGHTS dumps equal to 1e-10
Python 3 only; exits 0 on pass, 1 on failure.
"""
import glob
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import engine_test as E  # noqa: E402  (the shared helpers)
from engine_test import compare_cols, must_run, read_dump, refused, run, split_run, verdict  # noqa: E402

ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
DUMPFMT = {"lammps": "dump_modify d sort id format float %.17g",
           "liggghts": 'dump_modify d sort id format "%d' + " %.17g" * 5 + '"'}

HEAD = """dimension 2
units si
atom_style sphere
boundary f f p
atom_modify map array sort 0 0.0
lattice sq 0.04 origin 0.5 0.5 0.0
region box block -0.2 1.0 -0.2 1.2 -0.04 0.04 units box
create_box 3 box
region la block 0 0.8 0 0.4 -0.02 0.02 units box
region lb block 0 0.8 0.4 0.8 -0.02 0.02 units box
region wb block -0.12 0.92 -0.12 0 -0.02 0.02 units box
region wl block -0.12 0 0 1.0 -0.02 0.02 units box
region wr block 0.8 0.92 0 1.0 -0.02 0.02 units box
create_atoms 1 region la
create_atoms 2 region lb
create_atoms 3 region wb
create_atoms 3 region wl
create_atoms 3 region wr
group fluid type 1 2
group walls type 3
set group all diameter 0.04
set type 1 mass 3.2
set type 2 mass 1.6
set type 3 mass 1.6
"""
SETUP = """timestep 2.5e-4
pair_style none
neighbor 0.04 nsq
neigh_modify every 20 delay 0 check no
"""
FIX = ("fix tank fluid sph/fluid rho0 1000 h 0.06 c0 35 gravity 0 -9.8 0 wall walls "
       "phase 1 2000 hb 10 100 0.8 1.0 phase 2 1000 newtonian 0.001 diffusion renorm 0.1 shifting yes "
       "hydrostatic 0.8 {extra}\n")
THERMO = "thermo_style custom step f_tank[1] f_tank[2] f_tank[3]\nthermo 50\n"
DUMP = "dump d fluid custom {every} final.* id x y vx vy f_tank[1]\n{fmt}\n"
STEPS = 200


def scene(engine, extra="", steps=STEPS):
    return (HEAD + SETUP + FIX.format(extra=extra) + THERMO + DUMP.format(every=STEPS, fmt=DUMPFMT[engine]) +
            "run %d\n" % steps)


def final(wd):
    return read_dump(os.path.join(wd, "final.%d" % STEPS))


def moved(rows):
    return max(abs(r[2]) + abs(r[3]) for r in rows.values()) > 0


def test_badkw(exe, engine):
    base = scene(engine, steps=1)
    fixline = FIX.format(extra="")
    cases = [
        (fixline.replace("hb 10 100 0.8 1.0", "hb 10 100 0.8 0"),
         "phase 1: a yield stress or a flow index N < 1 makes the viscosity infinite at rest; give a cut-off"),
        (fixline.replace("hb 10 100 0.8 1.0", "bingham 10"),
         "phase rheology must be newtonian MU or hb TAU_Y K N GDOT_CUT (got 'bingham')"),
        (fixline.replace("phase 1 2000", "phase 7 2000"), "phase TYPE must be an atom type 1..3, got '7'"),
        (fixline.replace("phase 2 1000", "phase 1 1000"), "atom type 1 is given two phase keywords"),
        (fixline.replace(" phase 2 1000 newtonian 0.001", ""),
         "has type 2, which no phase keyword names (phase TYPE RHO0 ...)"),
        (fixline.replace("diffusion renorm", "diffusion fancy"), "diffusion must be none, molteni or renorm (got 'fancy')"),
        (fixline.replace("shifting yes", "shifting maybe"), "shifting must be yes or no (got 'maybe')"),
        (fixline.replace("wall walls", "wall walls visc morris 1e-3"),
         "the multiphase viscous term (eq 24, phase rheology) replaces visc morris/artificial; set visc none"),
        (fixline.replace(" phase 1 2000 hb 10 100 0.8 1.0 phase 2 1000 newtonian 0.001", " visc artificial 0.1"),
         "visc artificial is not defined with the delta-plus terms"),
        (fixline.replace("wall walls", "wall walls ghost box 0 1 0 1"),
         "ghost must be followed by mirror and the fluid box (usage: ghost mirror XLO XHI YLO YHI)"),
        (fixline.replace("wall walls", "wall walls ghost mirror -1 1 -1 1.1"), "lies inside the fluid box; mirror ghosts"),
        (fixline + "", None),  # placeholder replaced below
    ]
    cases[-1] = (fixline.replace("diffusion renorm 0.1", "eos ideal"), "eos must be tait or linear (got 'ideal')")
    fails = sum(not refused(exe, "mp_badkw_%s/%d" % (engine, i), "case %d" % i, base.replace(fixline, line), want,
                            crash_codes=(134, 136, 139)) for i, (line, want) in enumerate(cases))
    return 1 if fails else 0


def test_restart(exe, engine):
    first = HEAD + SETUP + FIX.format(extra="") + THERMO + "run %d\nwrite_restart half.restart\n" % (STEPS // 2)
    # LIGGGHTS forgets the sort settings in a restart (bin size 0 with pair none)
    second = ("read_restart half.restart\natom_modify sort 0 0.0\n" + SETUP + FIX.format(extra="") + THERMO +
              DUMP.format(every=STEPS, fmt=DUMPFMT[engine]) + "run %d\n" % (STEPS // 2))
    ab = split_run(exe, "mp_restart_" + engine, scene(engine), first, second, final, moved)
    if ab is None:
        return 1
    a, b = ab
    return verdict(compare_cols(a, b, ["x", "y", "vx", "vy", "rho"]), 1e-9,
                   "restart at step %d vs unbroken (%s)" % (STEPS // 2, engine))


def test_same(lmp, lig):
    must_run([lmp], "mp_same/lammps", scene("lammps"))
    must_run([lig], "mp_same/liggghts", scene("liggghts"))
    a, b = final("mp_same/lammps"), final("mp_same/liggghts")
    if not moved(a):
        print("FAIL: the fluid did not move")
        return 1
    return verdict(compare_cols(a, b, ["x", "y", "vx", "vy", "rho"]), 1e-10, "LAMMPS vs LIGGGHTS (two-layer tank)")


def steady_two_newtonian(y, mu_a=1.0, mu_b=0.25, G=2.0, H=2.0, a=1.0):
    """two-layer plane Poiseuille, data/reference/closed_forms.md closed form (layer 1 mu_a on 0 <= y <= a)"""
    tau0 = G * (a * a / mu_a + (H * H - a * a) / mu_b) / (2 * (a / mu_a + (H - a) / mu_b))
    if y <= a:
        return (tau0 * y - G * y * y / 2) / mu_a
    return (tau0 * (y - H) - G * (y * y - H * H) / 2) / mu_b


def test_poiseuille(exe, engine):
    wd = os.path.abspath("mp_poiseuille_" + engine)
    os.makedirs(wd, exist_ok=True)
    for f in glob.glob(os.path.join(wd, "dump.poiseuille.*")):
        os.remove(f)
    with open(os.path.join(ROOT, "examples", "poiseuille2phase", "in.poiseuille2phase")) as f:
        text = f.read()
    fails = 0
    # Adami walls, then the fixed ghost walls (MLS at the mirror points across y = 0 and y = 2)
    for label, extra in [("Adami walls", []), ("MLS ghost walls", ["-var", "integ", "ghost mirror -1 2 0 2"])]:
        for f in glob.glob(os.path.join(wd, "dump.poiseuille.*")):
            os.remove(f)
        rc, out = run([exe, "-var", "res", "20", "-var", "tend", "5.0"] + extra, wd, text, timeout=600)
        if rc != 0:
            print("FAIL: the example exited %d:\n%s" % (rc, out[-3000:]))
            return 1
        dumps = sorted(glob.glob(os.path.join(wd, "dump.poiseuille.*")), key=lambda p: int(p.rsplit(".", 1)[1]))
        rows = read_dump(dumps[-1])  # id -> [type, x, y, vx, vy, rho, mu]
        fl = [r for r in rows.values() if r[0] < 3]
        num = sum((r[3] - steady_two_newtonian(r[2])) ** 2 for r in fl)
        den = sum(steady_two_newtonian(r[2]) ** 2 for r in fl)
        e = (num / den) ** 0.5
        ok = e < 0.02
        fails += 0 if ok else 1
        print("%s two-phase Poiseuille through %s, %s: %d particles, L2 error %.3f %% (bound 2 %%)" %
              ("PASS" if ok else "FAIL", engine, label, len(fl), 100 * e))
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(E.dispatch(sys.argv, globals(), __doc__))
