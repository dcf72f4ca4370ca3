#!/usr/bin/env python3
"""test_fluid_mpi.py - fix sph/fluid on several MPI ranks (the engine's domain decomposition) against one rank.

  ranks EXE ENGINE MPIRUN EXAMPLES   every scene below at 1, 2 and 4 ranks (4 oversubscribed on small machines):
      dambreak   examples/dambreak2d at a/dx = 20, 1600 steps, cut vertically (processors 2 1 1, 4 1 1: the front
                 crosses the subdomain boundaries at x = 0.1 and 0.25 during the run) and horizontally (1 2 1);
                 LAMMPS: also comm_style tiled with balance rcb and with fix balance rcb, and fix balance shift (2 ranks:
                 the atoms change ranks during the run; LIGGGHTS has neither);
                 with the delta-plus terms (visc morris, shifting, renormalised diffusion) at 4 1 1, 400 steps
      vortex     examples/taylor_green (delta-plus single fluid: shifting, renormalised diffusion; periodic in x
                 and y, so the ghosts are also the periodic images), 60 steps, processors 2 2 1 and 1 2 1
      tank       examples/static_tank (two phases, Herschel-Bulkley mud under water, shifting), 100 steps, Adami
                 walls (processors 1 2 1: the cut runs through the interface, and 2 2 1) and mirror ghost walls
                 (ghost mirror, 2 1 1)
      couette    a lid moved by fix move linear (moving walls: the ghost walls' velocity and acceleration come from
                 their owners), 300 steps, processors 1 2 1 (the cut runs parallel to the lid)
      coupled    fix sph/couple: the tiny dam break with 6 grains (torque yes), 400 steps, processors 1 3 1, 4 1 1,
                 2 2 1 (grains and fluid on both sides of the cuts); LAMMPS: also comm_style tiled, balance rcb
      thin       the tiny dam break with isolated 0.5 on 8 ranks (8 1 1): subdomains thinner than the ghost band
      probe      compute sph/probe on the hydrostatic start (points on both sides of the cut), processors 1 2 1
  dambreak3d EXE ENGINE MPIRUN EXAMPLES  examples/dambreak3d at dx 20 mm, 700 steps: the front crosses x = 0.295
                 (processors 2 1 1, 4 1 1, 2 2 1); the ranks right of the column hold no fluid until it arrives
  settling EXE ENGINE MPIRUN EXAMPLES    examples/settling, 700 steps: the sphere settles across a horizontal cut
                 (processors 1 1 2, 2 1 2)
  options EXE ENGINE MPIRUN EXAMPLES     examples/dambreak2d with tensile, xsph, delta, wall_clamp, isolated, sync 7,
                 2000 steps (processors 2 1 1, 2 2 1)
  particles EXE ENGINE MPIRUN EXAMPLES   examples/dambreak_particles at dx 6 mm, 1600 steps (processors 1 2 1,
                 4 1 1: cuts through the bed of beads and the water)
  drum EXE ENGINE MPIRUN EXAMPLES        examples/drum (coarse), 0.005 s settling + 0.005 s rotation with water,
                 grains built the same at any rank count (processors 2 1 1, 1 1 2, 2 1 2)
  dense EXE ENGINE MPIRUN                the tiny dam break with a bed of 72 coupled grains across the cuts, 400 steps
                 (processors 4 1 1, 1 4 1, 2 2 1): fails without the coupling's part of the ghost band
  tworuns EXE ENGINE MPIRUN              run 100 + run 100 at 2 ranks against run 200 at 1 (no hang at the second
                 run's set-up)
  restart EXE ENGINE MPIRUN          the tiny dam break written by write_restart at 2 ranks and continued at 1, and
                                     written at 1 and continued at 4, against the unbroken run at 1 rank
  couple EXE ENGINE MPIRUN           fix sph/couple: the momentum balance at 3 and 4 ranks, a coupled restart 3 -> 1
  rk4 EXE ENGINE MPIRUN              integrator rk4 (the tiny dam break, plain and with the delta-plus terms) at
                                     2 ranks (1 2 1: the cut runs through the column) and 4 (2 2 1) against 1 rank, 300 steps
  scenes EXE ENGINE MPIRUN EXAMPLES  examples/hydrostatic (dx 5 mm, 300 steps; processors 2 1 1, 1 2 1, 2 2 1),
                 examples/poiseuille2phase (res 20, 300 steps; 1 2 1: the cut runs along the interface of the two
                 phases; 2 1 1: across the periodic axis), examples/debris_flow (dx 40 mm, 200 steps: Bingham mud
                 sliding into water, shifting; 2 1 1, 2 2 1)
  precision EXE ENGINE MPIRUN        precision mixed (the tiny dam break at 2 ranks, 1 2 1, and 4, 2 2 1; with the
                                     delta-plus terms at 2) and single (2 ranks) against 1 rank, 300 steps; bounds
                                     PREC_BOUND and SINGLE_BOUND (below)

Atoms are matched by their initial position (create_atoms numbers the atoms in a different order on another
number of ranks). Bounds: the runs differ only by the order of the floating-point sums (other neighbours are
ghosts, other cells, other list order), so x, v, rho agree to round-off growth: max |difference| / (largest
magnitude of the column; for velocities: of any velocity component) < 1e-9 over the stated steps. The delta-plus vortex is held to the steps before its
first threshold switch (the shifting and the renormalisation switch on lambda and on the smallest eigenvalue; a
round-off difference that crosses one grows like any other perturbation: one rank with another search-grid
skin shows the same growth after ~100 steps); 60 steps at the resolution used here.
Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import re
import shutil
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_test as et  # noqa: E402

BOUND = 1e-9
# precision mixed and single: the pair terms in float (round-off 6e-8) summed in another order on another rank count
# (ghost partners, other cells; the float loop's blocks of 16 pairs); grown over 300 steps as in double
PREC_BOUND = 1e-5
SINGLE_BOUND = 1e-4


def mpirun_cmd(mpirun, np_, exe):
    return [mpirun, "-np", str(np_), "--oversubscribe", "--allow-run-as-root", exe]


def add_processors(script, grid):
    """the processors command right after the dimension/units header (before create_box)"""
    if not grid:
        return script
    return re.sub(r"(?m)^(create_box.*)$", "processors %s\n\\1" % grid, script, count=1) \
        if "processors" not in script else script


def dump_lines(engine, group, every, cols):
    fmt = ("dump_modify m sort id format float %.17g" if engine == "lammps" else
           'dump_modify m sort id format "%d' + " %.17g" * len(cols.split()) + '"')
    return "dump m %s custom %d mpi.*.txt id %s\n%s\n" % (group, every, cols, fmt)


def keyed(workdir, step, ncoord=2, start="mpi.0.txt"):
    """rows of the dump of step, in the order of the atoms' positions in the dump start (x, then y, then z: the
    first ncoord columns)"""
    first = et.read_dump(os.path.join(workdir, start))
    now = et.read_dump(os.path.join(workdir, "mpi.%d.txt" % step))
    order = sorted(first, key=lambda t: tuple(round(first[t][c] * 1e7) for c in range(ncoord)))
    return [now[t] for t in order]


def worst(a, b, names, periodic=None):
    """max over columns of max|a - b| / max|column of a|; periodic: {column: length} compared modulo length"""
    if len(a) != len(b):
        return float("inf"), "atom count %d vs %d" % (len(a), len(b))
    out, where = 0.0, ""
    vcols = [c for c, name in enumerate(names) if name.startswith("v")]
    vscale = max((abs(r[c]) for r in a for c in vcols), default=0.0) or 1.0
    for c, name in enumerate(names):
        # velocities against the largest speed component (a column that is ~0 everywhere, vy in a Couette flow,
        # would otherwise measure round-off against round-off)
        scale = vscale if c in vcols else (max(abs(r[c]) for r in a) or 1.0)
        d = 0.0
        for ra, rb in zip(a, b):
            e = abs(ra[c] - rb[c])
            if periodic and c in periodic:
                e = min(e, abs(periodic[c] - e))
            d = max(d, e)
        if d / scale > out:
            out, where = d / scale, name
    return out, where


def ranks_case(exe, engine, mpirun, wd, script, grids, step, names, periodic=None, moved_col=None, ncoord=2,
               bound=BOUND, check=None):
    """script at 1 rank and at each (np, processors grid): the dumps of step against the 1-rank dump; check(sub,
    np, grid) (optional) returns the number of failures of further checks of each run"""
    et.must_run([exe], wd + "/np1", script, timeout=300)
    ref = keyed(wd + "/np1", step, ncoord)
    if moved_col is not None and max(abs(r[moved_col]) for r in ref) == 0.0:
        print("FAIL %s: nothing moved, equality would prove nothing" % wd)
        return 1
    fails = 0
    for np_, grid in grids:
        sub = "%s/np%d_%s" % (wd, np_, grid.replace(" ", ""))
        out = et.must_run(mpirun_cmd(mpirun, np_, exe), sub, add_processors(script, grid), timeout=300)
        if "%d MPI ranks (processors %s)" % (np_, grid) not in out:
            print("FAIL %s: the set-up line with %d MPI ranks (processors %s) is missing" % (sub, np_, grid))
            fails += 1
            continue
        d, col = worst(ref, keyed(sub, step, ncoord), names, periodic)
        ok = d < bound
        print("%s %s (%s) at %d ranks, processors %s, step %d: max relative difference %.3e in %s (bound %.0e)" %
              ("PASS" if ok else "FAIL", wd, engine, np_, grid, step, d, col, bound))
        fails += 0 if ok else 1
        if check:
            fails += check(sub, np_, grid)
    return fails


def tiled_case(exe, engine, mpirun, wd, script, step, how="static"):
    """script at 2 ranks with comm_style tiled against its 1-rank dump of step; how: static (balance rcb before
    the fix), dynamic (fix balance 100 1.0 rcb: the atoms change ranks during the run) or shift (no tiled
    communication: processors 2 1 1 and fix balance 100 1.0 shift x 10 1.0)"""
    sub = wd + "/np2_" + {"static": "tiled_rcb", "dynamic": "tiled_fix_rcb", "shift": "fix_shift"}[how]
    if how == "shift":
        s = add_processors(script, "2 1 1")
    else:
        s = re.sub(r"(?m)^(create_box.*)$", r"\1\ncomm_style tiled", script, count=1)
    if how == "static":
        s = re.sub(r"(?m)^(fix\s+\S+\s+\S+\s+sph/fluid.*)$", r"balance 1.0 rcb\n\1", s, count=1)
    else:
        fx = "fix lb all balance 100 1.0 " + ("rcb" if how == "dynamic" else "shift x 10 1.0")
        s = re.sub(r"(?m)^(run\s+\S+)", fx + r"\n\1", s, count=1)
    out = et.must_run(mpirun_cmd(mpirun, 2, exe), sub, s, timeout=300)
    m = re.search(r"rank 0 moves the boundary slice .*?: (\d+) of (\d+) owned fluid atoms .*?, (\d+) ghost", out)
    d, col = worst(keyed(wd + "/np1", step), keyed(sub, step), ["x", "y", "vx", "vy", "rho"])
    ok = d < BOUND and m is not None and int(m.group(1)) > 0 and int(m.group(3)) > 0
    print("%s %s (%s) at 2 ranks, %s, step %d: max relative difference %.3e in %s (bound %.0e); rank 0 sends %s "
          "of %s owned fluid atoms, %s ghosts" %
          ("PASS" if ok else "FAIL", sub, engine, {"static": "comm_style tiled, balance rcb",
                                                   "dynamic": "comm_style tiled, fix balance rcb every 100 steps",
                                                   "shift": "fix balance shift every 100 steps"}[how],
           step, d, col, BOUND, *(m.groups() if m else ("?",) * 3)))
    return 0 if ok else 1


def example(examples, name):
    with open(os.path.join(examples, name, "in." + name)) as f:
        return f.read()


def shorten(text, steps, group, every, cols, engine):
    """the example without its dumps, with our dump and 'run steps'"""
    text = re.sub(r"(?m)^dump\s.*$", "", text)
    text = re.sub(r"(?m)^dump_modify\s.*$", "", text)
    return re.sub(r"(?m)^run\s+\S+", dump_lines(engine, group, every, cols) + "run %d" % steps, text)


def test_ranks(exe, engine, mpirun, examples):
    fails = 0
    # dam break: walls, a free surface, a front that crosses the cuts
    db = shorten(example(examples, "dambreak2d"), 1600, "fluid", 1600, "x y vx vy f_water[1]", engine)
    db = db.replace("variable nres   index 40", "variable nres   index 20")
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/dambreak" % engine, db,
                        [(2, "2 1 1"), (4, "4 1 1"), (2, "1 2 1")], 1600, ["x", "y", "vx", "vy", "rho"], moved_col=2)
    # LAMMPS' tiled communication with a recursive-bisection balance (no processors grid): the send lists the fix
    # records come from the engine's tiled swaps
    if engine == "lammps":
        for how in ("static", "dynamic", "shift"):
            fails += tiled_case(exe, engine, mpirun, "ranks_%s/dambreak" % engine, db, 1600, how)
    # the same with the delta-plus terms: at 4 1 1 two ranks start without fluid (they still take part in the
    # reductions of every rate evaluation)
    dp = db.replace("visc artificial 0.02", "visc morris 1e-3 shifting yes diffusion renorm 0.1")
    dp = re.sub(r"(?m)^(dump m .*) 1600 ", r"\1 400 ", dp).replace("run 1600", "run 400")
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/dambreak_dplus" % engine, dp, [(4, "4 1 1")], 400,
                        ["x", "y", "vx", "vy", "rho"], moved_col=2)
    # delta-plus vortex, periodic in x and y
    tg = shorten(example(examples, "taylor_green"), 60, "fluid", 60, "x y vx vy f_tg[1]", engine)
    tg = tg.replace("variable res    index 50", "variable res    index 24")
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/vortex" % engine, tg, [(4, "2 2 1"), (2, "1 2 1")], 60,
                        ["x", "y", "vx", "vy", "rho"], periodic={0: 1.0, 1: 1.0}, moved_col=2)
    # two phases (Herschel-Bulkley mud under water, shifting, probes), Adami walls and mirror ghost walls
    st = shorten(example(examples, "static_tank"), 100, "fluid", 100, "x y vx vy f_tank[1]", engine)
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/tank" % engine, st, [(2, "1 2 1"), (4, "2 2 1")], 100,
                        ["x", "y", "vx", "vy", "rho"], moved_col=3)
    stm = st.replace('variable walls  index "wall_clamp no"', 'variable walls  index "ghost mirror 0 1.2 0 10"')
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/tank_mirror" % engine, stm, [(2, "2 1 1")], 100,
                        ["x", "y", "vx", "vy", "rho"], moved_col=3)
    # moving lid (the Couette scene of engine_test.py), cut parallel to the lid
    L, res, V0, dt, n = 1e-3, 30, 1.25e-5, 2.5e-4, 300
    dx = L / res
    cou = et.COUETTE.format(dx=repr(dx), lx=repr(20 * dx), ylo=repr(-4 * dx), yhi=repr(L + 4 * dx),
                            zlo=repr(-0.5 * dx), zhi=repr(0.5 * dx), L=repr(L), m=repr(1000 * dx * dx),
                            h=repr(1.5 * dx), c0=repr(100 * V0), V0=repr(V0), dt=repr(dt), n=n,
                            fmt=et.DUMPFMT[engine])
    cou = re.sub(r"(?m)^run\s+\S+", dump_lines(engine, "all", n, "x y vx vy") + "run %d" % n, cou)
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/couette" % engine, cou, [(2, "1 2 1")], n,
                        ["x", "y", "vx", "vy"], periodic={0: 20 * dx}, moved_col=2)
    # SPH-DEM coupling: the tiny dam break with 6 grains (engine_test.py's couple scene: every 2, superficial
    # density, drag), grains and fluid on both sides of the cut
    cp = et.couple_scene(engine, "torque yes", steps=400)
    cp = re.sub(r"(?m)^run\s+\S+", dump_lines(engine, "moving", 400, "x y vx vy f_water[1]") + "run 400", cp)
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/coupled" % engine, cp, [(3, "1 3 1"), (4, "4 1 1"),
                        (4, "2 2 1")], 400, ["x", "y", "vx", "vy", "rho"], moved_col=3)
    if engine == "lammps":
        fails += tiled_case(exe, engine, mpirun, "ranks_%s/coupled" % engine, cp, 400)
    # subdomains thinner than the ghost band (8 ranks across the tiny dam break; isolated's kernel sums add a
    # level: 0.05 m < 4h + skin = 0.057 m): the engine gathers the ghosts across several subdomains
    thin = et.HEAD + et.CREATE + et.NEIGH + et.FIX.format(extra="isolated 0.5") + et.THERMO + \
        dump_lines(engine, "fluid", et.STEPS, "x y vx vy f_water[1]") + "run %d\n" % et.STEPS
    fails += ranks_case(exe, engine, mpirun, "ranks_%s/thin" % engine, thin, [(8, "8 1 1")], et.STEPS,
                        ["x", "y", "vx", "vy", "rho"], moved_col=3)
    # probes on both sides of a vertical cut: the rank that holds a point samples it
    pr = (et.HEAD + et.CREATE + et.NEIGH + et.FIX.format(extra="") +
          "compute pr all sph/probe water 0.05 0.05 0.0 0.1 0.1 0.0 0.14 0.17 0.0 0.09 0.16 0.0\n"
          "thermo_style custom step c_pr[1][1] c_pr[2][1] c_pr[3][1] c_pr[4][1] c_pr[3][2] c_pr[4][6]\n"
          "thermo_modify format float %.15g\nthermo 10\nrun 20\n")
    et.must_run([exe], "ranks_%s/probe/np1" % engine, pr)
    fails += probe_case(exe, engine, mpirun, pr)
    return fails


def crossed(workdir, step, col, cut, ncoord=3):
    """how many atoms of the dumps at step 0 and at step were on the two sides of the plane coordinate col = cut"""
    first = et.read_dump(os.path.join(workdir, "mpi.0.txt"))
    now = et.read_dump(os.path.join(workdir, "mpi.%d.txt" % step))
    return sum(1 for t in first if (first[t][col] < cut) != (now[t][col] < cut))


def crossing_check(wd, step, cuts):
    """FAIL unless atoms of the 1-rank run crossed each plane (col, cut, name) during the run"""
    fails = 0
    for col, cut, name in cuts:
        n = crossed(wd + "/np1", step, col, cut)
        print("%s %s: %d atoms crossed the cut %s = %g in %d steps" % ("PASS" if n else "FAIL", wd, n, name, cut, step))
        fails += 0 if n else 1
    return fails


D3 = ["x", "y", "z", "vx", "vy", "vz", "rho"]


def test_dambreak3d(exe, engine, mpirun, examples):
    """examples/dambreak3d at dx = 20 mm (980 fluid, 7804 wall particles; h = 1.3 dx, delta-SPH 0.1, artificial
    viscosity), 700 steps (0.18 s): the front runs from x = 0.14 to 0.37 m and crosses the subdomain boundary at
    x = 0.295 (the box middle: processors 2 1 1, and 4 1 1 with further cuts at 0.1275, inside the column, and
    0.4625); 2 2 1 cuts the column also along y. Atoms matched by their initial x, y, z; bound 1e-9 relative (the
    module doc: round-off of the other order of the sums, grown over 700 steps)."""
    steps = 700
    db = shorten(example(examples, "dambreak3d"), steps, "fluid", steps, "x y z vx vy vz f_water[1]", engine)
    db = db.replace("variable dx     index 0.004", "variable dx     index 0.02")
    wd = "ranks_%s/dambreak3d" % engine
    fails = ranks_case(exe, engine, mpirun, wd, db, [(2, "2 1 1"), (4, "4 1 1"), (4, "2 2 1")], steps, D3,
                       moved_col=3, ncoord=3)
    return fails + crossing_check(wd, steps, [(0, 0.295, "x")])


def test_settling(exe, engine, mpirun, examples):
    """examples/settling (one glass sphere of 1 mm in still water, dx 2 mm, fix sph/couple, every 2), 700 steps
    (0.02 s), the box raised to z = 0.1074 m (empty space above the open tank) so that its middle, z = 0.0497 m,
    lies 0.3 mm below the sphere's release point (it passes there near step 450): at processors 1 1 2 and 2 1 2
    the sphere settles across that horizontal cut (it changes rank with its coupling state; the grain search and
    the fluid around it are ghosts on the other rank before and after); at 2 1 2 the sphere also sits on the
    vertical cut x = 0.015 m (the tank axis, where fluid lattice points lie too). Bound 1e-9 relative (the module doc)."""
    steps = 700
    st = shorten(example(examples, "settling"), steps, "moving", steps, "x y z vx vy vz f_water[1]", engine)
    st = st.replace("-0.008 0.09 units box", "-0.008 0.1074 units box")
    st = re.sub(r"(?m)^(dump m )", "group moving union fluid grain\n\\1", st, count=1)
    wd = "ranks_%s/settling" % engine

    def sphere(sub, np_, grid):
        first = et.read_dump(os.path.join(sub, "mpi.0.txt"))
        now = et.read_dump(os.path.join(sub, "mpi.%d.txt" % steps))
        g = [t for t in first if first[t][6] == 0.0]
        ok = len(g) == 1 and first[g[0]][2] > 0.0497 > now[g[0]][2]
        print("%s %s at %d ranks: the sphere from z = %s to %s (the cut at 0.0497)" %
              ("PASS" if ok else "FAIL", wd, np_, [first[t][2] for t in g], [now[t][2] for t in g]))
        return 0 if ok else 1
    return ranks_case(exe, engine, mpirun, wd, st, [(2, "1 1 2"), (4, "2 1 2")], steps, D3, moved_col=5, ncoord=3,
                      check=sphere)


def test_options(exe, engine, mpirun, examples):
    """examples/dambreak2d at a/dx = 20 with the optional fluid terms on: tensile 0.01, xsph 0.3, delta 0.1,
    wall_clamp yes, isolated 0.5 (one more ghost level: the kernel sums), sync 7 (host copies on steps that are no
    output or exchange steps); 2000 steps (T = t sqrt(2g/a) = 2.2: the water leaves the left wall, where the clamp
    acts, and its front crosses x = 0.25 m, the cut of processors 2 1 1); processors 2 1 1 and 2 2 1. Bound 1e-9
    relative (the module doc)."""
    steps = 2000
    op = shorten(example(examples, "dambreak2d"), steps, "fluid", steps, "x y vx vy f_water[1]", engine)
    op = op.replace("variable nres   index 40", "variable nres   index 20")
    op = op.replace("variable clamp  index no", "variable clamp  index yes")
    op = op.replace("variable iso    index 0 ", "variable iso    index 0.5 ")
    op = op.replace("visc artificial 0.02 wall walls",
                    "visc artificial 0.02 tensile 0.01 xsph 0.3 delta 0.1 wall walls")
    op = op.replace("sync 20", "sync 7")
    for want in ("wall_clamp ${clamp}", "index yes", "index 0.5", "xsph 0.3", "sync 7"):
        if want not in op:
            print("FAIL options: the example no longer has '%s' where the test sets it" % want)
            return 1
    wd = "ranks_%s/options" % engine
    out = ranks_case(exe, engine, mpirun, wd, op, [(2, "2 1 1"), (4, "2 2 1")], steps, ["x", "y", "vx", "vy", "rho"],
                     moved_col=2)
    log = open(os.path.join(wd, "np2_211", "log.test")).read()
    terms = re.search(r"Fix sph/fluid: terms: (.*)", log)
    print("  terms at 2 ranks: %s" % (terms.group(1) if terms else "MISSING"))
    return out + crossing_check(wd, steps, [(0, 0.25, "x")])


DENSE_BED = """lattice sq 0.009 origin 0.5 0.5 0.0
region bed block 0.036 0.144 0.036 0.09 -0.005 0.005 units box
create_atoms 3 region bed
group grains type 3
group moving type 1 3
set group grains diameter 0.006
set group grains mass 0.0706858347
timestep 5e-5
"""


def dense_scene(engine, steps):
    """the tiny dam break with a bed of 72 grains (12 x 6 on a 9 mm lattice, d 6 mm, solid fraction 0.35) in the
    lower half of the column: fix sph/couple as in the coupled scene (every 2, superficial density, drag, torque)"""
    create = et.CREATE.replace("create_box 2 box", "create_box 3 box").replace("timestep 1e-4\n", "") + DENSE_BED
    return (et.HEAD + create + et.NEIGH + et.COUPLE_FIX.format(extra="torque yes") + et.COUPLE_THERMO +
            dump_lines(engine, "moving", steps, "x y vx vy f_water[1]") + "run %d\n" % steps)


def test_dense(exe, engine, mpirun):
    """fix sph/couple with grains dense at the cuts: the tiny dam break with a bed of 72 grains spanning x =
    0.04-0.14 m and y = 0.04-0.09 m, 400 steps; processors 4 1 1 (cut x = 0.1 through the bed), 1 4 1 (cut y =
    0.075 through the bed) and 2 2 1. The coupling's chain of three supports (porosity <- grains, grain force <-
    fluid, reaction <- grain forces) reaches 3 x 2 h_c beyond the fluid's own ghost band; without that part of the
    band (fix sph/couple's extend_ghost_band) this scene differs from one rank by 2.8e-4 (4 1 1) and 1.7e-7 (1 4 1)
    relative (checked by hand; 2 2 1, whose cuts miss the bed, stays at 3e-13). Bound 1e-9 relative (the module
    doc)."""
    steps = 400
    wd = "ranks_%s/dense" % engine
    return ranks_case(exe, engine, mpirun, wd, dense_scene(engine, steps), [(4, "4 1 1"), (4, "1 4 1"), (4, "2 2 1")],
                      steps, ["x", "y", "vx", "vy", "rho"], moved_col=3)


def test_tworuns(exe, engine, mpirun):
    """two run commands in one script on 2 ranks (processors 2 1 1): the tiny dam break, run 100 + run 100, against
    run 200 at 1 rank (bound 1e-9 relative, the module doc); every rank must take part in the collective set-up
    checks of the second run (where one rank skips one, LAMMPS hangs and LIGGGHTS aborts in MPI: a run that hangs
    is stopped after 40 s and fails; the two runs take ~1 s)"""
    steps = et.STEPS
    base = et.HEAD + et.CREATE + et.NEIGH + et.FIX.format(extra="") + et.THERMO + \
        dump_lines(engine, "fluid", steps, "x y vx vy f_water[1]")
    wd = "ranks_%s/tworuns" % engine
    et.must_run([exe], wd + "/np1", base + "run %d\n" % steps)
    sub = wd + "/np2_211"
    script = add_processors(base + "run %d\nrun %d\n" % (steps // 2, steps // 2), "2 1 1")
    rc, out = et.run(mpirun_cmd(mpirun, 2, exe), sub, script, timeout=40)
    if rc != 0 or "ERROR" in out:
        print("FAIL %s: run 100 + run 100 on 2 ranks exited %d%s" % (sub, rc, " (hung: stopped after 40 s)"
                                                                       if rc == 124 else ""))
        print(out[-1500:])
        return 1
    d, col = worst(keyed(wd + "/np1", steps), keyed(sub, steps), ["x", "y", "vx", "vy", "rho"])
    ok = d < BOUND
    print("%s %s (%s): run %d + run %d at 2 ranks vs run %d at 1: max relative difference %.3e in %s (bound %.0e)" %
          ("PASS" if ok else "FAIL", wd, engine, steps // 2, steps // 2, steps, d, col, BOUND))
    return 0 if ok else 1


def last_dump(workdir):
    """the step and the rows (by atom ID) of the last dump mpi.STEP.txt in workdir"""
    step = max(int(f.split(".")[1]) for f in os.listdir(workdir) if re.match(r"mpi\.\d+\.txt$", f))
    return step, et.read_dump(os.path.join(workdir, "mpi.%d.txt" % step))


def write_start(engine, group, name):
    """write_dump of the positions of group to name (17 digits)"""
    fmt = "format float %.17g" if engine == "lammps" else 'format "%d %.17g %.17g %.17g"'
    return "write_dump %s custom %s id x y z modify sort id %s\n" % (group, name, fmt)


def by_start(workdir, starts):
    """the last dump's rows in the order of the atoms' positions in the write_dump files starts"""
    step, now = last_dump(workdir)
    pos = {}
    for name in starts:
        for t, r in et.read_dump(os.path.join(workdir, name)).items():
            pos[t] = tuple(r[:3])
    return step, [now[t] for t in sorted(now, key=lambda t: pos.get(t, (1e300,) * 3))], len(pos)


DRUM_VARS = {"ngrain": "969", "dg": "0.0054", "dx": "0.006", "dt": "1e-5", "tsettle": "0.005", "trot": "0.005",
             "nsamp": "1", "nfluid": "1"}


def test_drum(exe, engine, mpirun, examples):
    """examples/drum, its coarse variant (grains of 5.4 mm, dx 6 mm, dt 1e-5 s, fluid every 2), shortened to 0.005 s
    of settling without fluid and 0.005 s of rotation with water (fix sph/fluid with xsph, tensile, delta and
    rotating particle walls; fix sph/couple; the engine's granular pair style): grains and fluid at the end at
    processors 2 1 1 (a vertical cut through the drum axis), 1 1 2 (horizontal, through the axis, the water surface
    and the bed) and 2 1 2. The example keeps the ngrain (969) lowest sites of its grain lattice, picked and
    jittered by a key of each site's position, so it builds the same grains at any rank count; the test runs it as
    written. The grains start apart on their lattice and do not touch within these steps (contacts across ranks:
    engine_dem_mpi_*). Atoms matched by their positions after creation; bound 1e-9 relative (the module doc)."""
    text = example(examples, "drum")
    for k, v in DRUM_VARS.items():
        text, n = re.subn(r"(?m)^variable %s\s+index\s+\S+" % k, "variable %s index %s" % (k, v), text)
        if n != 1:
            print("FAIL drum: no 'variable %s index' in the example" % k)
            return 1
    edits = [("group         dwall type 2\n",
              "group         dwall type 2\n" + write_start(engine, "grains", "startg.txt")),
             ('print         "drum: $(count(fluid)) fluid particles"\n',
              'print         "drum: $(count(fluid)) fluid particles"\n' + write_start(engine, "fluid", "startf.txt"))]
    for a, b in edits:
        if text.count(a) != 1:
            print("FAIL drum: the example no longer has '%s' where the test changes it" % a.strip())
            return 1
        text = text.replace(a, b)
    text = re.sub(r"(?m)^dump\s.*$", "", text)
    text = re.sub(r"(?m)^dump_modify\s.*$", "", text)
    last = text.rfind("\nrun ")
    text = text[:last] + "\ngroup moving union grains fluid\n" + \
        dump_lines(engine, "moving", 1, "x y z vx vy vz f_water[1]").replace("custom 1 ", "custom ${nend} ") + \
        text[last:]
    wd = "ranks_%s/drum" % engine
    shutil.rmtree(wd, ignore_errors=True)  # the last dump of each run is read: none from an earlier run
    et.must_run([exe], wd + "/np1", text, timeout=300)
    step, ref, nstart = by_start(wd + "/np1", ("startg.txt", "startf.txt"))
    ng = len(et.read_dump(os.path.join(wd, "np1", "startg.txt")))
    vmax = max(abs(r[c]) for r in ref for c in (3, 4, 5))
    print("drum at 1 rank: %d grains, %d fluid, step %d, max |v| %.3g m/s" % (ng, nstart - ng, step, vmax))
    if not (ng > 900 and nstart - ng > 1000 and vmax > 0.05 and len(ref) == nstart):
        print("FAIL drum: too few grains or fluid atoms, or nothing moved")
        return 1
    return drum_ranks(exe, engine, mpirun, wd, text, step, ref, nstart, ["x", "y", "z", "vx", "vy", "vz", "rho"])


def drum_ranks(exe, engine, mpirun, wd, text, step, ref, nstart, names, timeout=300):
    """text at processors 2 1 1, 1 1 2 and 2 1 2 against the 1-rank rows ref (in the order of the start files
    startg.txt, startf.txt, see by_start): the number of failed comparisons (bound BOUND)"""
    fails = 0
    for np_, grid in ((2, "2 1 1"), (2, "1 1 2"), (4, "2 1 2")):
        sub = "%s/np%d_%s" % (wd, np_, grid.replace(" ", ""))
        et.must_run(mpirun_cmd(mpirun, np_, exe), sub, add_processors(text, grid), timeout=timeout)
        st, got, n = by_start(sub, ("startg.txt", "startf.txt"))
        if st != step or n != nstart:
            print("FAIL %s: step %d, %d atoms at the start (1 rank: %d, %d)" % (sub, st, n, step, nstart))
            fails += 1
            continue
        d, col = worst(ref, got, names)
        ok = d < BOUND
        print("%s %s (%s) at %d ranks, processors %s, step %d: max relative difference %.3e in %s (bound %.0e)" %
              ("PASS" if ok else "FAIL", wd, engine, np_, grid, step, d, col, BOUND))
        fails += 0 if ok else 1
    return fails


def test_particles(exe, engine, mpirun, examples):
    """examples/dambreak_particles (water and 7776 glass beads behind a gate lifted at 0.68 m/s; fix sph/fluid,
    fix sph/couple, the engine's granular pair style with shear history, fix move) at dx = 6 mm (3600 fluid, every
    32 DEM steps), 1600 DEM steps (6.6 ms: the gate rises 4.5 mm, the lower beads settle onto the wall particles
    and each other): water and beads at processors 1 2 1 (cut y = 0.075 m through the bed and the water) and 4 1 1
    (cuts x = 0.038 m through both, 0.1, 0.162). Atoms matched by their initial x, y, z; bound 1e-9 relative (the
    module doc; the contacts add their round-off)."""
    steps = 1600
    dp = shorten(example(examples, "dambreak_particles"), steps, "moving", steps, "x y z vx vy vz f_water[1]", engine)
    for a, b in (("variable dx     index 0.003", "variable dx     index 0.006"),
                 ("variable every  index 16", "variable every  index 32")):
        if a not in dp:
            print("FAIL particles: the example no longer has '%s'" % a)
            return 1
        dp = dp.replace(a, b)
    return ranks_case(exe, engine, mpirun, "ranks_%s/particles" % engine, dp, [(2, "1 2 1"), (4, "4 1 1")], steps, D3,
                      moved_col=5, ncoord=3)


def probe_rows(workdir):
    with open(os.path.join(workdir, "log.test")) as f:
        return et.thermo_rows(f.read())


def probe_case(exe, engine, mpirun, pr):
    ref = probe_rows("ranks_%s/probe/np1" % engine)
    sub = "ranks_%s/probe/np2" % engine
    et.must_run(mpirun_cmd(mpirun, 2, exe), sub, add_processors(pr, "1 2 1"))
    got = probe_rows(sub)
    if not ref or len(ref) != len(got) or all(v == 0.0 for v in ref[-1][1:]):
        print("FAIL probe (%s): thermo rows %d vs %d, last %s" % (engine, len(ref), len(got), ref[-1:] if ref else None))
        return 1
    d = max(abs(a - b) / max(abs(a), 1e-300) for ra, rb in zip(ref, got) for a, b in zip(ra[1:], rb[1:]) if a != 0.0)
    ok = d < BOUND
    print("%s probe (%s) at 2 ranks: max relative difference %.3e of the probed values (bound %.0e)" %
          ("PASS" if ok else "FAIL", engine, d, BOUND))
    return 0 if ok else 1


def test_restart(exe, engine, mpirun):
    half = et.STEPS // 2
    first = et.HEAD + et.CREATE + et.NEIGH + et.FIX.format(extra="") + et.THERMO + \
        dump_lines(engine, "fluid", half, "x y vx vy f_water[1]") + "run %d\nwrite_restart half.restart\n" % half
    second = ("read_restart half.restart\natom_modify sort 50 0.02\ntimestep 1e-4\n" + et.NEIGH +
              et.FIX.format(extra="") + et.THERMO + dump_lines(engine, "fluid", et.STEPS, "x y vx vy f_water[1]") +
              "run %d\n" % half)
    unbroken = et.HEAD + et.CREATE + et.NEIGH + et.FIX.format(extra="") + et.THERMO + \
        dump_lines(engine, "fluid", et.STEPS, "x y vx vy f_water[1]") + "run %d\n" % et.STEPS
    wd = "restart_ranks_%s" % engine
    et.must_run([exe], wd + "/unbroken", unbroken)
    ref = keyed(wd + "/unbroken", et.STEPS)
    fails = 0
    for n_write, n_read in ((2, 1), (1, 4)):
        sub = "%s/%dto%d" % (wd, n_write, n_read)
        et.must_run(mpirun_cmd(mpirun, n_write, exe), sub, first)
        et.must_run(mpirun_cmd(mpirun, n_read, exe), sub, second)
        d, col = worst(ref, keyed(sub, et.STEPS), ["x", "y", "vx", "vy", "rho"])
        ok = d < BOUND
        print("%s restart written at %d ranks, continued at %d (%s): max relative difference %.3e in %s (bound %.0e)"
              % ("PASS" if ok else "FAIL", n_write, n_read, engine, d, col, BOUND))
        fails += 0 if ok else 1
    return fails


def test_couple(exe, engine, mpirun):
    """SPH-DEM coupling on several ranks: the momentum balance (the fluid forces on the grains and the reactions
    on the fluid, each summed over the ranks' own atoms, cancel to 1e-10 of the former), and a restart written at
    3 ranks and continued at 1 against the unbroken run at 1 rank (1e-9)"""
    fails = 0
    for np_, grid in ((3, "1 3 1"), (4, "4 1 1")):  # cuts between the grain rows and columns
        wd = "couple_ranks_%s/momentum_np%d" % (engine, np_)
        out = et.must_run(mpirun_cmd(mpirun, np_, exe), wd,
                          add_processors(et.couple_scene(engine, "drag schiller-naumann torque yes superficial no"),
                                         grid))
        rows = et.thermo_rows(out)
        bal, fmax, ngr = 0.0, 0.0, 0
        for r in rows:
            fgx, fgy, ffx, ffy, fnx, fny = r[1:7]
            f = max(abs(fgx), abs(fgy))
            fmax = max(fmax, f)
            if f > 0:
                bal = max(bal, max(abs(fnx), abs(fny)) / f, max(abs(fgx + ffx), abs(fgy + ffy)) / f)
            ngr = int(r[8])
        ok = len(rows) >= 5 and fmax > 0 and bal <= 1e-10 and ngr == 6
        print("%s momentum balance at %d ranks (%s): max |F grains| %.4g N, max |net| / |F grains| %.2e (bound "
              "1e-10), %d grains counted once" % ("PASS" if ok else "FAIL", np_, engine, fmax, bal, ngr))
        fails += 0 if ok else 1
    half, steps = et.COUPLE_NSTEPS // 2, et.COUPLE_NSTEPS
    cols = "x y vx vy f_water[1]"
    unbroken = et.HEAD + et.COUPLE_CREATE + et.NEIGH + et.COUPLE_FIX.format(extra="") + et.COUPLE_THERMO + \
        dump_lines(engine, "moving", half, cols) + "run %d\n" % steps
    first = et.HEAD + et.COUPLE_CREATE + et.NEIGH + et.COUPLE_FIX.format(extra="") + et.COUPLE_THERMO + \
        dump_lines(engine, "moving", half, cols) + "run %d\nwrite_restart half.restart\n" % half
    second = ("read_restart half.restart\natom_modify sort 50 0.02\ntimestep 5e-5\n" + et.NEIGH +
              et.COUPLE_FIX.format(extra="") + et.COUPLE_THERMO + dump_lines(engine, "moving", steps, cols) +
              "run %d\n" % half)
    wd = "couple_ranks_%s/restart" % engine
    et.must_run([exe], wd + "/unbroken", unbroken)
    et.must_run(mpirun_cmd(mpirun, 3, exe), wd + "/3to1", add_processors(first, "1 3 1"))
    et.must_run([exe], wd + "/3to1", second)
    ref = keyed(wd + "/unbroken", steps)
    d, col = worst(ref, keyed(wd + "/3to1", steps), ["x", "y", "vx", "vy", "rho"])
    ok = d < BOUND
    print("%s coupled restart written at 3 ranks (1 3 1), continued at 1 (%s): max relative difference %.3e in %s (bound "
          "%.0e)" % ("PASS" if ok else "FAIL", engine, d, col, BOUND))
    return fails + (0 if ok else 1)


def test_rk4(exe, engine, mpirun):
    """integrator rk4: the ghosts take each stage's rates and XSPH / shift velocity from their owners"""
    fails = 0
    # the tiny dam break (plain fluid, Adami walls), cut through the column
    db = et.scene(engine, "integrator rk4", steps=300)
    db = re.sub(r"(?m)^dump d .*\n.*\n", "", db)
    db = re.sub(r"(?m)^run\s+\S+", dump_lines(engine, "fluid", 300, "x y vx vy f_water[1]") + "run 300", db)
    fails += ranks_case(exe, engine, mpirun, "rk4_%s/dambreak" % engine, db, [(2, "1 2 1"), (4, "2 2 1")], 300,
                        ["x", "y", "vx", "vy", "rho"], moved_col=2)
    # the delta-plus terms (shifting, diffusion: the shift velocity moves the ghosts too)
    dp = db.replace("visc artificial 0.05", "visc morris 1e-3 shifting yes diffusion renorm 0.1")
    fails += ranks_case(exe, engine, mpirun, "rk4_%s/dplus" % engine, dp, [(2, "1 2 1")], 300,
                        ["x", "y", "vx", "vy", "rho"], moved_col=2)
    return fails


def test_scenes(exe, engine, mpirun, examples):
    """the remaining fluid examples at 2 and 4 ranks against 1 (bound 1e-9, the module doc)"""
    fails = 0
    hs = shorten(example(examples, "hydrostatic"), 300, "fluid", 300, "x y vx vy f_water[1]", engine)
    hs = hs.replace("variable dx     index 0.0025", "variable dx     index 0.005")
    fails += ranks_case(exe, engine, mpirun, "scenes_%s/hydrostatic" % engine, hs, [(2, "2 1 1"), (2, "1 2 1"),
                        (4, "2 2 1")], 300, ["x", "y", "vx", "vy", "rho"], moved_col=3)
    po = shorten(example(examples, "poiseuille2phase"), 300, "fluid", 300, "x y vx vy f_chan[1]", engine)
    fails += ranks_case(exe, engine, mpirun, "scenes_%s/poiseuille2phase" % engine, po, [(2, "1 2 1"), (2, "2 1 1")],
                        300, ["x", "y", "vx", "vy", "rho"], periodic={0: 1.2}, moved_col=2)
    df = shorten(example(examples, "debris_flow"), 200, "fluid", 200, "x y vx vy f_flow[1]", engine)
    df = df.replace("variable dx     index 0.02", "variable dx     index 0.04")
    fails += ranks_case(exe, engine, mpirun, "scenes_%s/debris_flow" % engine, df, [(2, "2 1 1"), (4, "2 2 1")], 200,
                        ["x", "y", "vx", "vy", "rho"], moved_col=2)
    return fails


def test_precision(exe, engine, mpirun):
    """precision mixed and single on several ranks against one (and different from double: the float terms ran)"""
    fails = 0
    db = et.scene(engine, "", steps=300)
    db = re.sub(r"(?m)^dump d .*\n.*\n", "", db)
    db = re.sub(r"(?m)^run\s+\S+", dump_lines(engine, "fluid", 300, "x y vx vy f_water[1]") + "run 300", db)
    names = ["x", "y", "vx", "vy", "rho"]
    wd = "precision_%s" % engine
    dplus = "visc morris 1e-3 shifting yes diffusion renorm 0.1"
    # single rounds its state to float after each update: one rank's single is 4e-5 from double, and another sum
    # order flips roundings of the same size
    cases = [("mixed", "", [(2, "1 2 1"), (4, "2 2 1")], PREC_BOUND), ("single", "", [(2, "1 2 1")], SINGLE_BOUND),
             ("mixed", dplus, [(2, "1 2 1")], PREC_BOUND)]
    for prec, terms, grids, bound in cases:
        base = db.replace("visc artificial 0.05", terms) if terms else db
        sub = "%s/%s%s" % (wd, prec, "_dplus" if terms else "")
        et.must_run([exe], sub + "/double", base, timeout=300)
        sc = base.replace("sph/fluid", "sph/fluid precision %s" % prec, 1)
        fails += ranks_case(exe, engine, mpirun, sub, sc, grids, 300, names, moved_col=2, bound=bound)
        d, col = worst(keyed(sub + "/double", 300), keyed(sub + "/np1", 300), names)
        ok = d > 0.0
        print("%s %s%s at 1 rank differs from double by %.3e in %s (must differ: the float pair terms ran)" %
              ("PASS" if ok else "FAIL", prec, " (delta-plus)" if terms else "", d, col))
        fails += 0 if ok else 1
    return fails

if __name__ == "__main__":
    sys.exit(et.dispatch(sys.argv, globals(), __doc__))
