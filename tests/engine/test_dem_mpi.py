#!/usr/bin/env python3
"""test_dem_mpi.py - the GPU granular pair styles on several MPI ranks (the engine's domain decomposition).

The scene: 1008 frictional Hertz grains (d = 2 mm) on a lattice of touching grains over a floor, thrown
sideways (bulk vx, vz varying along x) under gravity in a box periodic in x and y, 'processors N 1 1': the
dense bed shears, settles and slides across the subdomain boundaries, so grains change rank while they
touch (the contact history must go with them) and pairs straddle two ranks. Positions are compared sorted by
atom ID after the stated number of steps; every bound is about round-off growth (the reference is stock
vs stock at another rank count, printed alongside).

  lammps   MPIRUN LMP  gran/hertz/history vs gran/hertz/history/gpu, newton on and newton off: /gpu vs
                       stock at np 2 and np 4 (4 oversubscribed), /gpu np 1 vs np 2; a restart written at
                       np 2 read at np 1 (write_restart after a run, by run ... every, and the restart command during one), and
                       written at np 1 read at np 4, each vs the unbroken run; a bed in
                       one fifth of a box at np 4 with the cuts moved by balance between two runs and by fix
                       balance (grains go to ranks two subdomains away), /gpu vs stock; a box that fix deform
                       squeezes and stretches, /gpu vs stock at np 1 and np 2 (and the core's list builds);
                       neigh_modify exclude group at np 2, /gpu vs stock; /gpu
                       without atom_modify map and with comm_style tiled at np 2; a grain made invalid on one rank mid-run stops every
                       rank with the core's message
  liggghts MPIRUN LIG  the same scene with 'gran model hertz tangential history' vs gran/gpu (newton off,
                       LIGGGHTS' contact-history rule): /gpu vs stock at np 2, /gpu np 1 vs np 2; restart
                       np 2 -> np 1 (both ways); model hooke/hysteresis (largest overlap per contact) and rolling_friction
                       epsd2 and epsd (a rolling torque per contact) /gpu vs stock at np 2; the epsd2 restart
                       np 2 -> np 1 (the rolling torques of both ranks in the file)
Python 3 only; exits 0 on pass, 1 on failure.
"""
import math
import os
import re
import shutil
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_test as E  # noqa: E402  (the run helper)

D = 2e-3       # grain diameter
STEPS = 2000   # steps compared (dt 2e-6: 4 ms; the bed slides by ~1 mm)
BOUND = 1e-8   # max |dx| / d after STEPS steps, /gpu vs stock and /gpu vs /gpu at other rank counts

LMP = """units si
atom_style sphere
boundary p p f
newton {newton}
processors {px} 1 1
atom_modify map array sort 100 0.002
comm_modify vel yes
read_data ../bed.data
neighbor 0.0004 bin
neigh_modify delay 0 every 1 check yes
pair_style {style} 2e8 NULL 2e4 NULL 0.5 1{extra}
pair_coeff * *
fix floor all wall/gran hertz/history 2e8 NULL 2e4 NULL 0.5 1 zplane 0 NULL
fix g all gravity 9.81 vector 0 0 -1
fix 1 all nve/sphere
timestep 2e-6
thermo_style custom step atoms ke press
thermo_modify format float %.15g
thermo 500
{run}
"""
DUMP = """write_dump all custom {name} id x y z vx vy vz omegax omegay omegaz modify sort id format float %.17g
"""

LIG = """units si
atom_style granular
boundary p p f
newton off
processors {px} 1 1
atom_modify map array sort 100 0.002
communicate single vel yes
read_data ../bed.data
neighbor 0.0004 bin
neigh_modify delay 0
""" + E.lig_materials("5e7", "0.3", "0.6", "0.5") + """pair_style {style} model hertz tangential history
pair_coeff * *
fix floor all wall/gran model hertz tangential history primitive type 1 zplane 0.0
fix g all gravity 9.81 vector 0 0 -1
fix 1 all nve/sphere
timestep 2e-6
thermo_style custom step atoms ke
thermo 500
{run}
"""
HYSTERESIS = """fix m6 all property/global characteristicVelocity scalar 0.5
fix m7 all property/global coefficientMaxElasticStiffness peratomtypepair 1 1.5
fix m8 all property/global coefficientAdhesionStiffness peratomtypepair 1 0.3
fix m9 all property/global coefficientPlasticityDepth peratomtypepair 1 0.5
"""
LIG_DUMP = """dump d all custom 1 {name} id x y z vx vy vz omegax omegay omegaz
dump_modify d sort id format "%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g"
run 0
undump d
"""


NX, NY, NZ, A = 14, 6, 12, 2.0e-3  # lattice of the bed (spacing A = D: neighbours touch or nearly)
JIT, DV, VZ = 2e-4, 0.05, 0.05     # lattice jitter / A (overlaps below 1e-3 D), velocity scatter, vertical amplitude (m/s)


def bed_data(path):
    """the bed as a data file (atom IDs do not depend on the rank count, as they would with create_atoms):
    grains on a lattice of touching grains, each displaced and given a velocity from its ID (a fixed hash), a
    bulk sideways velocity and a vertical one that varies along x: a dense bed that shears, settles and slides
    over the frictional floor (about 900 touching contacts at the end)"""
    def h(i, k):  # deterministic in [-1, 1)
        v = (i * 2654435761 + k * 40503) % 4294967296
        return v / 2147483648.0 - 1.0
    atoms, vel = [], []
    i = 0
    for z in range(NZ):
        for y in range(NY):
            for x in range(NX):
                i += 1
                px, py, pz = (x + 0.5 + JIT * h(i, 1)) * A, (y + 0.5 + JIT * h(i, 2)) * A, (z + 0.5 + JIT * h(i, 3)) * A
                atoms.append("%d 1 %.17g 2500 %.17g %.17g %.17g" % (i, D, px, py, pz))
                vx = 0.4 + DV * h(i, 4)
                vz = VZ * math.sin(2 * math.pi * px / (NX * A)) + DV * h(i, 5)
                vel.append("%d %.17g %.17g %.17g 0 0 0" % (i, vx, DV * h(i, 6), vz))
    with open(path, "w") as f:
        f.write("bed of %d grains\n\n%d atoms\n1 atom types\n\n0 %.17g xlo xhi\n0 %.17g ylo yhi\n0 0.04 zlo zhi\n\n"
                % (i, i, NX * A, NY * A))
        f.write("Atoms\n\n" + "\n".join(atoms) + "\n\nVelocities\n\n" + "\n".join(vel) + "\n")


def load(path):
    lines = [l.strip() for l in open(path).read().splitlines()]
    i = next(k for k, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    return [[float(v) for v in l.split()] for l in lines[i + 1:] if l.strip()]


def max_dx(a, b, d=D):
    """largest |x_a - x_b| / d over the grains (rows id x y z ...), None if the ids differ"""
    if len(a) != len(b) or [r[0] for r in a] != [r[0] for r in b]:
        return None
    return max(max(abs(r[k] - q[k]) for k in (1, 2, 3)) for r, q in zip(a, b)) / d


def fmt(v):
    return "%.3g" % v if v is not None else "(ids differ)"


class Runner:
    def __init__(self, mpirun, exe, liggghts, root):
        self.mpirun, self.exe, self.lig, self.root = mpirun, exe, liggghts, root
        self.out = {}
        self.text = None  # another input than LMP / LIG
        os.makedirs(root, exist_ok=True)
        bed_data(os.path.join(root, "bed.data"))  # written afresh: a folder left by an earlier version is reused

    def cmd(self, np):
        return [self.mpirun, "-np", str(np), "--oversubscribe", "--allow-run-as-root", self.exe]

    def script(self, style, np, newton, run, extra=""):
        t = self.text or (LIG if self.lig else LMP)
        return t.format(style=style, px=np, newton=newton, run=run, extra=extra)

    def dump(self, name):
        return (LIG_DUMP if self.lig else DUMP).format(name=name)

    def go(self, tag, np, text, files=()):
        wd = os.path.join(self.root, tag)
        os.makedirs(wd, exist_ok=True)
        for f in files:
            shutil.copy(f, wd)
        text = text.replace("../bed.data", os.path.abspath(os.path.join(self.root, "bed.data")))
        rc, out = E.run(self.cmd(np), wd, text, timeout=300)
        self.out[tag] = out
        if rc != 0 or "ERROR" in out:
            print("FAIL %s (np %d): rc %d\n%s" % (tag, np, rc, out[-2500:]))
            return None
        return wd

    def final(self, tag, style, np, newton="off", extra=""):
        """positions after STEPS steps"""
        wd = self.go(tag, np, self.script(style, np, newton, "run %d\n" % STEPS + self.dump("final.dump"), extra))
        return load(os.path.join(wd, "final.dump")) if wd else None

    def press(self, tag):
        """the thermo pressure column (LAMMPS: the pair virial summed over the ranks)"""
        rows, on = [], False
        for l in self.out.get(tag, "").splitlines():
            w = l.split()
            if w[:1] == ["Step"]:
                on = True
            elif on and len(w) == 4 and w[0].isdigit():
                rows.append(float(w[3]))
            elif w[:2] == ["Loop", "time"]:
                on = False
        return rows


def compare(results, label, a, b, bound=BOUND, d=D):
    dx = max_dx(a, b, d) if a is not None and b is not None else None
    ok = dx is not None and dx < bound
    print("  %-58s max |dx| = %s d %s" % (label, fmt(dx), "(bound %g)" % bound if bound else "(reference)"))
    results.append(ok if bound else True)
    return dx


def restart_pair(r, results, style, np_write, np_read, newton, keyword=None):
    """STEPS/2 steps at np_write, write_restart, read at np_read, STEPS/2 more: vs the same two runs in one
    input at np_write (a new run's setup alone moves the grains by ~3e-8 d here, with the stock style too:
    the stock fix wall/gran, the sorting and the reneighbouring of the setup). keyword "restart": the file
    written by the restart command in the middle of one run of STEPS steps; "every": by write_restart among
    the commands of run STEPS every STEPS/2"""
    half = STEPS // 2
    tag = "restart_%d_%d_%s%s" % (np_write, np_read, newton, "_" + keyword if keyword else "")
    u = r.go(tag + "/unbroken", np_write, r.script(style, np_write, newton, "run %d\nrun %d\n" % (half, half) +
                                                   r.dump("final.dump")))
    unbroken = load(os.path.join(u, "final.dump")) if u else None
    if keyword:
        cmd = ("restart %d bed.*.restart\nrun %d\n" % (half, STEPS) if keyword == "restart" else
               "run %d every %d \"write_restart bed.*.restart\"\n" % (STEPS, half))
        w = r.go(tag + "/write", np_write, r.script(style, np_write, newton, cmd))
        if w:
            os.replace(os.path.join(w, "bed.%d.restart" % half), os.path.join(w, "bed.restart"))
    else:
        w = r.go(tag + "/write", np_write, r.script(style, np_write, newton, "run %d\nwrite_restart bed.restart\n" % half))
    if not w:
        results.append(False)
        return
    if r.lig:
        cont = ("processors %d 1 1\nread_restart bed.restart\nneighbor 0.0004 bin\nneigh_modify delay 0\n"
                "communicate single vel yes\n" % np_read +
                "\n".join(l for l in (r.text or LIG).splitlines() if l.startswith("fix m")) + "\n" +
                "fix floor all wall/gran model hertz tangential history primitive type 1 zplane 0.0\n"
                "fix g all gravity 9.81 vector 0 0 -1\nfix 1 all nve/sphere\ntimestep 2e-6\n"
                "thermo 500\nrun %d\n" % half + r.dump("final.dump"))
    else:
        cont = ("processors %d 1 1\nread_restart bed.restart\nnewton %s\nneighbor 0.0004 bin\n"
                "neigh_modify delay 0 every 1 check yes\ncomm_modify vel yes\n"
                "fix floor all wall/gran hertz/history 2e8 NULL 2e4 NULL 0.5 1 zplane 0 NULL\n"
                "fix g all gravity 9.81 vector 0 0 -1\nfix 1 all nve/sphere\ntimestep 2e-6\n"
                "thermo 500\nrun %d\n" % (np_read, newton, half) + r.dump("final.dump"))
    c = r.go(tag + "/read", np_read, cont, files=[os.path.join(w, "bed.restart")])
    b = load(os.path.join(c, "final.dump")) if c else None
    how = {"restart": " (restart command)", "every": " (run every)"}.get(keyword, "")
    compare(results, "restart%s np %d -> np %d vs unbroken np %d" % (how, np_write, np_read, np_write), unbroken, b)


def lammps(mpirun, lmp):
    r = Runner(mpirun, lmp, False, "dem_mpi_lmp")
    res = []
    print("LAMMPS: %d steps, positions sorted by atom ID" % STEPS)
    for newton in ("on", "off"):
        s1 = r.final("stock_np1_" + newton, "gran/hertz/history", 1, newton)
        s2 = r.final("stock_np2_" + newton, "gran/hertz/history", 2, newton)
        g1 = r.final("gpu_np1_" + newton, "gran/hertz/history/gpu", 1, newton, " timers on")
        g2 = r.final("gpu_np2_" + newton, "gran/hertz/history/gpu", 2, newton, " timers on")
        if s2 is None or g2 is None:
            return False
        print(" newton %s, %d grains:" % (newton, len(s2)))
        compare(res, "stock np 1 vs stock np 2", s1, s2, bound=0)
        compare(res, "/gpu np 2 vs stock np 2", g2, s2)
        compare(res, "/gpu np 1 vs /gpu np 2", g1, g2)
        compare(res, "/gpu np 1 vs stock np 1", g1, s1)
        # the tiled communication (no processors grid): the periodic images of a rank's own atoms along y are ghost
        # atoms, evaluated as such (newton off: their share moved to the atom; newton on: sent back by the engine)
        r.text = LMP.replace("processors {px} 1 1\n", "processors {px} 1 1\ncomm_style tiled\n")
        gt = r.final("gpu_np2_tiled_" + newton, "gran/hertz/history/gpu", 2, newton)
        r.text = None
        compare(res, "/gpu np 2 comm_style tiled vs stock np 2", gt, s2)
        def dpress(a, b):
            pa, pb = r.press(a), r.press(b)
            return max(abs(x - y) for x, y in zip(pa, pb)) / max(abs(y) for y in pb) if pa and len(pa) == len(pb) else 1.0
        print("  %-58s max |dp| / max |p| = %.3g (reference)" % ("stock np 1 vs stock np 2 pressure",
                                                                 dpress("stock_np1_" + newton, "stock_np2_" + newton)))
        dp = dpress("gpu_np2_" + newton, "stock_np2_" + newton)
        print("  %-58s max |dp| / max |p| = %.3g (bound 1e-7)" % ("/gpu np 2 vs stock np 2 pressure (virial)", dp))
        res.append(dp < 1e-7)
        c1, c2 = contacts(r.out.get("gpu_np1_" + newton, "")), contacts(r.out.get("gpu_np2_" + newton, ""))
        print("  %-58s %s, %s" % ("touching contacts at the end (timers line) np 1, np 2", c1, c2))
        res.append(c1 is not None and c1 > 500 and c1 == c2)  # the bed is dense: most grains touch
        if newton == "on":
            gp = r.final("gpu_np2_pair_on", "gran/hertz/history/gpu", 2, newton, " algo pair")
            compare(res, "/gpu algo pair np 2 vs stock np 2", gp, s2)
            # without the engine's atom map the periodic images are found by a map of the owned tags
            r.text = LMP.replace("atom_modify map array sort", "atom_modify sort")
            gn = r.final("gpu_np2_nomap_on", "gran/hertz/history/gpu", 2, newton)
            r.text = None
            compare(res, "/gpu np 2 without atom_modify map vs stock np 2", gn, s2)
            s4 = r.final("stock_np4_on", "gran/hertz/history", 4, newton)
            g4 = r.final("gpu_np4_on", "gran/hertz/history/gpu", 4, newton)
            compare(res, "/gpu np 4 vs stock np 4", g4, s4)
            restart_pair(r, res, "gran/hertz/history/gpu", 2, 1, newton)
            restart_pair(r, res, "gran/hertz/history/gpu", 1, 4, newton)
            restart_pair(r, res, "gran/hertz/history/gpu", 2, 1, newton, keyword="restart")
            restart_pair(r, res, "gran/hertz/history/gpu", 2, 1, newton, keyword="every")
    for newton in ("on", "off"):
        res.append(balance_moves(r, newton))
    res.append(deforming_box(r))
    res.append(exclusions(r))
    res.append(failure_on_one_rank(r))
    moved = migrated(r.out.get("gpu_np2_on", ""))
    ok = all(res) and moved
    print("%s LAMMPS /gpu on several ranks (%d checks)" % ("PASS" if ok else "FAIL", len(res)))
    return ok


BALANCE = """units lj
atom_style sphere
boundary p p fm
newton {newton}
comm_modify vel yes
processors 4 1 1
region reg block 0 20 0 6 0 12 units box
create_box 1 reg
lattice sc 1.0 origin 0.5 0.5 0.5
region bed block 0 4 0 6 0 5 units box
create_atoms 1 region bed
set group all diameter 0.98
set group all density 1.0
velocity all create 0.5 12345 loop geom
neighbor 0.2 bin
neigh_modify delay 0
pair_style {style} 2000.0 NULL 50.0 NULL 0.5 0
pair_coeff * *
timestep 0.001
fix 1 all nve/sphere
fix 2 all gravity 1.0 spherical 0.0 -180.0
fix zl all wall/gran hertz/history 2000.0 NULL 50.0 NULL 0.5 0 zplane 0.0 2000.0
run 600
{balance}
run 600
write_dump all custom final.dump id x y z vx vy vz omegax omegay omegaz modify sort id format float %.17g
"""


def balance_moves(r, newton):
    """a bed of 120 touching grains in one fifth of a box cut in 4 along x: balance between two runs, or fix
    balance during the second, moves the cuts so that grains go to ranks two subdomains away (the engine's
    irregular migration), with their contacts; /gpu vs stock at np 4 (without the contacts' history the grains
    differ by ~3e-2 d)"""
    ok = True
    for name, bal in (("balance", "balance 1.0 shift x 10 1.0"), ("fix_balance", "fix lb all balance 300 1.0 shift x 10 1.0")):
        out = []
        for style in ("gran/hertz/history", "gran/hertz/history/gpu"):
            tag = "%s_%s_%s" % (name, newton, "gpu" if style.endswith("gpu") else "stock")
            wd = r.go(tag, 4, BALANCE.format(newton=newton, style=style, balance=bal))
            out.append(load(os.path.join(wd, "final.dump")) if wd else None)
        res = []
        compare(res, "/gpu vs stock np 4, newton %s, %s" % (newton, "balance between the runs" if name == "balance"
                                                             else "fix balance in the second run"), out[1], out[0],
                d=0.98)
        ok = ok and res[0]
    return ok


DEFORM = """units lj
atom_style sphere
boundary p p p
newton on
comm_modify vel yes
processors {np} 1 1
region reg block 0 8 0 8 0 8 units box
create_box 1 reg
lattice sc 1.0 origin 0.5 0.5 0.5
create_atoms 1 region reg
set group all diameter 1.0
set group all density 1.0
velocity all create 1.0 12345 loop geom
neighbor 0.2 bin
neigh_modify delay 0
pair_style {style} 2000.0 NULL 50.0 NULL 0.5 1{extra}
pair_coeff * *
timestep 0.001
fix 1 all nve/sphere
fix d all deform 1 x erate -0.02 y erate 0.01 remap x
run 2000
write_dump all custom final.dump id x y z vx vy vz modify sort id format float %.17g
"""


def deforming_box(r):
    """512 grains in a periodic box that fix deform squeezes along x and stretches along y (remap x), 2000 steps:
    /gpu vs stock at np 1 and np 2; the core keeps its pair list while only the box changes (its builds at np 1
    at most twice the engine's)"""
    ok = True
    for np_ in (1, 2):
        out = []
        for style, extra in (("gran/hertz/history", ""), ("gran/hertz/history/gpu", " timers on")):
            tag = "deform_np%d_%s" % (np_, "gpu" if extra else "stock")
            wd = r.go(tag, np_, DEFORM.format(np=np_, style=style, extra=extra))
            out.append(load(os.path.join(wd, "final.dump")) if wd else None)
        res = []
        compare(res, "/gpu vs stock np %d, fix deform (box squeezed and stretched)" % np_, out[1], out[0], d=1.0)
        ok = ok and res[0]
        if np_ == 1:
            g = re.search(r"builds_total=(\d+)", r.out.get("deform_np1_gpu", ""))
            e = re.search(r"Neighbor list builds = (\d+)", r.out.get("deform_np1_stock", ""))
            nb, ne = (int(g.group(1)) if g else -1), (int(e.group(1)) if e else -1)
            print("  %-58s %d (the engine's: %d)" % ("/gpu list builds in 2000 steps of a deforming box", nb, ne))
            ok = ok and 0 < nb <= 2 * max(ne, 1)
    return ok


def exclusions(r):
    """neigh_modify exclude group half half (half the bed, by atom ID, across both subdomains) at np 2, newton on:
    /gpu vs stock; the exclusion matters (stock with and without it differ by more than 1e-3 d)"""
    ex = "neigh_modify delay 0 every 1 check yes\ngroup half id <= 504\nneigh_modify exclude group half half\n"
    out = []
    for tag, style, text in (("excl_np2_stock", "gran/hertz/history", None), ("excl_np2_gpu", "gran/hertz/history/gpu", None),
                             ("excl_np2_plain", "gran/hertz/history", "plain")):
        t = r.script(style, 2, "on", "run %d\n" % STEPS + r.dump("final.dump"))
        if text is None:
            t = t.replace("neigh_modify delay 0 every 1 check yes\n", ex)
        wd = r.go(tag, 2, t)
        out.append(load(os.path.join(wd, "final.dump")) if wd else None)
    res = []
    compare(res, "/gpu vs stock np 2, neigh_modify exclude group half half", out[1], out[0])
    dplain = max_dx(out[0], out[2]) if out[0] is not None and out[2] is not None else None
    print("  %-58s max |dx| = %s d (must exceed 1e-3)" % ("stock with vs without the exclusion", fmt(dplain)))
    return res[0] and dplain is not None and dplain > 1e-3


def failure_on_one_rank(r):
    """a grain of one rank made invalid mid-run (fix adapt shrinks grain 5, on rank 0, to diameter 0): the core refuses
    it on that rank, and every rank stops with its message (no hang, no other error first). The ranks compare their
    failures every 10 steps without waiting for each other, and at the start of each step of a list build: from
    step 300 with the lists kept, the stop comes within 20 steps; from step 301 with a list build at every step
    (neigh_modify check no), after step 301 (the failure found at the build of step 302)"""
    good = True
    for first, neigh, lo, hi in ((300, "", 299, 320), (301, "neigh_modify delay 0 every 1 check no\n", 301, 302)):
        tag = "failure_np2_%d" % first
        wd = os.path.join(r.root, tag)
        text = r.script("gran/hertz/history/gpu", 2, "on", "group one id 5\nvariable d equal \"(step < %d) * 2e-3\"\n"
                        "fix shrink one adapt 1 atom diameter v_d mass no\n%sthermo 1\nrun 1000\n" % (first, neigh))
        text = text.replace("../bed.data", os.path.abspath(os.path.join(r.root, "bed.data")))
        text = text.replace("atom_style sphere\n", "atom_style sphere 1\n")  # radii that fix adapt may change
        rc, out = E.run(r.cmd(2), wd, text, timeout=120)
        err = [l for l in out.splitlines() if "ERROR" in l]
        ok = rc not in (0, 124) and len(err) >= 1 and "DEM core" in err[0] and "(rank 0)" in err[0] and "(grain 5)" in err[0]
        steps = [int(l.split()[0]) for l in out.splitlines() if re.match(r"^\s*\d+\s+\d+\s", l)]
        last = steps[-1] if steps else -1
        ok = ok and lo <= last <= hi  # the last step that ended before the stop
        what = "a grain made invalid on rank 0 at step %d (np 2%s):" % (first, ", builds" if neigh else "")
        print("  %-58s %s" % (what, "every rank stops after step %d with: %s" % (last, err[0].strip()) if ok else
                              "FAIL rc %d, last step %d (must be %d..%d)\n%s" % (rc, last, lo, hi, out[-1500:])))
        good = good and ok
    return good


def contacts(out):
    """the contact count of the timers line (summed over the ranks, each pair once)"""
    for l in out.splitlines():
        if " timers: " in l and "contacts=" in l:
            return int(l.split("contacts=")[1].split()[0])
    return None


def migrated(out):
    """the run rebuilt its lists (so atoms changed rank) and kept its grains"""
    good = "Neighbor list builds" in out and "Dangerous builds = 0" in out
    if not good:
        print("  the /gpu np 2 run reports no neighbour-list builds or dangerous builds:\n" + out[-1500:])
    return good


def liggghts(mpirun, lig):
    r = Runner(mpirun, lig, True, "dem_mpi_lig")
    res = []
    print("LIGGGHTS: %d steps, positions sorted by atom ID" % STEPS)
    s1 = r.final("stock_np1", "gran", 1)
    s2 = r.final("stock_np2", "gran", 2)
    g1 = r.final("gpu_np1", "gran/gpu", 1)
    g2 = r.final("gpu_np2", "gran/gpu", 2)
    if s2 is None or g2 is None:
        return False
    print(" %d grains:" % len(s2))
    compare(res, "stock np 1 vs stock np 2", s1, s2, bound=0)
    compare(res, "/gpu np 2 vs stock np 2", g2, s2)
    compare(res, "/gpu np 1 vs /gpu np 2", g1, g2)
    compare(res, "/gpu np 1 vs stock np 1", g1, s1)
    restart_pair(r, res, "gran/gpu", 2, 1, "off")
    restart_pair(r, res, "gran/gpu", 2, 1, "off", keyword="restart")
    # model hooke/hysteresis: the largest overlap of each contact is a history value too
    hyst = Runner(mpirun, lig, True, os.path.join("dem_mpi_lig", "hysteresis"))
    hyst.text = LIG.replace("model hertz tangential history\n", "model hooke/hysteresis tangential history\n").replace(
        "pair_style", HYSTERESIS + "pair_style", 1)
    h2 = hyst.final("stock_np2", "gran", 2)
    hg2 = hyst.final("gpu_np2", "gran/gpu", 2)
    compare(res, "model hooke/hysteresis: /gpu np 2 vs stock np 2", hg2, h2)
    # rolling_friction epsd2 and epsd keep a rolling torque per contact, handed over with the tangential history
    for model, extra in (("epsd2", ""), ("epsd", "fix m6 all property/global coefficientRollingViscousDamping "
                                                 "peratomtypepair 1 0.3\n")):
        roll = Runner(mpirun, lig, True, os.path.join("dem_mpi_lig", model))
        roll.text = LIG.replace("model hertz tangential history\n", "model hertz tangential history rolling_friction "
                                "%s\n" % model).replace("pair_style", "fix m5 all property/global coefficientRollingFriction "
                                                          "peratomtypepair 1 0.05\n" + extra + "pair_style", 1)
        e1 = roll.final("stock_np1", "gran", 1)
        e2 = roll.final("stock_np2", "gran", 2)
        eg2 = roll.final("gpu_np2", "gran/gpu", 2)
        compare(res, "rolling_friction %s: stock np 1 vs stock np 2" % model, e1, e2, bound=0)
        compare(res, "rolling_friction %s: /gpu np 2 vs stock np 2" % model, eg2, e2)
        if model == "epsd2":  # the rolling torques in the restart file gathered from both ranks
            restart_pair(roll, res, "gran/gpu", 2, 1, "off")
    ok = all(res)
    print("%s LIGGGHTS gran/gpu on several ranks (%d checks)" % ("PASS" if ok else "FAIL", len(res)))
    return ok


def main():
    if len(sys.argv) < 4:
        print(__doc__)
        return 2
    mode, mpirun, exe = sys.argv[1:4]
    ok = lammps(mpirun, exe) if mode == "lammps" else liggghts(mpirun, exe) if mode == "liggghts" else None
    if ok is None:
        print("unknown mode " + mode)
        return 2
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
