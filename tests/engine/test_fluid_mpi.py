#!/usr/bin/env python3
"""test_fluid_mpi.py - fix sph/fluid on several MPI ranks (the engine's domain decomposition) against one rank.

  ranks EXE ENGINE MPIRUN EXAMPLES   every scene below at 1, 2 and 4 ranks (4 oversubscribed on small machines):
      dambreak   examples/dambreak2d at a/dx = 20, 1600 steps, cut vertically (processors 2 1 1, 4 1 1: the front
                 crosses the subdomain boundaries at x = 0.1 and 0.25 during the run) and horizontally (1 2 1);
                 with the delta-plus terms (visc morris, shifting, renormalised diffusion) at 4 1 1, 400 steps
      vortex     examples/taylor_green (delta-plus single fluid: shifting, renormalised diffusion; periodic in x
                 and y, so the ghosts are also the periodic images), 60 steps, processors 2 2 1 and 1 2 1
      tank       examples/static_tank (two phases, Herschel-Bulkley mud under water, shifting), 100 steps, Adami
                 walls (processors 1 2 1: the cut runs through the interface, and 2 2 1) and mirror ghost walls
                 (ghost mirror, 2 1 1)
      couette    a lid moved by fix move linear (moving walls: the ghost walls' velocity and acceleration come from
                 their owners), 300 steps, processors 1 2 1 (the cut runs parallel to the lid)
      coupled    fix sph/couple: the tiny dam break with 6 grains (torque yes), 400 steps, processors 1 3 1, 4 1 1,
                 2 2 1 (grains and fluid on both sides of the cuts)
      thin       the tiny dam break on 8 ranks (8 1 1): subdomains thinner than the ghost band
      probe      compute sph/probe on the hydrostatic start (points on both sides of the cut), processors 1 2 1
  restart EXE ENGINE MPIRUN          the tiny dam break written by write_restart at 2 ranks and continued at 1, and
                                     written at 1 and continued at 4, against the unbroken run at 1 rank
  couple EXE ENGINE MPIRUN           fix sph/couple: the momentum balance at 3 and 4 ranks, a coupled restart 3 -> 1
  rk4 EXE ENGINE MPIRUN              integrator rk4 (the tiny dam break, plain and with the delta-plus terms) at
                                     2 ranks (1 2 1: the cut runs through the column) and 4 (2 2 1) against 1 rank, 300 steps

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
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_test as et  # noqa: E402

BOUND = 1e-9


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


def keyed(workdir, step):
    """rows of the dump of step, in the order of the atoms' positions at step 0 (x, then y)"""
    first = et.read_dump(os.path.join(workdir, "mpi.0.txt"))
    now = et.read_dump(os.path.join(workdir, "mpi.%d.txt" % step))
    order = sorted(first, key=lambda t: (round(first[t][0] * 1e7), round(first[t][1] * 1e7)))
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


def ranks_case(exe, engine, mpirun, wd, script, grids, step, names, periodic=None, moved_col=None):
    """script at 1 rank and at each (np, processors grid): the dumps of step against the 1-rank dump"""
    et.must_run([exe], wd + "/np1", script, timeout=300)
    ref = keyed(wd + "/np1", step)
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
        d, col = worst(ref, keyed(sub, step), names, periodic)
        ok = d < BOUND
        print("%s %s (%s) at %d ranks, processors %s, step %d: max relative difference %.3e in %s (bound %.0e)" %
              ("PASS" if ok else "FAIL", wd, engine, np_, grid, step, d, col, BOUND))
        fails += 0 if ok else 1
    return fails


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
    # subdomains thinner than the ghost band (8 ranks across the tiny dam break: 0.05 m < 4h + skin = 0.057 m):
    # the engine gathers the ghosts across several subdomains
    thin = et.HEAD + et.CREATE + et.NEIGH + et.FIX.format(extra="") + et.THERMO + \
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


if __name__ == "__main__":
    sys.exit(et.dispatch(sys.argv, globals(), __doc__))
