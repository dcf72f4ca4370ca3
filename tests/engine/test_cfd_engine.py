#!/usr/bin/env python3
"""test_cfd_engine.py - engine tests of fix cfd/grid (coarse-grid gas of CFD-DEM) through the launchers.

  badkw    EXE ENGINE   bad fix cfd/grid input stops with a message naming the keyword and the choices
                        (parse errors, the core's parameter check, a core error during a gas step); no crash
  particle EXE ENGINE   one grain (d 1e-4 m, rho_p 2000) released at rest in an upward gas flow (rho_g 1.2,
                        mu 1.8e-5, inlet 0.5 m/s at zlo, outlet zhi, slip side walls), fix gravity, nve/sphere:
                        vz(t) vs the single-sphere ODE dv/dt = -g (rho_p - rho_g)/rho_p
                        + 3/4 rho_g |u-v|(u-v) C_D/(d rho_p), C_D = 24/Re (1 + 0.15 Re^0.687) (Yu 2024 eqs 20-22):
                        relative error of v at t = 0.05 s below 1.25 %
  restart  EXE ENGINE   five grains in a ramped inlet flow (bc zlo inlet v_uin), gas every 3 steps: 100 steps
                        == 50 + write_restart + read_restart + 50 (x, v and the held forces, 1e-9); the split
                        falls between gas steps, so the held per-atom forces must come from the restart file
                        (checked by hand: 0.26 without the gas state, 1.1e-2 without the held forces); the
                        global vector in thermo at steps 50-100 equal (0 at step 50 without its restart
                        record, checked by hand); and == run 50 + run 50 in one script (1e-12)
  vtk      EXE ENGINE   vtk 2 PREFIX writes PREFIX_<step>.vti files that xml.etree parses, with the grid's
                        cell count in every array, and a PREFIX.pvd that lists them with increasing times;
                        a patch (spout) on zlo shows as the fastest cell of the bottom layer; after
                        write_restart/read_restart the collection keeps the earlier files and the times go on
  ergun    EXE ENGINE   a fixed bed (16,384 grains of 1 mm on a simple cubic lattice, voidage 0.40, 16 cells of
                        3.8 mm high, no integrator) in an upward gas flow of 0.1 and 0.3 m/s: the pressure drop
                        over the column (f_ID[1], less the gas weight) vs the Ergun equation, within 5 %
                        (the bed edges cost ~0.7 cell of drop: -4.5 % measured by the core test)
  mpi_fixed EXE ENGINE MPIRUN  a fixed bed (1458 grains, 4 x 3 x 12 cells) at 1, 2 (cut along x, along z) and
                        4 ranks, the grid decomposed: grain forces, thermo (dp, sums) and the VTK fields equal the
                        1-rank run within 2 kappa tol = 4.7e-8 (the block-Jacobi preconditioner changes with the
                        cuts, so each solve stops elsewhere within tol); the largest rank stores its block and
                        halo only; processors 4 1 1 on 4 cells (1 per rank) stops naming the processors grid and
                        the axis; a gas step beyond cfl at 2 ranks stops every rank with the message
  mpi_bed  EXE ENGINE MPIRUN  a small bubbling bed (512 grains, stirred start, 1000 steps, gas every 25) at 1, 2
                        (cut along x, along z) and 4 ranks, grains crossing every cut: grain positions,
                        velocities, gas forces and thermo equal the 1-rank run within 10 x the larger growth of
                        a 1e-17 m perturbation of the start and of a 1-rank run with the other preconditioner
                        (at most 1e-7)
  mpi_example EXE ENGINE MPIRUN EXAMPLES  examples/bubbling_bed as written, 1000 steps, at 1, 2 (cut along x, along
                        z) and 4 ranks: grains within 1e-8 of the 1-rank run; the largest rank's cells
  mpi_restart EXE ENGINE MPIRUN  the bed (not stirred) written at 2 ranks at step 510 (between gas steps), read at
                        1 and at 4 ranks, and written at 1 rank, read at 4, against the unbroken 2-rank run,
                        same bound (checked by hand: 0.98 when the gas fix gets another ID and so no state from
                        the file)
  plugin   HOST PLUGIN LMP  the particle scene (shortened) through sphdemplugin.so: fix cfd/grid registered,
                        thermo identical to lmp_sphdem's
Python 3 only; exits 0 on pass, 1 on failure.
"""
import math
import re
import os
import sys
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_test as E  # noqa: E402  (the shared helpers)
from engine_test import compare_cols, read_dump, run, thermo_rows  # noqa: E402

# the engines differ in dump_modify format syntax
DUMPFMT = {"lammps": "dump_modify d sort id format float %.17g",
           "liggghts": 'dump_modify d sort id format "%d' + " %.17g" * 12 + '"'}


def must_run(cmd, workdir, script, timeout=120):
    return E.must_run(cmd, workdir, script, timeout=timeout, no_error=True)


# ---- the scene: a gas column 3 x 3 x 10 mm, cells of 1 mm, grains of type 1 -------------------------------
HEAD = """# fix cfd/grid engine test
units si
atom_style sphere
boundary f f f
atom_modify map array sort 20 0.001
region box block 0 {lx} 0 {ly} 0 {lz} units box
create_box 1 box
"""
# LIGGGHTS recomputes the mass when the diameter is set: diameter first
GRAIN = "create_atoms 1 single {x} {y} {z} units box\n"
PROPS = """set type 1 diameter {d}
set type 1 mass {m}
"""
SETUP = """pair_style none
neighbor {skin} bin
neigh_modify every 10 delay 0 check no
timestep {dt}
"""
GAS = ("fix gas all cfd/grid grid {nx} {ny} {nz} rho 1.2 mu 1.8e-5 {bc} {extra}\n"
       "fix grav all gravity 9.81 vector 0 0 -1\n"
       "fix nvs all nve/sphere\n")
BC_COLUMN = "bc zlo inlet 0.5 bc zhi outlet bc xlo slip bc xhi slip bc ylo slip bc yhi slip"


def column(engine, grains, d=1e-4, rhop=2000.0, extra="", steps=10, dt=1e-4, bc=BC_COLUMN, grid=(3, 3, 10),
           box=None, tail="", pre_run=""):
    """the box is grid x 1 mm unless given"""
    lx, ly, lz = box if box else (1e-3 * grid[0], 1e-3 * grid[1], 1e-3 * grid[2])
    s = HEAD.format(lx=repr(lx), ly=repr(ly), lz=repr(lz))
    for (x, y, z) in grains:
        s += GRAIN.format(x=repr(x), y=repr(y), z=repr(z))
    s += PROPS.format(d=repr(d), m=repr(rhop * math.pi / 6 * d ** 3))
    s += SETUP.format(skin=repr(d), dt=repr(dt))
    s += GAS.format(nx=grid[0], ny=grid[1], nz=grid[2], bc=bc, extra=extra)
    s += tail + pre_run + "run %d\n" % steps
    return s


# ---- (1) bad input ----------------------------------------------------------------------------------------
def test_badkw(exe, engine):
    base = column(engine, [(0.0015, 0.0015, 0.005)], steps=2)
    kw = ("grid, box, rho, mu, gravity, bc, patch, every, drag, voidage, eps_min, ddt_eps, pressure_force, solver, "
          "tol, maxiter, cfl, device, init_u, vtk")
    bcs = "noslip, slip, inlet U (a number or v_name) or outlet"
    cases = [
        ("drag foo", "Fix cfd/grid: drag must be gidaspow, wenyu or none (got 'foo')"),
        ("voidage mean", "Fix cfd/grid: voidage must be centroid or smooth (got 'mean')"),
        ("device tpu", "Fix cfd/grid: device must be auto, gpu or cpu (got 'tpu')"),
        ("solver sor", "Fix cfd/grid: solver must be mg or line (got 'sor')"),
        ("ddt_eps maybe", "Fix cfd/grid: ddt_eps must be yes or no (got 'maybe')"),
        ("pressure_force 1", "Fix cfd/grid: pressure_force must be yes or no (got '1')"),
        ("bc top outlet", "Fix cfd/grid: bc SIDE must be xlo, xhi, ylo, yhi, zlo or zhi (got 'top')"),
        ("bc xlo wall", "Fix cfd/grid: bc xlo: TYPE must be " + bcs + " (got 'wall')"),
        ("bc xlo inlet fast", "Fix cfd/grid: bc xlo inlet U expects a number or v_name"),
        ("bc xlo inlet", "Fix cfd/grid: bc xlo inlet needs the superficial velocity U (a number or v_name)"),
        ("eps_min 1.5", "Fix cfd/grid: eps_min must be in (0, 1) (got 1.5)"),
        ("tol abc", "Fix cfd/grid: tol expects a number, got 'abc' (usage: tol V)"),
        ("every 0", "Fix cfd/grid: every expects an integer >= 1, got '0' (usage: every N)"),
        ("maxiter", "Fix cfd/grid: missing value(s) for maxiter (usage: maxiter N)"),
        ("vtk 0 gas", "Fix cfd/grid: vtk expects an integer >= 1, got '0'"),
        ("box 0 1 0 1 1 0", "Fix cfd/grid: box: zhi must be > zlo"),
        ("patch xlo 0 1 0 1 0.3", "Fix cfd/grid: patch on side xlo needs 'bc xlo inlet U' (a patch is a spout on "
                                  "an inlet side)"),
        ("bogus 1", "Fix cfd/grid: unknown keyword 'bogus'; keywords are " + kw),
    ]
    scripts = [
        # the core's own parameter check names the field
        ("grid 2000 2000 2000", base.replace("grid 3 3 10", "grid 2000 2000 2000"),
         "8000000000 cells exceed the limit"),
        ("grid missing", base.replace("grid 3 3 10 ", ""), "Fix cfd/grid: missing required keyword(s): grid (syntax:"),
        ("rho and mu missing", base.replace("rho 1.2 mu 1.8e-5 ", ""),
         "Fix cfd/grid: missing required keyword(s): rho mu"),
        ("no outlet", base.replace("bc zhi outlet", "bc zhi slip"),
         "Fix cfd/grid: no side is an outlet: give at least one 'bc SIDE outlet'"),
        ("grid 0 cells", base.replace("grid 3 3 10", "grid 3 0 10"),
         "Fix cfd/grid: grid expects an integer >= 1, got '0' (usage: grid NX NY NZ, integers >= 1)"),
        ("inlet variable missing", base.replace("inlet 0.5", "inlet v_nosuch"),
         "Fix cfd/grid: bc zlo inlet v_nosuch: variable nosuch does not exist"),
        ("inlet variable atom-style", base.replace("inlet 0.5", "inlet v_az").replace(
            "pair_style none", "variable az atom z\npair_style none"),
         "Fix cfd/grid: bc zlo inlet v_az: variable az is not equal-style"),
        # an error of the core during a gas step: its message through error->all
        ("CFL above cfl_max", base.replace("bc yhi slip ", "bc yhi slip cfl 0.01 "),
         "Fix cfd/grid: gas step at timestep 1 (gas dt 0.0001): "),
        ("atom style without radius", base.replace("atom_style sphere", "atom_style atomic").replace(
            "set type 1 diameter 0.0001\nset type 1 mass", "mass 1").replace("fix nvs all nve/sphere", "fix nvs all nve"),
         "Fix cfd/grid: the atom style must define a per-atom radius (atom_style sphere or granular)"),
    ]
    fails = 0
    items = [(k, base.replace("bc yhi slip ", "bc yhi slip " + k + " ", 1), w) for k, w in cases] + scripts
    for i, (what, script, want) in enumerate(items):
        rc, out = run([exe], "cfd_badkw_%s/%d" % (engine, i), script, timeout=60)
        crashed = rc < 0 or rc in (124, 134, 136, 137, 139) or "Segmentation" in out
        if want is None:  # the engine may refuse the script first (no radius, no mass); either way no crash
            ok = rc != 0 and not crashed and "ERROR" in out
            shown = [l for l in out.splitlines() if "ERROR" in l][:1]
            print("%s %s -> exit %d, %s" % ("PASS" if ok else "FAIL", what, rc, shown))
        else:
            ok = rc != 0 and want in out and not crashed
            print("%s %s -> exit %d, %s" % ("PASS" if ok else "FAIL", what, rc,
                                             "message found" if want in out else "MISSING: " + want))
        if ok and want is not None and what == "CFL above cfl_max":
            print("   " + next(l for l in out.splitlines() if want in l).strip())
        if not ok:
            print(out[-1500:])
            fails += 1
    return 1 if fails else 0


# ---- (2) one grain in an upward gas flow vs the single-sphere ODE ------------------------------------------
def particle_ode(t_end, d=1e-4, rhop=2000.0, rhog=1.2, mu=1.8e-5, u=0.5, g=9.81, dt=1e-6):
    """Yu 2024 eqs 20-22 (Schiller-Naumann C_D), RK4; upward velocity at t_end"""
    def acc(v):
        w = u - v
        re = rhog * abs(w) * d / mu
        # 3/4 rho_g |w| w C_D / (d rho_p) with C_D = 24/Re (1 + 0.15 Re^0.687) = 18 mu w (1 + ...) / (d^2 rho_p)
        drag = 18.0 * mu * w * (1.0 + 0.15 * re ** 0.687) / (d * d * rhop)
        return -g * (rhop - rhog) / rhop + drag
    v, t = 0.0, 0.0
    while t < t_end - 0.5 * dt:
        k1 = acc(v)
        k2 = acc(v + 0.5 * dt * k1)
        k3 = acc(v + 0.5 * dt * k2)
        k4 = acc(v + dt * k3)
        v += dt * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
        t += dt
    return v


def test_particle(exe, engine):
    dt, tend = 5e-5, 0.05
    steps = int(round(tend / dt))
    tail = ("variable vz equal vz[1]\nvariable zz equal z[1]\n"
            "thermo_style custom step v_zz v_vz f_gas[4] f_gas[11] f_gas[20]\n"
            "thermo_modify format float %.15g\nthermo 100\n")
    # One column of cells 3 x 3 x 1 mm: the gas flux through every layer is then fixed by continuity, so the
    # grain's own drag reaction cannot divert the gas around it (with 3 x 3 columns of 1 mm cells it lowers
    # the gas speed at the grain by ~3 %, i.e. ~20 % of the grain's small rise speed u - w_terminal)
    script = column(engine, [(0.0015, 0.0015, 0.003)], steps=steps, dt=dt, tail=tail, grid=(1, 1, 10),
                    box=(0.003, 0.003, 0.01))
    out = must_run([exe], "cfd_particle_" + engine, script)
    if "Fix cfd/grid:" not in out:
        print("FAIL: no set-up line of fix cfd/grid")
        return 1
    print("\n".join(l for l in out.splitlines() if l.startswith("Fix cfd/grid:")))
    rows = thermo_rows(out)
    if not rows or int(rows[-1][0]) != steps:
        print("FAIL: thermo output did not reach step %d" % steps)
        return 1
    print("   t (s)     vz (m/s)    ODE (m/s)   rel. error   eps_min   Fz drag (N)  Fz pg (N)")
    worst_late = 0.0
    for r in rows:
        t = r[0] * dt
        if t <= 0:
            continue
        exact = particle_ode(t)
        err = abs(r[2] - exact) / abs(exact)
        if t >= 0.01 - 1e-12:
            worst_late = max(worst_late, err)
        if int(r[0]) % 200 == 0:
            print("  %.4f  %11.6g  %11.6g  %9.3e  %.6f  %11.5g  %11.5g" % (t, r[2], exact, err, r[3], r[4], r[5]))
    t = rows[-1][0] * dt
    exact = particle_ode(t)
    err = abs(rows[-1][2] - exact) / abs(exact)
    print("grain in an upward gas flow (%s): t = %.3f s, vz = %.6g m/s, ODE %.6g m/s, error %.3f%% (bound 1.25%%); "
          "largest error for t >= 0.01 s %.3f%%" % (engine, t, rows[-1][2], exact, 100 * err, 100 * worst_late))
    ok = err < 0.0125
    print("%s single grain vs the drag ODE" % ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


# ---- (3) restart ------------------------------------------------------------------------------------------
RS_GRAINS = [(0.0012, 0.0013, 0.0020), (0.0021, 0.0017, 0.0031), (0.0016, 0.0024, 0.0043),
             (0.0009, 0.0008, 0.0052), (0.0025, 0.0022, 0.0025)]
RS_D = 4e-4
RS_BC = ("bc zlo inlet v_uin bc zhi outlet bc xlo noslip bc xhi slip bc ylo noslip bc yhi slip every 3 "
         "voidage smooth")
RS_VAR = "variable uin equal 0.3+step*2e-3\n"
RS_STEPS = 100
RS_DUMP = ("dump d all custom {n} final.* id x y z vx vy vz f_gas[1] f_gas[2] f_gas[3] f_gas[4] f_gas[5] f_gas[6]\n"
           "{fmt}\n")
RS_COLS = ["x", "y", "z", "vx", "vy", "vz", "fdx", "fdy", "fdz", "fpx", "fpy", "fpz"]
RS_THERMO = "thermo_style custom step f_gas[1] f_gas[4] f_gas[11]\nthermo 10\n"


def test_restart(exe, engine):
    wd = "cfd_restart_" + engine
    dump = RS_DUMP.format(n=RS_STEPS, fmt=DUMPFMT[engine])
    unbroken = column(engine, RS_GRAINS, d=RS_D, bc=RS_BC, steps=RS_STEPS, tail=RS_THERMO + dump,
                      pre_run="").replace("pair_style none", RS_VAR + "pair_style none")
    out_u = must_run([exe], wd + "/unbroken", unbroken)
    half = RS_STEPS // 2
    first = column(engine, RS_GRAINS, d=RS_D, bc=RS_BC, steps=half, tail=RS_THERMO).replace(
        "pair_style none", RS_VAR + "pair_style none") + "write_restart half.restart\n"
    must_run([exe], wd + "/split", first)
    # the fix is defined again with the same ID: its gas state and held forces come from the file;
    # LIGGGHTS does not restore the timestep
    second = ("read_restart half.restart\natom_modify sort 20 0.001\n" + RS_VAR + SETUP.format(skin=repr(RS_D), dt=repr(1e-4)) +
              GAS.format(nx=3, ny=3, nz=10, bc=RS_BC, extra="") + RS_THERMO + dump + "run %d\n" % half)
    out_s = must_run([exe], wd + "/split", second)
    # two runs in one script: the later run's set-up (parameters again, held forces added once) changes nothing
    tworuns = unbroken.replace("run %d\n" % RS_STEPS, "run %d\nrun %d\n" % (half, half))
    must_run([exe], wd + "/tworuns", tworuns)
    a = read_dump(os.path.join(wd, "unbroken", "final.%d" % RS_STEPS))
    c = read_dump(os.path.join(wd, "tworuns", "final.%d" % RS_STEPS))
    worst2 = compare_cols(a, c, RS_COLS)
    ok2 = worst2 <= 1e-12
    print("%s run %d + run %d vs run %d (%s): max relative difference %.3e (bound 1e-12)" %
          ("PASS" if ok2 else "FAIL", half, half, RS_STEPS, engine, worst2))
    b = read_dump(os.path.join(wd, "split", "final.%d" % RS_STEPS))
    vmax = max(abs(r[5]) for r in a.values())
    fmax = max(abs(r[8]) for r in a.values())
    print("  grains: max |vz| %.4g m/s, max |Fz drag| %.4g N" % (vmax, fmax))
    if not (vmax > 1e-3 and fmax > 0):
        print("FAIL: the grains did not move or felt no gas force")
        return 1
    worst = compare_cols(a, b, RS_COLS)
    ok = worst <= 1e-9
    # the global vector (statistics of the last gas step, kept in the restart file) from step 50 on
    ru = [r for r in thermo_rows(out_u) if r[0] >= half]
    rs = thermo_rows(out_s)
    okt = len(rs) == len(ru) == 6 and rs == ru and rs[0][1] != 0
    print("%s thermo f_gas[1] f_gas[4] f_gas[11] at steps %d-%d equal after the restart (first row %s)" %
          ("PASS" if okt else "FAIL", half, RS_STEPS, rs[0] if rs else None))
    ok = ok and okt
    # the split at step 50 lies between the gas steps 48 and 51: step 50 uses the forces held since step 48
    print("%s restart at step %d vs unbroken (%s): max relative difference %.3e (bound 1e-9)" %
          ("PASS" if ok else "FAIL", half, engine, worst))
    return 0 if ok and ok2 else 1


# ---- (4) VTK output ---------------------------------------------------------------------------------------
def test_vtk(exe, engine):
    wd = "cfd_vtk_" + engine
    nx, ny, nz, steps, every = 3, 4, 5, 12, 2
    grains = [(0.0015, 0.0015, 0.0025), (0.0012, 0.0031, 0.0012)]
    os.makedirs(os.path.join(wd, "out"), exist_ok=True)
    for f in os.listdir(os.path.join(wd, "out")):
        os.remove(os.path.join(wd, "out", f))
    script = column(engine, grains, d=5e-4, grid=(nx, ny, nz), steps=steps,
                    extra="every %d vtk 2 out/gas init_u 0 0 0.5 patch zlo 0 0.001 0.002 0.003 1.5 solver line" % every)
    must_run([exe], wd, script)
    ncell = nx * ny * nz
    fails = 0
    # gas steps at 2, 4, ..., 12; a file every 2 gas steps: steps 4, 8, 12
    want = [4, 8, 12]
    pvd = ET.parse(os.path.join(wd, "out", "gas.pvd")).getroot()
    sets = pvd.find("Collection").findall("DataSet")
    files = [s.get("file") for s in sets]
    times = [float(s.get("timestep")) for s in sets]
    if files != ["gas_%d.vti" % s for s in want]:
        print("FAIL: gas.pvd lists %s, expected %s" % (files, ["gas_%d.vti" % s for s in want]))
        fails += 1
    if any(abs(t - s * 1e-4) > 1e-12 for t, s in zip(times, want)):
        print("FAIL: gas.pvd times %s, expected %s" % (times, [s * 1e-4 for s in want]))
        fails += 1
    epsmin = 1.0
    for s in want:
        path = os.path.join(wd, "out", "gas_%d.vti" % s)
        root = ET.parse(path).getroot()
        img = root.find("ImageData")
        ext = [int(w) for w in img.get("WholeExtent").split()]
        spacing = [float(w) for w in img.get("Spacing").split()]
        arrays = {a.get("Name"): a for a in img.find("Piece").find("CellData").findall("DataArray")}
        counts = {k: len(a.text.split()) for k, a in arrays.items()}
        okc = (ext == [0, nx, 0, ny, 0, nz] and all(abs(h - 1e-3) < 1e-15 for h in spacing) and
               counts.get("voidage") == ncell and counts.get("pressure") == ncell and
               counts.get("velocity") == 3 * ncell and arrays["velocity"].get("NumberOfComponents") == "3")
        eps = [float(w) for w in arrays["voidage"].text.split()]
        uz = [float(w) for w in arrays["velocity"].text.split()][2::3]
        epsmin = min(epsmin, min(eps))
        # the spout (patch zlo over x in [0, 1] mm, y in [2, 3] mm: cell i = 0, j = 2, at 1.5 m/s, the rest of
        # zlo at 0.5 m/s): the fastest cell of the bottom layer, its centre velocity the mean of the inlet face
        # and the face above
        bottom = uz[:nx * ny]
        ks = 0 + nx * 2
        spout = bottom[ks]
        if not (spout > 0.75 and max(b for k, b in enumerate(bottom) if k != ks) < spout):
            print("FAIL: %s: the spout cell does not carry the fastest gas of the bottom layer: %s" % (path, bottom))
            fails += 1
        sane = all(0 < e <= 1 for e in eps) and all(v == v for v in uz) and max(uz) > 0.3
        print("%s %s: extent %s, %d cells, arrays %s, eps in [%.5f, %.5f], uz in [%.4f, %.4f], spout cell %.4f" %
              ("PASS" if okc and sane else "FAIL", os.path.basename(path), ext, ncell, counts, min(eps), max(eps),
               min(uz), max(uz), spout))
        fails += 0 if okc and sane else 1
    # a grain of 0.5 mm in a 1 mm cell: voidage 1 - 0.065 there
    if epsmin > 0.99:
        print("FAIL: no cell shows the grains (min voidage %.5f)" % epsmin)
        fails += 1
    # continued from a restart file: the collection keeps the earlier files, the times go on (the engines do
    # not keep the elapsed time in restart files; the fix does)
    wr = os.path.join(wd, "restart")
    os.makedirs(wr, exist_ok=True)
    for f in os.listdir(wr):
        os.remove(os.path.join(wr, f))
    gas = "vtk 1 g every 2"
    first = column(engine, grains, d=5e-4, grid=(nx, ny, nz), steps=4, extra=gas) + "write_restart r.bin\n"
    must_run([exe], wr, first)
    second = ("read_restart r.bin\natom_modify sort 20 0.001\n" + SETUP.format(skin=repr(5e-4), dt=repr(1e-4)) +
              GAS.format(nx=nx, ny=ny, nz=nz, bc=BC_COLUMN, extra=gas) + "run 4\n")
    must_run([exe], wr, second)
    sets = ET.parse(os.path.join(wr, "g.pvd")).getroot().find("Collection").findall("DataSet")
    got = [(s.get("file"), float(s.get("timestep"))) for s in sets]
    exp = [("g_%d.vti" % k, k * 1e-4) for k in (2, 4, 6, 8)]
    okr = len(got) == len(exp) and all(g[0] == e[0] and abs(g[1] - e[1]) < 1e-12 for g, e in zip(got, exp)) and \
        all(os.path.exists(os.path.join(wr, e[0])) for e in exp)
    print("%s collection after a restart at step 4: %s" % ("PASS" if okr else "FAIL", got))
    fails += 0 if okr else 1
    print("%s VTK output (%s)" % ("PASS" if not fails else "FAIL", engine))
    return 1 if fails else 0


ERGUN = """# fixed bed of 1 mm grains, voidage 0.40, 16 cells high, in a 4 x 4 x 32 cell column
units si
atom_style sphere
boundary f f f
atom_modify map array sort 0 0.0
region box block 0 {L} 0 {L} 0 {H} units box
create_box 1 box
lattice sc {s} origin 0.5 0.5 0.5
region bed block 0 {L} 0 {L} {z0} {z1} units box
create_atoms 1 region bed units box
set type 1 diameter 0.001
set type 1 density 2500
pair_style none
neighbor 0.001 bin
neigh_modify every 1000 delay 0 check no
timestep 1e-3
fix gas all cfd/grid grid 4 4 32 rho 1.2 mu 1.8e-5 bc zlo inlet {U} bc zhi outlet bc xlo slip bc xhi slip &
    bc ylo slip bc yhi slip solver line
thermo_style custom step f_gas[1] f_gas[5] f_gas[8]
thermo 10
run 40
"""


def test_ergun(exe, engine):
    d, eps, mu, rho, g = 1e-3, 0.40, 1.8e-5, 1.2, 9.81
    s = d * (math.pi / (6 * (1 - eps))) ** (1.0 / 3.0)
    h = 4 * s
    worst = 0.0
    for U in (0.1, 0.3):
        script = ERGUN.format(L=repr(4 * h), H=repr(32 * h), s=repr(s), z0=repr(8 * h), z1=repr(24 * h), U=U)
        out = must_run([exe], "cfd_ergun_%s_%g" % (engine, U), script, timeout=240)
        rows = thermo_rows(out)
        if not rows or int(rows[-1][0]) != 40:
            print("FAIL: no thermo rows to step 40")
            return 1
        if "16384 atoms" not in out and "Created 16384 atoms" not in out:
            print("FAIL: the bed does not have 16384 grains:\n" + out[-1500:])
            return 1
        dp = rows[-1][1] - rho * g * 31 * h        # first minus last cell layer, less the gas weight
        H = 16 * h
        ref = (150 * mu * (1 - eps) ** 2 * U / (eps ** 3 * d * d) + 1.75 * rho * (1 - eps) * U * U / (eps ** 3 * d)) * H
        err = dp / ref - 1
        worst = max(worst, abs(err))
        print("fixed bed U %.2f m/s: dp %.3f Pa vs Ergun %.3f Pa (%+.2f %%), mean voidage %.4f, mass error %.2e"
              % (U, dp, ref, 100 * err, rows[-1][2], rows[-1][3]))
        # the drops of successive thermo rows: steady
        if abs(rows[-1][1] - rows[-2][1]) > 1e-6 * abs(rows[-1][1]):
            print("FAIL: pressure drop not steady (%g, %g)" % (rows[-2][1], rows[-1][1]))
            return 1
    if worst > 0.05:
        print("FAIL: pressure drop off Ergun by %.2f %% (bound 5 %%)" % (100 * worst))
        return 1
    print("PASS: fixed bed vs Ergun through %s, worst %.2f %%" % (engine, 100 * worst))
    return 0


# ---- (6) many MPI ranks: the decomposed grid --------------------------------------------------------------
# Every rank holds its block of the grid and a 2-cell halo, deposits its own grains, exchanges halos with its
# face neighbours and takes part in one pressure solve over the whole grid: the answer at any rank count is the
# 1-rank answer to the solver tolerance (the block-Jacobi preconditioner depends on the cuts).

def mpirun_cmd(mpirun, np, exe):
    return [mpirun, "-np", str(np), "--oversubscribe", "--allow-run-as-root", exe]


def mpi_run(mpirun, np, exe, wd, script, timeout=120):
    """run script on np ranks (np 1 without mpirun); exit 1 with its output where it fails"""
    cmd = [exe] if np == 1 else mpirun_cmd(mpirun, np, exe)
    return must_run(cmd, wd, script, timeout=timeout)


def read_vti(path):
    """the cell arrays of a .vti file written by the fix: {name: [values]}"""
    img = ET.parse(path).getroot().find("ImageData")
    return {a.get("Name"): [float(w) for w in a.text.split()]
            for a in img.find("Piece").find("CellData").findall("DataArray")}


def rel_diff(a, b):
    """max |a - b| over max |a| of two equal-length lists"""
    scale = max(max(abs(v) for v in a), 1e-300)
    return max(abs(x - y) for x, y in zip(a, b)) / scale


# (a) A fixed bed (Ergun scene, smaller: 1458 grains of 1 mm on a simple cubic lattice, voidage 0.40, no
# integrator) in a 4 x 3 x 12 cell column: the grains do not move. Each rank holds its block of the grid and a
# 2-cell halo; the deposits differ from 1 rank only by the order of the sums (1e-16 relative), but the pressure
# solve's preconditioner is block Jacobi over the ranks' blocks, so its iterates differ and each solve stops
# somewhere else within relative residual tol = 1e-10. Two solutions whose residuals are both below tol |b| differ
# by at most 2 kappa tol relative (kappa the condition number of the pressure matrix: about (4 nz / pi)^2 = 233
# for the 12-cell column, whose outlet holds the pressure level), so the bound is 2 (4 nz / pi)^2 tol = 4.7e-8 on
# the pressure, and on the gas fields and grain forces that follow it linearly; measured 1e-13 to 2e-11.
MPI_FIXED = """# fixed bed of 1 mm grains, voidage 0.40, 6 cells high, in a 4 x 3 x 12 cell column
units si
atom_style sphere
boundary f f f
atom_modify map array sort 0 0.0
{procs}
region box block 0 {L} 0 {L} 0 {H} units box
create_box 1 box
lattice sc {s} origin 0.5 0.5 0.5
region bed block 0 {L} 0 {L} {z0} {z1} units box
create_atoms 1 region bed units box
set type 1 diameter 0.001
set type 1 density 2500
pair_style none
neighbor 0.001 bin
neigh_modify every 1000 delay 0 check no
timestep 1e-3
fix gas all cfd/grid grid 4 3 12 rho 1.2 mu 1.8e-5 bc zlo inlet 0.3 bc zhi outlet bc xlo slip bc xhi slip &
    bc ylo slip bc yhi slip vtk {steps} gas {extra}
thermo_style custom step f_gas[1] f_gas[2] f_gas[3] f_gas[5] f_gas[8] f_gas[11] f_gas[14] f_gas[17] f_gas[20]
thermo_modify format float %.17g
thermo {steps}
dump d all custom {steps} final.* id x y z f_gas[1] f_gas[2] f_gas[3] f_gas[4] f_gas[5] f_gas[6]
{fmt}
run {steps}
"""
FIXED_COLS = ["x", "y", "z", "fdx", "fdy", "fdz", "fpx", "fpy", "fpz"]
# the residual where the solve stopped and the mass error are round-off (below tol); the iterations are printed,
# not bounded
FIXED_THERMO = ["dp", "iters", "residual", "eps_mean", "mass_err", "f_grains_z", "f_gas_z", "f_bound_z", "f_pg_z"]
FIXED_STEPS = 20


def fixed_scene(engine, procs="", extra=""):
    s = 0.001 * (math.pi / (6 * 0.6)) ** (1.0 / 3.0)
    h = 3 * s
    fmt = DUMPFMT[engine].replace(" %.17g" * 12, " %.17g" * 9)
    return MPI_FIXED.format(L=repr(3 * h), H=repr(12 * h), s=repr(s), z0=repr(3 * h), z1=repr(9 * h), procs=procs,
                            steps=FIXED_STEPS, fmt=fmt, extra=extra)


# (b) A small bubbling bed (the examples/bubbling_bed scene cut down: 512 grains of 1.2 mm, 1000 kg/m^3, 20 mm
# deep in a 12 x 6 x 32 mm gas box on 4 x 2 x 10 cells, inlet 0.6 m/s; the example's stock spring-dashpot contacts
# and wall planes, fix nve/sphere, gravity, gas every 25 steps; a stirred start, 0.05 m/s): the cuts of the
# processors grids run through the bed, grains collide, cross the cuts and carry their held gas forces with them.
# Here the DEM adds round-off of its own (the force sums on a grain are in neighbour-list order, which changes with
# the decomposition), and collisions amplify any difference: the bound is set against that amplification,
# measured in the same test: a 1-rank run from initial positions moved by 1e-17 m (a few units of round-off of a
# position of 1e-2 m, 1.7e-18 m) grows apart from the plain 1-rank run by G; the rank counts may differ from the
# 1-rank run by at most 10 G (round-off enters every step, not once), and never more than 1e-9 (relative to each
# vector's largest component).
BED = """# small bubbling bed (examples/bubbling_bed cut down)
variable U equal 0.6
variable Lx equal 0.012
variable Ly equal 0.006
variable Lz equal 0.032
variable dp equal 0.0012
variable rhop equal 1000.0
variable kn equal 800.0
variable e equal 0.97
variable mu equal 0.1
variable mp equal ${{rhop}}*PI/6*${{dp}}^3
variable zeta equal -ln(${{e}})/sqrt(PI^2+ln(${{e}})^2)
variable gn equal 2*${{zeta}}*sqrt(${{kn}}/(0.5*${{mp}}))
units si
atom_style sphere
boundary f f f
atom_modify map array sort 1000 0.004
newton off
{procs}
region box block -0.001 $(v_Lx+0.00034) -0.001 $(v_Ly+0.001) -0.001 $(v_Lz+0.00276) units box
create_box 1 box
lattice sc 0.00125 origin 0 0 0
region bed block 0.0002 0.0112 0.0002 0.005 0.0002 0.02 units box
create_atoms 1 region bed units box
group grains type 1
set type 1 diameter ${{dp}}
set type 1 density ${{rhop}}
displace_atoms grains move -0.0006 -0.000625 -0.0006 units box
# a stirred start (the same velocity for a grain at any rank count: a function of its position), so that grains
# cross the subdomain boundaries within the run
variable vx0 atom {stir}*sin(1300*y+2100*z)
variable vz0 atom {stir}*cos(1700*x+900*z)
velocity grains set v_vx0 0 v_vz0 units box
{perturb}
timestep 4e-6
{dem}
neighbor 0.0003 bin
neigh_modify delay 0 every 1 check yes
fix gas grains cfd/grid grid 4 2 10 box 0 ${{Lx}} 0 ${{Ly}} 0 ${{Lz}} rho 1.225 mu 1.8e-5 &
    bc xlo noslip bc xhi noslip bc ylo noslip bc yhi noslip bc zlo inlet ${{U}} bc zhi outlet every 25 &
    drag gidaspow voidage smooth {extra}
fix grav grains gravity 9.81 vector 0 0 -1
fix move grains nve/sphere
compute zmax grains reduce max z
thermo_style custom step f_gas[1] f_gas[2] f_gas[5] f_gas[11] f_gas[20] c_zmax
thermo_modify format float %.17g
thermo {thermo}
dump d grains custom {dumpevery} final.* id x y z vx vy vz f_gas[1] f_gas[2] f_gas[3] f_gas[4] f_gas[5] f_gas[6]
{fmt}
{run}
"""
BED_DEM = {"lammps": """pair_style gran/hooke/history ${kn} NULL ${gn} NULL ${mu} 1
pair_coeff * *
comm_modify vel yes
fix wx grains wall/gran hooke/history ${kn} NULL ${gn} NULL ${mu} 1 xplane 0 ${Lx}
fix wy grains wall/gran hooke/history ${kn} NULL ${gn} NULL ${mu} 1 yplane 0 ${Ly}
fix wz grains wall/gran hooke/history ${kn} NULL ${gn} NULL ${mu} 1 zplane 0 ${Lz}""",
           "liggghts": """variable kt equal 2/7*${kn}
variable gt equal 0.5*${gn}
pair_style gran model hooke/stiffness tangential history
pair_coeff * *
communicate single vel yes
fix m1 all property/global kn peratomtypepair 1 ${kn}
fix m2 all property/global kt peratomtypepair 1 ${kt}
fix m3 all property/global gamman peratomtypepair 1 ${gn}
fix m4 all property/global gammat peratomtypepair 1 ${gt}
fix m5 all property/global coefficientFriction peratomtypepair 1 ${mu}
fix m6 all property/global youngsModulus peratomtype 1e7
fix m7 all property/global poissonsRatio peratomtype 0.3
fix wxl grains wall/gran model hooke/stiffness tangential history primitive type 1 xplane 0.0
fix wxh grains wall/gran model hooke/stiffness tangential history primitive type 1 xplane ${Lx}
fix wyl grains wall/gran model hooke/stiffness tangential history primitive type 1 yplane 0.0
fix wyh grains wall/gran model hooke/stiffness tangential history primitive type 1 yplane ${Ly}
fix wzl grains wall/gran model hooke/stiffness tangential history primitive type 1 zplane 0.0
fix wzh grains wall/gran model hooke/stiffness tangential history primitive type 1 zplane ${Lz}"""}
BED_STEPS = 1000
BED_STIR = 0.05  # m/s: the grains cross the cuts; at 0.2 m/s the round-off growth reaches 4e-10 in 1000 steps
# the subdomain cuts of the processors grids (uniform): the box middle, at x = 5.67 mm and z = 16.88 mm (the box
# reaches beyond the gas walls by as much as puts them 0.02 mm from a column and a layer of grains)
BED_MID = {"x": 0.00567, "z": 0.01688}
BED_COLS = ["x", "y", "z", "vx", "vy", "vz", "fdx", "fdy", "fdz", "fpx", "fpy", "fpz"]


def bed_scene(engine, procs="", steps=BED_STEPS, perturb="", extra="", run=None, dumpevery=None, stir=BED_STIR):
    return BED.format(procs=procs, perturb=perturb, dem=BED_DEM[engine], extra=extra, thermo=steps // 4,
                      dumpevery=dumpevery or steps, fmt=DUMPFMT[engine], run=run or "run %d" % steps,
                      stir=stir)


PROCS = {"x": "processors 2 1 1", "z": "processors 1 1 2", "xz": "processors 2 1 2", "": ""}
CUT = {"x": "cut along x (vertical planes)", "z": "cut along z (a horizontal plane)", "xz": "cut along x and z",
       "": "one rank"}
# an uneven cut (LAMMPS `balance`; LIGGGHTS 3.8 has no balance command): z at 0.292 of the box, -1 mm + 0.292 *
# 35.76 mm = 9.442 mm, which leaves 3 of the 10 gas layers (centres 1.6, 4.8, 8.0 mm) to the lower rank and 7 to the
# upper, 42 um above a layer of grains (at 9.4 mm; so that grains cross it)
BALANCE_Z = "balance 1.0 z 0.292"
BALANCE_Z_CUT = -0.001 + 0.292 * 0.03576


def compare_thermo(a, b, names, skip=()):
    """max over columns (but those in skip) of the relative difference of two thermo tables (same rows)"""
    if len(a) != len(b) or not a:
        print("  thermo: %d rows vs %d" % (len(a), len(b)))
        return float("inf")
    worst = 0.0
    for c in range(1, len(a[0])):
        scale = max(max(abs(r[c]) for r in a), 1e-300)
        d = max(abs(x[c] - y[c]) for x, y in zip(a, b)) / scale
        print("  %-10s max relative difference %.3e%s" % (names[c - 1], d, " (not bounded)" if c - 1 in skip else ""))
        if c - 1 not in skip:
            worst = max(worst, d)
    return worst


def compare_vec(a, b, names):
    """max over the vectors (3 columns each: position, velocity, drag, pressure-gradient force) of max |a - b| over
    the largest magnitude of that vector's components: a component that is round-off itself (the sideways drag in a
    bed blown from below) is measured against the size of the force, not against its own noise"""
    if sorted(a) != sorted(b):
        print("FAIL: different grains (%d vs %d, %d in common)" % (len(a), len(b), len(set(a) & set(b))))
        return float("inf")
    worst = 0.0
    for c0 in range(0, len(names), 3):
        scale = max(max(abs(v) for r in a.values() for v in r[c0:c0 + 3]), 1e-300)
        d = max(abs(a[t][c] - b[t][c]) for t in a for c in range(c0, c0 + 3)) / scale
        print("  %-12s max difference / largest component %.3e" % ("/".join(names[c0:c0 + 3]), d))
        worst = max(worst, d)
    return worst


def by_start(first, last):
    """the rows of the last dump keyed by each grain's position in the first one (the engines number the atoms of
    create_atoms by rank, so the same grain has another id at another rank count)"""
    return {tuple(round(v, 9) for v in first[t][:3]): last[t] for t in last}


FIXED_BOUND = 2 * (4 * 12 / math.pi) ** 2 * 1e-10
# cells of the 4 x 3 x 12 grid that the largest rank stores (its block and 2 halo layers per cut side): the
# blocks are 2 of 4 cells along x, 6 of 12 along z
FIXED_LOCAL = {"x": (2 + 2) * 3 * 12, "z": 4 * 3 * (6 + 2), "xz": (2 + 2) * 3 * (6 + 2)}


def local_cells(out):
    """(cells the largest rank stores, cells of the grid) from the fix's set-up line, or None"""
    m = re.search(r"the largest rank stores (\d+) of the (\d+) cells", out)
    return (int(m.group(1)), int(m.group(2))) if m else None


def test_mpi_fixed(exe, engine, mpirun):
    wd = "cfd_mpi_fixed_" + engine
    runs = [(1, ""), (2, "x"), (2, "z"), (4, "xz")]
    res = {}
    for np_, cut in runs:
        key = "np%d%s" % (np_, cut)
        out = mpi_run(mpirun, np_, exe, wd + "/" + key, fixed_scene(engine, PROCS[cut]))
        last = read_dump(os.path.join(wd, key, "final.%d" % FIXED_STEPS))
        res[key] = (thermo_rows(out), by_start(last, last),
                    read_vti(os.path.join(wd, key, "gas_%d.vti" % FIXED_STEPS)), out)
    t1, d1, v1, out1 = res["np1"]
    if len(d1) != 1458 or not t1 or t1[-1][1] <= 0:
        print("FAIL: the bed does not have 1458 grains or no pressure drop (%d grains, thermo %s)" % (len(d1), t1))
        return 1
    print("1 rank: dp %.10g Pa, %d PCG iterations, eps_mean %.10g, sum of drag z %.6g N" %
          (t1[-1][1], t1[-1][2], t1[-1][4], t1[-1][6]))
    fails = 0
    bound = FIXED_BOUND
    for key in res:
        if key == "np1":
            continue
        t, d, v, out = res[key]
        print("%s (%s) vs 1 rank:" % (key, CUT[key[3:]]))
        wd_ = compare_vec(d1, d, FIXED_COLS)
        wt = compare_thermo(t1, t, FIXED_THERMO, skip=(1, 2, 4))
        wv = max(rel_diff(v1[k], v[k]) for k in ("voidage", "pressure", "velocity"))
        iters = [r[2] for r in t]
        ok = wd_ <= bound and wt <= bound and wv <= max(bound, 1e-9) and len(t) == len(t1)
        print("%s %s: grain forces %.3e, thermo %.3e, VTK fields %.3e (bound %.2e; the file has 10 digits), PCG "
              "iterations %s vs %s" % ("PASS" if ok else "FAIL", key, wd_, wt, wv, bound, iters,
                                       [r[2] for r in t1]))
        fails += 0 if ok else 1
        # the grid is decomposed: the largest rank stores its block and halo, not the grid
        lc = local_cells(out)
        want = FIXED_LOCAL[key[3:]]
        ok = lc == (want, 144) and "halo exchange (rank 0)" in out
        print("%s %s: the largest rank stores %s cells of 144 (block and halo: %d)" %
              ("PASS" if ok else "FAIL", key, lc[0] if lc else "no line on the", want))
        fails += 0 if ok else 1
    # a processors grid whose subdomains are thinner than the gas stencil (1 of 4 cells along x per rank)
    rc, out = run(mpirun_cmd(mpirun, 4, exe), wd + "/thin", fixed_scene(engine, "processors 4 1 1"), timeout=120)
    want = "processors grid 4 x 1 x 1"
    crashed = rc < 0 or rc in (124, 134, 136, 137, 139) or "Segmentation" in out
    ok = rc != 0 and want in out and "thinner than the gas stencil" in out and "along x" in out and not crashed
    print("%s processors 4 1 1 on 4 cells along x: exit %d, message %s" %
          ("PASS" if ok else "FAIL", rc, "found" if ok else "MISSING"))
    if not ok:
        print(out[-2000:])
    fails += 0 if ok else 1
    if engine == "lammps":  # subdomains that are not a processor grid (LIGGGHTS has no other layout)
        rc, out = run(mpirun_cmd(mpirun, 2, exe), wd + "/tiled", fixed_scene(engine, "comm_style tiled"), timeout=120)
        crashed = rc < 0 or rc in (124, 134, 136, 137, 139) or "Segmentation" in out
        ok = rc != 0 and "comm_style tiled" in out and "is not supported" in out and not crashed
        print("%s comm_style tiled at 2 ranks: exit %d, message %s" % ("PASS" if ok else "FAIL", rc,
                                                                       "found" if ok else "MISSING"))
        if not ok:
            print(out[-2000:])
        fails += 0 if ok else 1
    # a failure of the core during a gas step at 2 ranks: every rank stops with the message, no hang
    rc, out = run(mpirun_cmd(mpirun, 2, exe), wd + "/stop", fixed_scene(engine, "", "cfl 1e-6"), timeout=120)
    want = "gas step at timestep 1 (gas dt 0.001): gas CFL"
    crashed = rc < 0 or rc in (124, 134, 136, 137, 139) or "Segmentation" in out
    ok = rc != 0 and want in out and not crashed
    print("%s a gas step beyond cfl at 2 ranks: exit %d, message %s" % ("PASS" if ok else "FAIL", rc,
                                                                       "found" if want in out else "MISSING: " + want))
    if not ok:
        print(out[-2000:])
    fails += 0 if ok else 1
    print("%s fixed bed at 1, 2 and 4 ranks (%s)" % ("PASS" if not fails else "FAIL", engine))
    return 1 if fails else 0


def bed_result(wd):
    """the final dump of a bed run keyed by the grains' start positions"""
    return by_start(read_dump(os.path.join(wd, "final.0")), read_dump(os.path.join(wd, "final.%d" % BED_STEPS)))


def bed_growth(exe, engine, wd, stir=BED_STIR):
    """the bed on one rank, and twice more on one rank: from positions moved by 1e-17 m (how far round-off grows in
    BED_STEPS), and with the other preconditioner (solver line: every pressure solve stops at another point within
    tol, as the block-Jacobi preconditioner of a decomposed grid does). The bound of the rank-count comparisons is
    10 times the larger growth (the difference enters at every gas step, not once), at least 1e-13 and at most 1e-7;
    returned with the 1-rank result and its thermo table"""
    out1 = mpi_run(None, 1, exe, wd + "/np1", bed_scene(engine, stir=stir))
    a = bed_result(wd + "/np1")
    mpi_run(None, 1, exe, wd + "/perturbed",
            bed_scene(engine, perturb="displace_atoms grains move 1e-17 0 1e-17 units box", stir=stir))
    print("1 rank, positions moved by 1e-17 m, vs 1 rank:")
    growth = compare_vec(a, bed_result(wd + "/perturbed"), BED_COLS)
    mpi_run(None, 1, exe, wd + "/line", bed_scene(engine, extra="solver line", stir=stir))
    print("1 rank, solver line (another stopping point within tol), vs 1 rank:")
    gtol = compare_vec(a, bed_result(wd + "/line"), BED_COLS)
    bound = min(max(10 * max(growth, gtol), 1e-13), 1e-7)
    print("growth over %d steps: round-off %.3e, solver stopping point %.3e -> bound %.3e" %
          (BED_STEPS, growth, gtol, bound))
    return bound, a, thermo_rows(out1)


BED_THERMO = ["dp", "iters", "eps_mean", "f_grains_z", "f_pg_z", "zmax"]


def test_mpi_bed(exe, engine, mpirun):
    wd = "cfd_mpi_bed_" + engine
    bound, a, t1 = bed_growth(exe, engine, wd)
    vmax = max(abs(r[5]) for r in a.values())
    fz = sum(r[8] for r in a.values())
    print("1 rank: %d grains, max |vz| %.4g m/s, sum of drag z %.4g N, thermo at the end %s" %
          (len(a), vmax, fz, t1[-1] if t1 else None))
    if len(a) != 512 or not (vmax > 1e-2 and fz > 0):
        print("FAIL: the bed did not move or felt no gas")
        return 1
    fails = 0
    cases = [(2, "x", False), (2, "z", False), (4, "xz", False)] + ([(2, "z", True)] if engine == "lammps" else [])
    for np_, cut, uneven in cases:
        key = "np%d%s%s" % (np_, cut, "_balance" if uneven else "")
        out = mpi_run(mpirun, np_, exe, wd + "/" + key,
                      bed_scene(engine, PROCS[cut], perturb=BALANCE_Z if uneven else ""))
        if uneven and "z cuts: 0.0000000 0.29200000 1.0000000" not in out:
            print("FAIL %s: the balance command did not cut z at 0.292" % key)
            fails += 1
            continue
        # grains on either side of each cut at the end, and grains that crossed a cut (they changed rank and took
        # their held gas forces with them)
        d0 = read_dump(os.path.join(wd, key, "final.0"))
        d1 = read_dump(os.path.join(wd, key, "final.%d" % BED_STEPS))
        axes = [(0 if c == "x" else 2, BALANCE_Z_CUT if uneven else BED_MID[c]) for c in cut]
        side = lambda r: tuple(r[a] > m for a, m in axes)  # noqa: E731
        moved = sum(1 for t in d1 if side(d1[t]) != side(d0[t]))
        per = {}
        for r in d1.values():
            per[side(r)] = per.get(side(r), 0) + 1
        cells = local_cells(out)
        if uneven:  # the gas layers split 3 / 7 (a cell by its centre): the upper rank stores its 7 and 2 halo layers
            want = (4 * 2 * (7 + 2), 4 * 2 * 10)
            if cells != want:
                print("FAIL %s: the largest rank stores %s cells of the grid, expected %s (7 layers of 4 x 2 and 2 "
                      "halo layers, of 10)" % (key, cells, want))
                fails += 1
                continue
        print("%s (%s%s) vs 1 rank: grains per subdomain %s, %d grains crossed a cut%s" %
              (key, CUT[cut], ", uneven: `%s`" % BALANCE_Z if uneven else "", sorted(per.values()), moved,
               ", the largest rank stores %d of the %d gas cells" % cells if uneven else ""))
        w = compare_vec(a, bed_result(wd + "/" + key), BED_COLS)
        wt = compare_thermo(t1, thermo_rows(out), BED_THERMO, skip=(1,))
        # every subdomain holds grains, and grains cross the cuts
        ok = w <= bound and wt <= bound and len(per) == np_ and moved > 0
        print("%s %s: grains %.3e, thermo %.3e (bound %.3e)" % ("PASS" if ok else "FAIL", key, w, wt, bound))
        fails += 0 if ok else 1
    print("%s bubbling bed at 1, 2 and 4 ranks (%s)" % ("PASS" if not fails else "FAIL", engine))
    return 1 if fails else 0


EX_STEPS = 1000
EX_BOUND = 1e-8


def test_mpi_example(exe, engine, mpirun, examples):
    """examples/bubbling_bed as written (9240 grains on a simple-cubic lattice, 15 x 3 x 68 gas cells, gas every 25
    steps), 1000 steps (4 ms, 40 gas steps: the gas takes the weight, the lattice starts to collapse) at 1 rank, 2
    (cut along x), 2 (cut along z) and 4 (x and z) ranks, each rank holding its block of the grid and a halo:
    grain positions, velocities and gas forces within EX_BOUND of the largest component of each vector of the
    1-rank run. The pressure solves of a decomposed grid stop at another point within tol = 1e-10 (block-Jacobi
    preconditioner), so each gas step starts from fields that differ by up to about kappa tol (1e-9 to 1e-8 for
    this 68-cell column, mpi_fixed derives it) and the bed carries that forward; the collapsing lattice is
    unstable, so the run stops early: at 1 rank a 1e-17 m move of the start grows to 5.9e-13 at step 1500, 7.5e-11
    at 2000, 1.2e-4 at 5000 (measured by hand). Measured: 7.0e-12 to 8.2e-12 of 1 rank at step 1000 (1.7e-11 to
    3.4e-11 at step 1500)."""
    with open(os.path.join(examples, "bubbling_bed", "in.bubbling_bed")) as f:
        text = f.read()
    edits = [(r"(?m)^variable tend\s+index\s+\S+", "variable tend    index %r" % (EX_STEPS * 4e-6)),
             (r"(?m)^variable nvtk\s+index\s+\S+", "variable nvtk    index 1000000"),
             (r"(?m)^dump .*$", "dump d grains custom %d final.* id x y z vx vy vz f_gas[1] f_gas[2] f_gas[3] f_gas[4] "
                                "f_gas[5] f_gas[6]" % EX_STEPS),
             (r"(?m)^dump_modify .*$", DUMPFMT[engine]),
             (r"(?m)^thermo\s+2500$", "thermo_modify format float %%.17g\nthermo %d" % (EX_STEPS // 4)),
             (r"(?m)^(create_box .*)$", "{procs}\n\\1")]
    for pat, rep in edits:
        text, n = re.subn(pat, rep, text, count=1)
        if n != 1:
            print("FAIL: examples/bubbling_bed has no line matching %s" % pat)
            return 1
    wd = "cfd_mpi_example_" + engine
    res = {}
    for np_, cut in [(1, ""), (2, "x"), (2, "z"), (4, "xz")]:
        key = "np%d%s" % (np_, cut)
        out = mpi_run(mpirun, np_, exe, wd + "/" + key, text.replace("{procs}", PROCS[cut]), timeout=300)
        first = read_dump(os.path.join(wd, key, "final.0"))
        last = read_dump(os.path.join(wd, key, "final.%d" % EX_STEPS))
        res[key] = (by_start(first, last), thermo_rows(out), out)
    a, t1, _ = res["np1"]
    vmax = max(abs(r[5]) for r in a.values())
    fz = sum(r[8] for r in a.values())
    print("1 rank: %d grains, max |vz| %.4g m/s, sum of drag z %.4g N" % (len(a), vmax, fz))
    if len(a) != 9240 or not (vmax > 1e-3 and fz > 0):
        print("FAIL: the bed did not move or felt no gas")
        return 1
    fails = 0
    for key in ("np2x", "np2z", "np4xz"):
        b, t, out = res[key]
        print("%s (%s) vs 1 rank:" % (key, CUT[key[3:]]))
        w = compare_vec(a, b, BED_COLS)
        ok = w <= EX_BOUND and len(t) == len(t1)
        print("%s %s: grains %.3e (bound %.0e), PCG iterations %s (1 rank %s)" %
              ("PASS" if ok else "FAIL", key, w, EX_BOUND, [int(r[3]) for r in t], [int(r[3]) for r in t1]))
        fails += 0 if ok else 1
        # the largest rank's block and halo of the 15 x 3 x 68 grid: 8 of 15 cells along x, 34 of 68 along z
        want = {"np2x": (8 + 2) * 3 * 68, "np2z": 15 * 3 * (34 + 2), "np4xz": (8 + 2) * 3 * (34 + 2)}[key]
        lc = local_cells(out)
        ok = lc == (want, 3060)
        print("%s %s: the largest rank stores %s of 3060 cells (block and halo %d)" %
              ("PASS" if ok else "FAIL", key, lc[0] if lc else "no line on the", want))
        fails += 0 if ok else 1
    print("%s examples/bubbling_bed at 1, 2 and 4 ranks (%s)" % ("PASS" if not fails else "FAIL", engine))
    return 1 if fails else 0


def test_mpi_restart(exe, engine, mpirun):
    """the bed written half way at 2 ranks, read at 1 and at 4 ranks, and written at 1 rank, read at 4 (the gas state
    is the whole grid in one layout at any rank count), against the unbroken 2-rank run"""
    wd = "cfd_mpi_restart_" + engine
    half = BED_STEPS // 2
    # the split falls between gas steps (every 25: 500 is one; 510 is not), so the held forces come from the file.
    # Not stirred: no grain touches another or a wall before the split. (The stirred bed, contacts across the split,
    # continues from a restart file 6e-4 off its unbroken run at one rank already, with the gas forces off: the
    # stock DEM styles' contact state, not the gas.)
    split = half + 10
    unbroken = bed_scene(engine, PROCS["x"], dumpevery=BED_STEPS, stir=0.0)
    mpi_run(mpirun, 2, exe, wd + "/unbroken", unbroken)
    # keyed by each grain's start position (a run begun at 1 rank numbers the atoms otherwise than one at 2)
    a = by_start(read_dump(os.path.join(wd, "unbroken", "final.0")),
                 read_dump(os.path.join(wd, "unbroken", "final.%d" % BED_STEPS)))
    first = bed_scene(engine, PROCS["x"], run="run %d\nwrite_restart half.restart" % split, stir=0.0)
    mpi_run(mpirun, 2, exe, wd + "/split", first)
    mpi_run(None, 1, exe, wd + "/split1", bed_scene(engine, run="run %d\nwrite_restart half.restart" % split, stir=0.0))
    bound = bed_growth(exe, engine, wd, stir=0.0)[0]
    fails = 0
    for np0, np_ in ((2, 1), (2, 4), (1, 4)):
        # the second half: the contacts, the gas fix and the output again; the restart file holds the atoms, their
        # held gas forces and contact history, the gas state
        tail = bed_scene(engine, run="run %d" % (BED_STEPS - split), stir=0.0)
        tail = tail[tail.index("timestep 4e-6"):]
        var = bed_scene(engine, stir=0.0)
        var = var[:var.index("units si")]
        second = (var + (PROCS["xz"] + "\n" if np_ == 4 else "") +
                  "read_restart ../%s/half.restart\n" % ("split" if np0 == 2 else "split1") +
                  "atom_modify sort 1000 0.004\nnewton off\n" + tail)
        sub = "read%d_from%d" % (np_, np0)
        os.makedirs(os.path.join(wd, sub), exist_ok=True)
        mpi_run(mpirun, np_, exe, os.path.join(wd, sub), second)
        b = by_start(read_dump(os.path.join(wd, "split" if np0 == 2 else "split1", "final.0")),
                     read_dump(os.path.join(wd, sub, "final.%d" % BED_STEPS)))
        print("written at %d ranks (step %d), read at %d, vs the unbroken 2-rank run:" % (np0, split, np_))
        w = compare_vec(a, b, BED_COLS)
        ok = w <= bound
        print("%s restart %d -> %d ranks: %.3e (bound %.3e)" % ("PASS" if ok else "FAIL", np0, np_, w, bound))
        fails += 0 if ok else 1
    print("%s restart across rank counts (%s)" % ("PASS" if not fails else "FAIL", engine))
    return 1 if fails else 0


def test_plugin(host, plugin, lmp):
    tail = ("variable vz equal vz[1]\nthermo_style custom step v_vz f_gas[1] f_gas[4] f_gas[11] f_gas[20]\n"
            "thermo_modify format float %.15g\nthermo 50\n")
    script = column("lammps", [(0.0015, 0.0015, 0.003)], steps=300, dt=5e-5, tail=tail, grid=(1, 1, 10),
                    box=(0.003, 0.003, 0.01), extra="every 2")
    out_l = must_run([lmp], "cfd_plugin/launcher", script)
    out_p = must_run([host, plugin], "cfd_plugin/plugin", script)
    if "registered fix cfd/grid" not in out_p:
        print("FAIL: the plugin did not register fix cfd/grid")
        return 1
    rl, rp = thermo_rows(out_l), thermo_rows(out_p)
    same = len(rl) == 7 and rl == rp and rl[-1][1] != 0
    print("%s fix cfd/grid via sphdemplugin.so: %d thermo rows %s the launcher's (last %s)" %
          ("PASS" if same else "FAIL", len(rp), "identical to" if same else "differ from", rp[-1] if rp else None))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(E.dispatch(sys.argv, globals(), __doc__))
