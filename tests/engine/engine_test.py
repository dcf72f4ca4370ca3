#!/usr/bin/env python3
"""engine_test.py - engine tests of fix sph/fluid through the lmp_sphdem / liggghts_sphdem launchers.

A tiny 2D dam break (204 fluid particles, 282 wall particles, 200 steps) run as
  same    LMP LIG          LAMMPS and LIGGGHTS give the same final x, v, density (1e-10)
  restart EXE ENGINE       write_restart at 100 + read_restart + 100 steps == 200 steps (1e-9)
  sync    EXE ENGINE       'sync 1' == default (1e-12)
  badkw   EXE ENGINE       bad input stops with a message naming the keyword and the choices
  plugin  HOST PLUGIN LMP  sphdemplugin.so loaded through lammpsplugin_init == lmp_sphdem (1e-12)
  couette EXE ENGINE       lid moved by 'fix move linear' (moving walls detected, uploaded each step):
                           velocity profile vs the Couette start-up series (L2 < 2 % of V0)
  example EXE ENGINE INPUT STEPS  an example input with its 'run' shortened to STEPS: runs to the end,
                           the fix reports its backend, the fluid moves or stays finite, no ERROR
  probe   EXE ENGINE       compute sph/probe on the hydrostatic start: p = rho0 g depth (2 %), and a
                           probe naming a fix that is not sph/fluid stops with a clear message
  every   EXE ENGINE       'every 1' == no keyword (0), and 'every 2' at dt/2 == 'every 1' at dt (0: the
                           fluid steps are then the same floating-point operations); 'every 3' at a
                           dt whose 3 dt exceeds the stable step stops with the message for N dt
  couple_same LMP LIG      the tiny dam break with 6 grains (fix sph/couple, every 2, nve/sphere, gravity):
                           LAMMPS == LIGGGHTS for fluid and grains (1e-10)
  couple_restart EXE ENGINE  the coupled scene split by write_restart/read_restart at step 100 == unbroken (1e-9)
  couple_momentum EXE ENGINE  (drag schiller-naumann, torque yes, superficial no) sum of the fluid forces
                           on the grains + sum of the reactions on the fluid = 0 (1e-10 of the former),
                           grains feel a force, porosity < 1 where they are
  couple_badkw EXE ENGINE  bad sph/couple input stops with a message naming the keyword and the choices
  settling EXE ENGINE INPUT  examples/settling shortened to t = 0.02 s: settling speed vs the
                           Schiller-Naumann ODE (3 %)
  drum_restart EXE ENGINE INPUT  examples/drum (coarse, 0.01 s settling, 0.01 s of rotation) in one run and
                           as a restart chain of two 0.005 s chunks (-var chunk, -var resume 1): the same
                           grains and fluid at the end (exact), the chain continued where it stopped
Differences are relative to the largest magnitude of each column (x, y, vx, vy, rho).
Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import re
import subprocess
import sys

STEPS = 200
HEAD = """# tiny 2D dam break: fluid column in a tank of 3 wall layers
dimension 2
units si
atom_style sphere
boundary f f p
atom_modify map array sort 50 0.02
"""
CREATE = """lattice sq 0.01 origin 0.5 0.5 0.0
region box block 0 0.4 0 0.3 -0.005 0.005 units box
create_box 2 box
region fl block 0.03 0.15 0.03 0.2 -0.005 0.005 units box
region wb block 0 0.4 0 0.03 -0.005 0.005 units box
region wl block 0 0.03 0.03 0.3 -0.005 0.005 units box
region wr block 0.37 0.4 0.03 0.3 -0.005 0.005 units box
create_atoms 1 region fl
create_atoms 2 region wb
create_atoms 2 region wl
create_atoms 2 region wr
group fluid type 1
group walls type 2
# LIGGGHTS recomputes the mass when the diameter is set: diameter first
set group all diameter 0.01
set group all mass 0.1
timestep 1e-4
"""
# no pair forces; reneighbor every 20 steps so the download / re-map / upload path runs
NEIGH = """pair_style none
neighbor 0.005 bin
neigh_modify every 20 delay 0 check no
"""
FIX = ("fix water fluid sph/fluid rho0 1000 h 0.013 c0 15 gravity 0 -9.81 0 visc artificial 0.05 "
       "wall walls hydrostatic 0.2 {extra}\n")
THERMO = "thermo_style custom step f_water[1] f_water[2] f_water[3] f_water[4]\nthermo 50\n"
# the engines differ in dump_modify format syntax
DUMPFMT = {"lammps": "dump_modify d sort id format float %.17g",
           "liggghts": 'dump_modify d sort id format "%d %.17g %.17g %.17g %.17g %.17g"'}
DUMP = "dump d fluid custom {every} final.* id x y vx vy f_water[1]\n{fmt}\n"


def scene(engine, extra="", steps=STEPS):
    return (HEAD + CREATE + NEIGH + FIX.format(extra=extra) + THERMO +
            DUMP.format(every=STEPS, fmt=DUMPFMT[engine]) + "run %d\n" % steps)


def run(cmd, workdir, script, timeout=240, env_extra=None):
    os.makedirs(workdir, exist_ok=True)
    with open(os.path.join(workdir, "in.test"), "w") as f:
        f.write(script)
    env = dict(os.environ)
    env.setdefault("OMP_NUM_THREADS", "1")
    env.update(env_extra or {})
    try:
        p = subprocess.run(cmd + ["-in", "in.test", "-log", "log.test"], cwd=workdir, env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=timeout)
    except subprocess.TimeoutExpired:
        return 124, "timed out after %d s" % timeout
    out = p.stdout.decode(errors="replace")
    with open(os.path.join(workdir, "out.test"), "w") as f:
        f.write(out)
    return p.returncode, out


def read_dump(path):
    rows = {}
    with open(path) as f:
        lines = f.read().splitlines()
    start = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS")) + 1
    for l in lines[start:]:
        w = l.split()
        if w:
            rows[int(w[0])] = [float(v) for v in w[1:]]
    return rows


def compare(a, b, what):
    """max over columns of max|a-b| / max|column| (the x, y, vx, vy, rho dumps of the dam-break scenes)"""
    if not a or not b:
        print("FAIL %s: empty dump" % what)
        return float("inf")
    return compare_cols(a, b, ["x", "y", "vx", "vy", "rho"][:len(next(iter(a.values())))])


def final_dump(workdir):
    return read_dump(os.path.join(workdir, "final.%d" % STEPS))


def must_run(cmd, workdir, script, timeout=240, no_error=False):
    """run, or exit 1 with the run's output where it fails (with no_error also where it prints an ERROR)"""
    rc, out = run(cmd, workdir, script, timeout=timeout)
    if rc != 0 or (no_error and "ERROR" in out):
        print("FAIL: run in %s exited %d:\n%s" % (workdir, rc, out[-3000:]))
        sys.exit(1)
    return out


def refused(exe, wd, what, script, want, crash_codes=None, timeout=60):
    """bad input: the run of script in wd must exit non-zero with want in its output (with crash_codes: and not by
    a signal, a segmentation fault or one of those exit codes); prints PASS/FAIL what, returns whether it passed"""
    rc, out = run([exe], wd, script, timeout=timeout)
    crashed = crash_codes is not None and (rc < 0 or rc in crash_codes or "Segmentation" in out)
    ok = rc != 0 and want in out and not crashed
    print("%s %s -> exit %d, %s" % ("PASS" if ok else "FAIL", what, rc,
                                     "message found" if want in out else "MISSING: " + want))
    if not ok:
        print(out[-1500:])
    return ok


def verdict(worst, tol, what):
    ok = worst <= tol
    print("%s %s: max relative difference %.3e (bound %.0e)" % ("PASS" if ok else "FAIL", what, worst, tol))
    return 0 if ok else 1


def moved(rows):
    """the scene must actually move, or equality would prove nothing"""
    vmax = max(abs(r[3]) for r in rows.values())
    print("  max |vy| at step %d: %.4g m/s" % (STEPS, vmax))
    return vmax > 0.05


def test_same(lmp, lig):
    must_run([lmp], "same/lammps", scene("lammps"))
    must_run([lig], "same/liggghts", scene("liggghts"))
    a, b = final_dump("same/lammps"), final_dump("same/liggghts")
    if not moved(a):
        print("FAIL: the fluid did not move")
        return 1
    return verdict(compare(a, b, "LAMMPS vs LIGGGHTS"), 1e-10, "LAMMPS vs LIGGGHTS")


def split_run(exe, wd, unbroken, first, second, load, moved):
    """the scene in one run (wd/unbroken) and split in two by a restart file (wd/split): the two final dumps (load
    of the folder), or None where the unbroken run did not move (it says so)"""
    must_run([exe], wd + "/unbroken", unbroken)
    must_run([exe], wd + "/split", first)
    must_run([exe], wd + "/split", second)
    a, b = load(wd + "/unbroken"), load(wd + "/split")
    if not moved(a):
        print("FAIL: the fluid did not move")
        return None
    return a, b


def test_restart(exe, engine):
    first = HEAD + CREATE + NEIGH + FIX.format(extra="") + THERMO + "run %d\nwrite_restart half.restart\n" % (STEPS // 2)
    # LIGGGHTS does not restore the timestep from a restart file
    second = ("read_restart half.restart\natom_modify sort 50 0.02\ntimestep 1e-4\n" + NEIGH + FIX.format(extra="") + THERMO +
              DUMP.format(every=STEPS, fmt=DUMPFMT[engine]) + "run %d\n" % (STEPS // 2))
    ab = split_run(exe, "restart_" + engine, scene(engine), first, second, final_dump, moved)
    if ab is None:
        return 1
    a, b = ab
    return verdict(compare(a, b, "restart"), 1e-9, "restart at step %d vs unbroken (%s)" % (STEPS // 2, engine))


def check_timing(out, steps, what):
    """The split fix sph/fluid prints at the end of a run: present, one entry per phase, the parts add up to the
    total (each printed to 4 digits), and it counts the run's fluid steps."""
    m = re.search(r"Fix sph/fluid timing \(s, this run\): (.*); total ([0-9.eE+-]+) over (\d+) fluid steps", out)
    if not m:
        print("FAIL %s: no 'Fix sph/fluid timing' line" % what)
        return 1
    parts = dict((k, float(v)) for k, v in re.findall(r"(\w+) ([0-9.eE+-]+)", m.group(1)))
    total, nsteps = float(m.group(2)), int(m.group(3))
    names = ["sort", "walls", "rates", "coupling", "integrate", "transfer", "reduce"]
    ok = (sorted(parts) == sorted(names) and total > 0 and nsteps == steps and
          abs(sum(parts.values()) - total) <= 2e-3 * total + 1e-6)
    print("%s %s: timing line %s, total %.4g s over %d fluid steps (want %d)" %
          ("PASS" if ok else "FAIL", what, parts, total, nsteps, steps))
    return 0 if ok else 1


def test_sync(exe, engine):
    wd = "sync_" + engine
    out = must_run([exe], wd + "/default", scene(engine))
    must_run([exe], wd + "/sync1", scene(engine, "sync 1"))
    a, b = final_dump(wd + "/default"), final_dump(wd + "/sync1")
    fails = check_timing(out, STEPS, "end-of-run timing (%s)" % engine)
    return fails + verdict(compare(a, b, "sync"), 1e-12, "sync 1 vs default (%s)" % engine)


def test_badkw(exe, engine):
    cases = [
        ("visc foo", "Fix sph/fluid: visc must be none, morris MU or artificial ALPHA"),
        ("bogus 1", "Fix sph/fluid: unknown keyword 'bogus'; keywords are rho0, h, c0"),
        ("device tpu", "Fix sph/fluid: device must be auto, cpu or gpu"),
        ("cfl abc", "Fix sph/fluid: cfl expects a number, got 'abc'"),
        ("cfl 2", "Fix sph/fluid: cfl must be in (0, 1]"),
        ("wall nosuchgroup", "Fix sph/fluid: wall group 'nosuchgroup' does not exist"),
        ("isolated 1.5", "Fix sph/fluid: isolated (kernel-sum threshold) must be in [0, 1) (got 1.5)"),
    ]
    fails = sum(not refused(exe, "badkw_%s/%d" % (engine, i), "'%s'" % extra, scene(engine, extra, steps=1), want)
                for i, (extra, want) in enumerate(cases))
    # a second integrator on the fluid
    rc, out = run([exe], "badkw_%s/nve" % engine, scene(engine, steps=1).replace("run 1", "fix 1 all nve\nrun 1"),
                  timeout=60)
    want = "Fix sph/fluid integrates its own group; fix 1 (style nve) also integrates atoms of group all"
    ok = rc != 0 and want in out
    print("%s fix nve on all -> exit %d, %s" % ("PASS" if ok else "FAIL", rc, "message found" if ok else out[-1500:]))
    fails += 0 if ok else 1
    # a missing required keyword
    rc, out = run([exe], "badkw_%s/required" % engine, scene(engine).replace("c0 15 ", ""), timeout=60)
    want = "Fix sph/fluid: missing required keyword(s): c0"
    ok = rc != 0 and want in out
    print("%s missing c0 -> exit %d, %s" % ("PASS" if ok else "FAIL", rc, "message found" if ok else out[-1500:]))
    return 1 if fails or not ok else 0


def test_plugin(host, plugin, lmp):
    must_run([lmp], "plugin/launcher", scene("lammps"))
    out = must_run([host, plugin], "plugin/plugin", scene("lammps"))
    if "registered fix sph/fluid" not in out:
        print("FAIL: the plugin did not register fix sph/fluid")
        return 1
    a, b = final_dump("plugin/launcher"), final_dump("plugin/plugin")
    fails = verdict(compare(a, b, "plugin"), 1e-12, "sphdemplugin.so vs lmp_sphdem")
    # the GPU DEM pair styles through the plugin: examples/dem_drop shortened, thermo equal to the launcher's
    import re
    inp = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples", "dem_drop", "in.dem_drop")
    with open(inp) as f:
        text = re.sub(r"(?m)^variable steps index \S+", "variable steps index 3000", f.read())
    text = re.sub(r"(?m)^thermo\s+\S+", "thermo 500", text)
    out_l = must_run([lmp], "plugin/dem_launcher", text)
    out_p = must_run([host, plugin], "plugin/dem_plugin", text)
    if "registered pair gran/hertz/history/gpu" not in out_p:
        print("FAIL: the plugin did not register pair gran/hertz/history/gpu")
        return 1
    rl, rp = thermo_rows(out_l), thermo_rows(out_p)
    same = len(rl) >= 6 and rl == rp
    print("%s dem_drop (pair gran/hertz/history/gpu) via the plugin: %d thermo rows %s the launcher's" %
          ("PASS" if same else "FAIL", len(rp), "identical to" if same else "differ from"))
    return fails + (0 if same else 1)


# two 10 mm grains 0.1 mm apart along x (the DEM pair tests): a head-on collision and an oblique one with spin
TWO_GRAINS = {
    "headon": """create_atoms 1 single -0.00505 0 0 units box
create_atoms 1 single 0.00505 0 0 units box
velocity all set 0 0 0
set atom 1 vx 1.0
set atom 2 vx -1.0
""",
    "oblique": """create_atoms 1 single -0.00505 0.004 0.001 units box
create_atoms 1 single 0.00505 0 0 units box
velocity all set 0 0 0
set atom 1 vx 1.5
set atom 1 vy -0.3
set atom 1 omega 0 0 200
set atom 2 omega -100 0 0
""",
}


# LAMMPS: a pour into an empty periodic box (after examples/granular/in.pour), 1000 grains falling onto a
# wall/gran floor; NEWTON a "newton ..." line or "", PAIR_STYLE / PAIR_COEFF the words after pair_style and
# pair_coeff; braces of further fields doubled ({{steps}} stays a field)
POUR_LJ = """units           lj
atom_style      sphere
boundary        p p fm
{newton}comm_modify     vel yes
region          reg block -10 10 -10 10 -0.5 16 units box
create_box      1 reg
neighbor        0.2 bin
neigh_modify    delay 0
pair_style      {pair_style}
pair_coeff      {pair_coeff}
timestep        0.001
fix             1 all nve/sphere
fix             2 all gravity 1.0 spherical 0.0 -180.0
fix             zlower all wall/gran hertz/history 2000.0 NULL 50.0 NULL 0.5 0 zplane 0.0 2000.0
region          slab block -9.0 9.0 -9.0 9.0 10.0 15.0
fix             ins all pour 1000 1 300719 vol 0.13 50 region slab
thermo_style    custom step atoms ke
thermo_modify   lost ignore norm no format float %.12g
thermo          1000
run             {steps}
write_dump all custom final.dump id x y z vx vy vz omegax omegay omegaz modify sort id format float %.17g
"""


class Checks:
    """a test's PASS/FAIL lines and their count: check(cond, what, out) prints the line (with the last `tail` lines
    of out on a failure) and returns cond; .fails counts the failures"""

    def __init__(self, tail=6):
        self.fails, self.tail = 0, tail

    def __call__(self, cond, what, out=""):
        print("%s %s" % ("PASS" if cond else "FAIL", what))
        if not cond:
            self.fails += 1
            if out:
                print("     " + "\n     ".join(out.splitlines()[-self.tail:]))
        return cond


def lig_materials(young="5e6", poisson="0.45", restitution="0.7", friction="0.5"):
    """the four LIGGGHTS material tables of a one-type granular scene (fix m1 .. m4 property/global)"""
    return ("fix m1 all property/global youngsModulus peratomtype %s\n"
            "fix m2 all property/global poissonsRatio peratomtype %s\n"
            "fix m3 all property/global coefficientRestitution peratomtypepair 1 %s\n"
            "fix m4 all property/global coefficientFriction peratomtypepair 1 %s\n") % (young, poisson, restitution,
                                                                                     friction)


def dem_dump(path):
    """rows [id x y z vx vy vz omegax omegay omegaz] of a dump custom of those columns (the DEM engine tests)"""
    lines = [l.strip() for l in open(path).read().splitlines()]
    i = lines.index("ITEM: ATOMS id x y z vx vy vz omegax omegay omegaz")
    return [[float(v) for v in l.split()] for l in lines[i + 1:] if l.strip()]


def thermo_words(out):
    """the rows (as words) of the first thermo table in out, up to its 'Loop time' line"""
    rows, on = [], False
    for l in out.splitlines():
        if l.split()[:1] == ["Step"]:
            on = True
            continue
        if on:
            if l.startswith("Loop time"):
                break
            rows.append(l.split())
    return rows


def thermo_rows(log_text):
    """Numeric rows of the thermo table that follows the last 'Step' header."""
    rows, on = [], False
    for line in log_text.splitlines():
        words = line.split()
        if words[:1] == ["Step"]:
            rows, on = [], True
            continue
        if on:
            try:
                rows.append([float(w) for w in words])
            except ValueError:
                on = False
    return rows


COUETTE = """# Couette start-up: periodic channel, lid moved by fix move
dimension 2
units si
atom_style sphere
boundary p f p
atom_modify map array sort 50 {dx}
lattice sq {dx} origin 0.5 0.5 0.0
region box block 0 {lx} {ylo} {yhi} {zlo} {zhi} units box
create_box 3 box
region fl block 0 {lx} 0 {L} {zlo} {zhi} units box
region wb block 0 {lx} {ylo} 0 {zlo} {zhi} units box
region wt block 0 {lx} {L} {yhi} {zlo} {zhi} units box
create_atoms 1 region fl
create_atoms 2 region wb
create_atoms 3 region wt
group fluid type 1
group walls type 2 3
group lid type 3
set group all diameter {dx}
set group all mass {m}
pair_style none
neighbor {dx} bin
neigh_modify every 20 delay 0 check no
fix water fluid sph/fluid rho0 1000 h {h} dx {dx} c0 {c0} visc morris 1e-3 wall walls
fix lid lid move linear {V0} 0 0 units box
timestep {dt}
thermo 100
dump d fluid custom {n} final.* id x y vx vy f_water[1]
{fmt}
run {n}
"""


def couette_exact(y, t, V0=1.25e-5, nu=1e-6, L=1e-3):
    import math
    u = V0 * y / L
    for n in range(1, 400):
        u += 2 * V0 / (n * math.pi) * (-1) ** n * math.sin(n * math.pi * y / L) * \
            math.exp(-nu * n * n * math.pi ** 2 * t / L ** 2)
    return u


def test_couette(exe, engine):
    L, res, V0, dt, n = 1e-3, 30, 1.25e-5, 2.5e-4, 450
    dx = L / res
    script = COUETTE.format(dx=repr(dx), lx=repr(20 * dx), ylo=repr(-4 * dx), yhi=repr(L + 4 * dx),
                            zlo=repr(-0.5 * dx), zhi=repr(0.5 * dx), L=repr(L), m=repr(1000 * dx * dx),
                            h=repr(1.5 * dx), c0=repr(100 * V0), V0=repr(V0), dt=repr(dt), n=n,
                            fmt=DUMPFMT[engine])
    wd = "couette_" + engine
    must_run([exe], wd, script)
    rows = list(read_dump(os.path.join(wd, "final.%d" % n)).values())  # x y vx vy rho
    if len(rows) != 20 * res:
        print("FAIL: expected %d fluid atoms in the dump, got %d" % (20 * res, len(rows)))
        return 1
    t = n * dt
    e2 = sum((r[2] - couette_exact(r[1], t)) ** 2 for r in rows)
    l2 = (e2 / len(rows)) ** 0.5 / V0
    print("Couette at t = %.4f s through %s: L2 error %.3f%% of V0 (bound 2%%)" % (t, engine, 100 * l2))
    return verdict(l2, 0.02, "Couette profile")


def test_example(exe, engine, inp, steps):
    import re
    name = os.path.basename(os.path.dirname(os.path.abspath(inp)))
    wd = "example_%s_%s" % (name, engine)
    with open(inp) as f:
        text = f.read()
    short, nrun = re.subn(r"(?m)^run\s+\S+", "run %d" % int(steps), text)
    if nrun == 0:
        print("FAIL: no 'run' line in %s" % inp)
        return 1
    out = must_run([exe], wd, short)
    if "ERROR" in out or ("Fix sph/fluid:" not in out and "Fix cfd/grid:" not in out):
        print("FAIL: %s did not report the fix set-up or printed an ERROR:\n%s" % (inp, out[-2000:]))
        return 1
    rows = thermo_rows(out)
    if not rows or int(rows[-1][0]) < int(steps):
        print("FAIL: %s: thermo output did not reach step %s" % (inp, steps))
        return 1
    bad = [r for r in rows if any(v != v or abs(v) == float("inf") for v in r)]
    if bad:
        print("FAIL: %s: non-finite thermo values %s" % (inp, bad[0]))
        return 1
    print("PASS: %s through %s, %d thermo rows, last %s" % (name, engine, len(rows), rows[-1]))
    return 0


def test_wallclamp(exe, engine, inp):
    """examples/dambreak2d to t = 0.2 s with wall_clamp no and yes: fluid particles on the left wall more than
    1 cm above the water column (the wall-clinging artefact of a negative Adami wall pressure): some without
    the clamp, none with it; the surge front moves less than 1 % between the two"""
    res = {}
    for c in ("no", "yes"):
        wd = "wallclamp_%s_%s" % (engine, c)
        with open(inp) as f:
            text = f.read()
        text = text.replace("variable clamp  index no", "variable clamp  index %s" % c)
        import re
        text = re.sub(r"(?m)^run\s+\S+", "run 5168", text)
        must_run([exe], wd, text)
        rows = open(os.path.join(wd, "dump.dambreak2d.5168")).read().splitlines()
        i = next(k for k, l in enumerate(rows) if l.startswith("ITEM: ATOMS"))
        cols = rows[i].split()[2:]
        fluid = [dict(zip(cols, map(float, l.split()))) for l in rows[i + 1:] if l.strip()]
        fluid = [r for r in fluid if int(r["type"]) == 1]
        ys = sorted(r["y"] for r in fluid if 0.01 < r["x"] < 0.03)
        top = ys[int(0.98 * len(ys))]
        cling = sum(1 for r in fluid if r["x"] < 0.005 and r["y"] > top + 0.01)
        front = max(r["x"] for r in fluid)
        res[c] = (cling, front)
        print("wall_clamp %s: column top %.3f m, %d particles on the wall above it, front x %.4f m" % (c, top, cling, front))
    ok = res["no"][0] > 0 and res["yes"][0] == 0 and abs(res["yes"][1] / res["no"][1] - 1) < 0.01
    print("%s: wall_clamp removes the clinging particles without moving the front" % ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


def test_probe(exe, engine):
    wd = "probe_" + engine
    probe = ("compute p all sph/probe water 0.09 0.1 0 0.09 0.05 0\n"
             "thermo_style custom step c_p[1][1] c_p[2][1] c_p[1][2] c_p[1][6]\nrun 0\n")
    script = HEAD + CREATE + NEIGH + FIX.format(extra="") + probe
    out = must_run([exe], wd, script)
    rows = thermo_rows(out)
    if not rows or len(rows[-1]) < 5:
        print("FAIL: no probe values in the thermo output")
        return 1
    step, p1, p2, rho1, shep = rows[-1][:5]
    worst = 0.0
    for p, depth in ((p1, 0.1), (p2, 0.15)):
        exact = 1000 * 9.81 * depth
        err = abs(p - exact) / exact
        print("probe depth %.2f m: p = %.2f Pa, rho0 g depth = %.2f Pa (%.2f%%)" % (depth, p, exact, 100 * err))
        worst = max(worst, err)
    B = 15.0 ** 2 * 1000 / 7  # Tait B of the scene (c0 15)
    rho_exact = 1000 * (1 + 1000 * 9.81 * 0.1 / B) ** (1 / 7)
    print("density at probe 1: %.4f, hydrostatic %.4f; Shepard sum %.4f" % (rho1, rho_exact, shep))
    if worst > 0.02 or not (0.9 < shep < 1.1) or abs(rho1 - rho_exact) > 1e-3 * rho_exact:
        print("FAIL: probe values off")
        return 1
    bad = HEAD + CREATE + NEIGH + FIX.format(extra="") + "fix nothing walls setforce 0 0 0\n" + \
        "compute p all sph/probe nothing 0.09 0.1 0\nthermo_style custom step c_p[1][1]\nrun 0\n"
    rc, text = run([exe], wd + "_bad", bad)
    if rc == 0 or "is not a fix sph/fluid" not in text:
        print("FAIL: a probe on a fix that is not sph/fluid did not stop with a clear message")
        return 1
    print("PASS: probe values and error message")
    return 0


# ---- fix sph/couple ------------------------------------------------------------------------------
# The tiny dam break with three atom types and 6 grains (d = 6 mm, rho_p 2500, mass per unit depth)
# inside the water column; every 2 sub-cycling: the engine timestep is half the fluid step.
COUPLE_CREATE = CREATE.replace("create_box 2 box", "create_box 3 box").replace(
    "timestep 1e-4\n", "") + """create_atoms 3 single 0.06 0.08 0.0 units box
create_atoms 3 single 0.09 0.08 0.0 units box
create_atoms 3 single 0.12 0.08 0.0 units box
create_atoms 3 single 0.06 0.12 0.0 units box
create_atoms 3 single 0.09 0.12 0.0 units box
create_atoms 3 single 0.12 0.12 0.0 units box
group grains type 3
group moving type 1 3
set group grains diameter 0.006
set group grains mass 0.0706858347
timestep 5e-5
"""
COUPLE_FIX = ("fix water fluid sph/fluid rho0 1000 h 0.013 c0 15 gravity 0 -9.81 0 visc artificial 0.05 "
              "wall walls hydrostatic 0.2 every 2\n"
              "fix couple grains sph/couple water mu 1e-3 {extra}\n"
              "fix grav grains gravity 9.81 vector 0 -1 0\n"
              "fix nvs grains nve/sphere\n")
COUPLE_THERMO = ("thermo_style custom step f_couple[1] f_couple[2] f_couple[4] f_couple[5] f_couple[7] f_couple[8] "
                 "f_couple[10] f_couple[14]\nthermo 50\n")
COUPLE_NSTEPS = 400
COUPLE_DUMPFMT = {"lammps": "dump_modify d sort id format float %.17g",
                  "liggghts": 'dump_modify d sort id format "%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g"'}
COUPLE_DUMP = ("dump d moving custom {every} final.* id x y vx vy f_water[1] f_water[3] f_couple[1] f_couple[2]\n"
               "{fmt}\n")


def couple_scene(engine, extra="", steps=COUPLE_NSTEPS):
    return (HEAD + COUPLE_CREATE + NEIGH + COUPLE_FIX.format(extra=extra) + COUPLE_THERMO +
            COUPLE_DUMP.format(every=COUPLE_NSTEPS, fmt=COUPLE_DUMPFMT[engine]) + "run %d\n" % steps)


def compare_cols(a, b, names):
    """max over columns of max|a-b| / max|column| (any number of columns)"""
    if sorted(a) != sorted(b):
        print("FAIL: different atom ids")
        return float("inf")
    worst = 0.0
    for c, name in enumerate(names):
        scale = max(max(abs(r[c]) for r in a.values()), max(abs(r[c]) for r in b.values()), 1e-300)
        d = max(abs(a[t][c] - b[t][c]) for t in a) / scale
        print("  %-6s max relative difference %.3e" % (name, d))
        worst = max(worst, d)
    return worst


COUPLE_COLS = ["x", "y", "vx", "vy", "rho", "eps", "Fx", "Fy"]


def grains_moved(rows):
    """the grains (ids above the fluid and walls: rho column 0) must have moved and felt the fluid"""
    g = [r for r in rows.values() if r[4] == 0.0]
    if len(g) != 6:
        print("FAIL: expected 6 grains in the dump, found %d" % len(g))
        return False
    vmax = max(abs(r[3]) for r in g)
    fmax = max(abs(r[7]) for r in g)
    print("  grains: max |vy| %.4g m/s, max |Fy fluid| %.4g N (per unit depth)" % (vmax, fmax))
    return vmax > 1e-3 and fmax > 0


def test_every(exe, engine):
    wd = "every_" + engine
    must_run([exe], wd + "/none", scene(engine))
    must_run([exe], wd + "/every1", scene(engine, "every 1"))
    a, b = final_dump(wd + "/none"), final_dump(wd + "/every1")
    if not moved(a):
        print("FAIL: the fluid did not move")
        return 1
    fails = verdict(compare(a, b, "every 1"), 0.0, "every 1 vs no keyword (%s)" % engine)
    half = scene(engine, "every 2", steps=2 * STEPS).replace("timestep 1e-4", "timestep 5e-5").replace(
        "dump d fluid custom %d" % STEPS, "dump d fluid custom %d" % (2 * STEPS))
    must_run([exe], wd + "/every2", half)
    c = read_dump(os.path.join(wd, "every2", "final.%d" % (2 * STEPS)))
    fails += verdict(compare(a, c, "every 2"), 0.0, "every 2 at dt/2 vs every 1 at dt (%s)" % engine)
    # the stability check judges the fluid step N dt: 3e-4 s exceeds the stable 2.2e-4 s of this scene
    rc, out = run([exe], wd + "/every3", scene(engine, "every 3", steps=10), timeout=60)
    want = "With every 3 the fluid step is 3 x timestep: set the timestep to"
    ok = rc != 0 and "exceeds the stable SPH time step" in out and want in out
    print("%s every 3 at dt 1e-4 stops with the N dt stability message (%s)" % ("PASS" if ok else "FAIL", engine))
    if not ok:
        print(out[-1500:])
    return 1 if fails or not ok else 0


def couple_final(workdir):
    return read_dump(os.path.join(workdir, "final.%d" % COUPLE_NSTEPS))


def test_couple_same(lmp, lig):
    must_run([lmp], "couple_same/lammps", couple_scene("lammps"))
    must_run([lig], "couple_same/liggghts", couple_scene("liggghts"))
    a, b = couple_final("couple_same/lammps"), couple_final("couple_same/liggghts")
    if not grains_moved(a):
        print("FAIL: the grains did not move or felt no fluid force")
        return 1
    return verdict(compare_cols(a, b, COUPLE_COLS), 1e-10, "coupled scene, LAMMPS vs LIGGGHTS")


def test_couple_restart(exe, engine):
    wd = "couple_restart_" + engine
    must_run([exe], wd + "/unbroken", couple_scene(engine))
    half = COUPLE_NSTEPS // 2
    first = (HEAD + COUPLE_CREATE + NEIGH + COUPLE_FIX.format(extra="") + COUPLE_THERMO +
             "run %d\nwrite_restart half.restart\n" % half)
    must_run([exe], wd + "/split", first)
    second = ("read_restart half.restart\natom_modify sort 50 0.02\ntimestep 5e-5\n" + NEIGH +
              COUPLE_FIX.format(extra="") + COUPLE_THERMO +
              COUPLE_DUMP.format(every=COUPLE_NSTEPS, fmt=COUPLE_DUMPFMT[engine]) + "run %d\n" % half)
    must_run([exe], wd + "/split", second)
    a, b = couple_final(wd + "/unbroken"), couple_final(wd + "/split")
    if not grains_moved(a):
        print("FAIL: the grains did not move or felt no fluid force")
        return 1
    return verdict(compare_cols(a, b, COUPLE_COLS), 1e-9,
                   "coupled restart at step %d vs unbroken (%s)" % (half, engine))


def test_couple_momentum(exe, engine):
    wd = "couple_momentum_" + engine
    # the other drag law paths, torque and the porosity reported only (superficial no)
    out = must_run([exe], wd, couple_scene(engine, "drag schiller-naumann torque yes superficial no"))
    rows = thermo_rows(out)
    if len(rows) < 5:
        print("FAIL: no thermo rows")
        return 1
    worst, fmax, epsmin, ngr = 0.0, 0.0, 1.0, 0
    for r in rows:
        step, fgx, fgy, ffx, ffy, fnx, fny, eps, ng = r[:9]
        f = max(abs(fgx), abs(fgy))
        fmax = max(fmax, f)
        if f > 0:
            worst = max(worst, max(abs(fnx), abs(fny)) / f,
                        max(abs(fgx + ffx), abs(fgy + ffy)) / f)
        epsmin = min(epsmin, eps)
        ngr = int(ng)
    print("coupled scene (%s): max |F grains| %.4g N, max |net| / |F grains| %.2e, min porosity %.4f, %d grains"
          % (engine, fmax, worst, epsmin, ngr))
    ok = fmax > 0 and worst <= 1e-10 and epsmin < 0.999 and ngr == 6
    print("%s momentum balance of the coupling (bound 1e-10)" % ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


def test_couple_badkw(exe, engine):
    cases = [
        ("drag foo", "Fix sph/couple: drag must be ergun-wenyu, difelice, schiller-naumann or none (got 'foo')"),
        ("superficial maybe", "Fix sph/couple: superficial must be yes or no (got 'maybe')"),
        ("torque 1", "Fix sph/couple: torque must be yes or no (got '1')"),
        ("eps_min 1.5", "Fix sph/couple: eps_min must be in (0, 1) (got 1.5)"),
        ("hc -1", "Fix sph/couple: hc must be > 0 (got -1)"),
        ("mu abc", "Fix sph/couple: mu expects a number, got 'abc' (usage: mu V)"),
        ("dmax", "Fix sph/couple: missing value for dmax (usage: dmax V)"),
        ("wall_porosity yes", "Fix sph/couple: wall_porosity must be none or fluid (got 'yes')"),
        ("immersion 2", "Fix sph/couple: immersion must be in [0, 1], 0 = off (got 2)"),
        ("eps_walls on", "Fix sph/couple: eps_walls must be yes or no (got 'on')"),
        ("pressure_form vol", "Fix sph/couple: pressure_form must be mass or volume (got 'vol')"),
        ("bogus 1", "Fix sph/couple: unknown keyword 'bogus'; keywords are drag, mu, hc, eps_min, superficial, "
                    "torque, dmax, wall_porosity, immersion, eps_walls, pressure_form"),
    ]
    fails = sum(not refused(exe, "couple_badkw_%s/%d" % (engine, i), "'%s'" % extra,
                            couple_scene(engine, extra, steps=1), want) for i, (extra, want) in enumerate(cases))
    base = couple_scene(engine, steps=1)
    scripts = [
        ("fluid fix missing", base.replace("sph/couple water", "sph/couple nosuch"),
         "Fix sph/couple: fix ID 'nosuch' does not exist"),
        ("not a fluid fix", base.replace("sph/couple water", "sph/couple grav"),
         "Fix sph/couple: fix 'grav' is not a fix sph/fluid (its style is gravity)"),
        ("no viscosity", base.replace("sph/couple water mu 1e-3", "sph/couple water"),
         "Fix sph/couple: drag ergun-wenyu needs the fluid viscosity: give mu V, or use visc morris MU"),
        ("defined before the fluid", base.replace("fix couple grains sph/couple water mu 1e-3 \n", "").replace(
            "fix water fluid", "fix couple grains sph/couple water mu 1e-3\nfix water fluid"),
         "Fix sph/couple: define fix couple after fix sph/fluid water"),
        ("grains overlap the fluid", base.replace("fix couple grains sph/couple", "fix couple moving sph/couple"),
         "Fix sph/couple: the grain group moving overlaps the fluid or wall group of fix sph/fluid water"),
        ("two couplers", base.replace("fix grav grains", "fix couple2 grains sph/couple water mu 1e-3\n"
                                                         "fix grav grains"),
         "is already coupled by another fix sph/couple"),
        ("every 0", base.replace("hydrostatic 0.2 every 2", "hydrostatic 0.2 every 0"),
         "Fix sph/fluid: every expects an integer N >= 1, got '0' (usage: every N)"),
    ]
    fails += sum(not refused(exe, "couple_badkw_%s/s%d" % (engine, i), what, script, want)
                 for i, (what, script, want) in enumerate(scripts))
    return 1 if fails else 0


def settling_ode(t_end, d=0.001, rhop=2500.0, rhof=1000.0, mu=8.9e-4, g=9.81, dt=1e-6):
    """Schiller-Naumann single-sphere ODE (data/reference/closed_forms.md), RK4; downward speed at t_end"""
    def acc(v):
        re = rhof * d * abs(v) / mu
        cdw = 24.0 * mu / (rhof * d) * (1.0 + 0.15 * re ** 0.687) if re > 0 else 24.0 * mu / (rhof * d)
        return g * (rhop - rhof) / rhop - 0.75 * rhof * v * cdw / (d * rhop)
    v, t = 0.0, 0.0
    while t < t_end - 0.5 * dt:
        k1 = acc(v)
        k2 = acc(v + 0.5 * dt * k1)
        k3 = acc(v + 0.5 * dt * k2)
        k4 = acc(v + dt * k3)
        v += dt * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
        t += dt
    return v


def test_settling(exe, engine, inp):
    """The sphere's speed at t = 0.02 s vs the ODE, with the default pair terms and with pressure_form volume."""
    fails = 0
    for pform in ("mass", "volume"):
        wd = "settling_%s_%s" % (engine, pform)
        os.makedirs(wd, exist_ok=True)
        rc, out = run([exe, "-var", "tend", "0.02", "-var", "pform", pform], wd, open(inp).read(), timeout=400)
        if rc != 0:
            print("FAIL: settling run (pressure_form %s) exited %d:\n%s" % (pform, rc, out[-3000:]))
            fails += 1
            continue
        if "pressure_form %s;" % pform not in out:
            print("FAIL: the fix sph/couple set-up line does not report pressure_form %s" % pform)
            fails += 1
        rows = []
        with open(os.path.join(wd, "settling.dat")) as f:
            for l in f:
                if not l.startswith("#") and l.strip():
                    rows.append([float(w) for w in l.split()])
        t, vz = rows[-1][1], rows[-1][3]
        exact = settling_ode(t)
        err = abs(-vz - exact) / exact
        print("settling (%s, pressure_form %s): t = %.4f s, v = %.5f m/s, Schiller-Naumann ODE %.5f m/s, error %.2f%% "
              "(bound 3%%)" % (engine, pform, t, -vz, exact, 100 * err))
        fails += verdict(err, 0.03, "settling speed vs ODE (pressure_form %s)" % pform)
    return fails


def test_drum_restart(exe, engine, inp):
    text = open(inp).read()
    coarse = {"dg": 0.0054, "ngrain": 969, "dx": 0.006, "dt": 1e-5, "every": 2, "tsettle": 0.01, "trot": 0.01,
              "tavg": 0.01, "nsamp": 2, "nfluid": 1}
    def script(extra):
        v = dict(coarse, **extra)
        return "".join("variable %s index %s\n" % (k, v[k]) for k in v) + text
    wa, wb = "drum_restart_%s_unbroken" % engine, "drum_restart_%s_chain" % engine
    must_run([exe], wa, script({}))
    out1 = must_run([exe], wb, script({"chunk": 0.005}))
    out2 = must_run([exe], wb, script({"chunk": 0.005, "resume": 1}))
    starts = [re.search(r"drum: rotation from step (\d+)", o) for o in (out1, out2)]
    if not all(starts) or int(starts[0].group(1)) != 1 or int(starts[1].group(1)) != 501:
        print("FAIL: the chain's parts should start at steps 1 and 501: %s" % [m and m.group(1) for m in starts])
        return 1
    worst = 0.0
    last = lambda kind: max((f for f in os.listdir(wa) if f.startswith(kind + ".")), key=lambda f: int(f.split(".")[-1]))
    for f in (last("dump.grains"), last("dump.fluid")):
        a, b = read_dump(os.path.join(wa, f)), read_dump(os.path.join(wb, f))
        if set(a) != set(b) or not a:
            print("FAIL: %s: the two runs dump different atoms" % f)
            return 1
        d = max(abs(x - y) for i in a for x, y in zip(a[i], b[i]))
        vmax = max(abs(c) for i in a for c in a[i][4:7])
        print("  %s: %d atoms, max |unbroken - chain| %.3g, max |v| %.3g m/s" % (f, len(a), d, vmax))
        if vmax < 0.01:
            print("FAIL: %s: nothing moves, the comparison would prove nothing" % f)
            return 1
        worst = max(worst, d)
    ok = worst == 0.0
    print("%s drum restart chain == unbroken run (%s): max difference %.3g (exact expected)"
          % ("PASS" if ok else "FAIL", engine, worst))
    return 0 if ok else 1


def dispatch(argv, scope, doc, prefix="test_"):
    """the command line of a test script: argv[1] names the function prefix + name of scope (a module's globals()
    or a table), called with the arguments after it (as many as it takes); it returns the exit code, or True
    (pass, 0) / False (fail, 1). Unknown or missing name: the script's doc, exit 2."""
    fn = scope.get(prefix + argv[1]) if len(argv) > 1 else None
    if not callable(fn):
        print(doc)
        return 2
    rc = fn(*argv[2:2 + fn.__code__.co_argcount])
    return (0 if rc else 1) if isinstance(rc, bool) else rc


if __name__ == "__main__":
    sys.exit(dispatch(sys.argv, globals(), __doc__))
