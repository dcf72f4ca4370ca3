#!/usr/bin/python3
"""dem_bench.py - GPU DEM pair styles vs the stock granular pair styles, side by side.

Scene (the same geometry for every code): a dense column of grains settling under gravity: d = 5 mm,
2500 kg/m^3, simple cubic lattice of spacing 4.999 mm (every grain touches its 6 lattice neighbours
from the start), nx * nx columns periodic in x and y, nz layers on a floor (fix wall/gran), random
velocities of about 0.01 m/s, skin 1 mm, dt 2e-6 s, atoms sorted every 1000 steps.
  LIGGGHTS: pair_style gran model hertz tangential history (E 5e6, nu 0.45, e 0.7, mu 0.5 from
            fix property/global) - stock, 1 MPI rank and 2 ranks - and pair_style gran/gpu with
            the same words (sphdem CPU backend, 1 and 2 ranks; GPU backend when a GPU is usable).
  LAMMPS:   pair_style gran/hertz/history 2e7 NULL 5e3 NULL 0.5 1 - stock, 1 and 2 ranks - and
            gran/hertz/history/gpu with the same arguments (CPU backend, 1 and 2 ranks; GPU when usable).
Our styles run with OMP_NUM_THREADS=1 and the keyword `timers on`, which prints the split of the
pair time: pack (atoms -> core arrays), upload, rebuild check, detection (cell grid, candidate
pairs, history carry), forces, download, unpack. For the stock styles the split is the engine's own
timing table: Neigh (detection) and Pair (forces).

Each run is repeated --repeat times and the best loop time is kept (the machine may be shared).
Printed: particle-steps/s (grains * steps / loop time), contacts/s (mean number of touching grain
pairs, from compute contact/atom at the first and last step, * steps / loop time), the CPU seconds
of the whole process (smallest of the repeats, set-up included, all ranks: less sensitive than the
loop time to other jobs on a shared machine) and the split.
--compare-build DIR adds rows for the launchers of another build (e.g. before a change).

--scenes picks the scenes (default column): column is the dense column above; gas a loose granular gas
(the same lattice at spacing 5.5 mm = 1.1 d, random velocities of about 0.3 m/s per component: most
candidate pairs within the skin do not touch, the list is rebuilt often); pour grains inserted into an
empty box while the run goes on, so that the atom count changes (LAMMPS: examples/granular/in.pour, 3000
grains by fix pour in lj units with the Hertz arguments 2000 NULL 50 NULL 0.5 0; LIGGGHTS: fix insert/pack every
500 steps, d = 5 mm falling onto the floor at 2 m/s).
--callgrind column:100,gas:300,pour:5000 adds a table of instruction counts (valgrind callgrind, one run per code at
these steps): the run loop, the pair style's compute and the engine's neighbour builds, with their ratios to stock. At the end a table of
the ratios /gpu (CPU backend, 1 rank, 1 thread) / stock (1 rank): loop time, Pair time, and Pair time
against stock Pair + Neigh (the /gpu styles build their pair list inside Pair).

  python3 bench/dem_bench.py [--build build] [--sizes 1e4,1e5] [--steps 1e4:1000,1e5:100,1e6:10]
                             [--repeat 3] [--no-mpi] [--engines lammps,liggghts] [--compare-build DIR]
                             [--scenes column,gas,pour] [--callgrind column:100,gas:300,pour:5000]
python3 standard library only. A benchmark: it prints numbers and asserts nothing.
"""
import argparse
import os
import resource
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
A = 0.004999  # lattice spacing (d = 0.005: 0.02 % overlap with each lattice neighbour)

COMMON_TOP = """units           si
boundary        p p f
newton          off
atom_modify     map array sort 1000 0.002
region          box block 0 {L:.9g} 0 {L:.9g} 0 {H:.9g} units box
create_box      1 box
neighbor        0.001 bin
"""
LATTICE = """lattice         sc {a} origin 0.5 0.5 0.5
region          ins block 0 {L:.9g} 0 {L:.9g} 0 {Hins:.9g} units box
create_atoms    1 region ins
set             type 1 diameter 0.005
set             type 1 density 2500
variable        vx atom normal(0,0.0058,15485863)
variable        vy atom normal(0,0.0058,32452843)
variable        vz atom normal(0,0.0058,49979687)
velocity        all set v_vx v_vy v_vz
"""
TAIL = """fix             g all gravity 9.81 vector 0 0 -1
fix             integrate all nve/sphere
timestep        2e-6
compute         cn all contact/atom
compute         ncs all reduce sum c_cn
thermo_style    custom step atoms ke c_ncs
thermo          {steps}
run             {steps}
"""


GAS_A = 0.0055  # gas: lattice spacing 1.1 d
GAS_LATTICE = LATTICE.replace("{a}", "%g" % GAS_A).replace("0.0058", "0.3")
# LIGGGHTS pour: grains of d = 5 mm inserted at 2 m/s into a box of 50 x 50 mm (periodic x y) 20-50 mm above the floor
POUR_L = 0.05
# LAMMPS pour: examples/granular/in.pour of LAMMPS (lj units, 3000 grains poured into a periodic box by fix pour
# in batches, each when the one before has fallen out of the slab), its own Hertz arguments
POUR_LMP = """units           lj
atom_style      sphere
boundary        p p fm
newton          off
comm_modify     vel yes
region          reg block -10 10 -10 10 -0.5 16 units box
create_box      1 reg
neighbor        0.2 bin
neigh_modify    delay 0
pair_style      {style} 2000.0 NULL 50.0 NULL 0.5 0 {extra}
pair_coeff      * *
timestep        0.001
fix             1 all nve/sphere
fix             2 all gravity 1.0 spherical 0.0 -180.0
fix             zlower all wall/gran hertz/history 2000.0 NULL 50.0 NULL 0.5 0 zplane 0.0 2000.0
region          slab block -9.0 9.0 -9.0 9.0 10.0 15.0
fix             ins all pour 3000 1 300719 vol 0.13 50 region slab
compute         cn all contact/atom
compute         ncs all reduce sum c_cn
thermo_style    custom step atoms ke c_ncs
thermo_modify   lost ignore norm no
thermo          {steps}
run             {steps}
"""
POUR_LIG = """fix             pts all particletemplate/sphere 15485863 atom_type 1 density constant 2500 radius constant 0.0025
fix             pdd all particledistribution/discrete 32452843 1 pts 1.0
region          slab block 0.003 0.047 0.003 0.047 0.02 0.05 units box
fix             ins all insert/pack seed 49979687 distributiontemplate pdd insert_every 500 overlapcheck yes &
                vel constant 0 0 -2.0 particles_in_region 400 region slab
"""


def scene_parts(scene, nx, nz, engine):
    """(L, H, the lines that make the grains) of a scene"""
    if scene == "pour":
        return POUR_L, 0.06, POUR_LIG
    a, lat = (GAS_A, GAS_LATTICE) if scene == "gas" else (A, LATTICE)
    L, Hins = nx * a, nz * a
    return L, Hins + 0.02 + (nz * a if scene == "gas" else 0.0), lat.format(a=a, L=L, Hins=Hins)


def lammps_input(nx, nz, steps, style, extra, scene="column"):
    if scene == "pour":
        return POUR_LMP.format(style=style, extra=extra, steps=steps)
    L, H, grains = scene_parts(scene, nx, nz, "lammps")
    return (COMMON_TOP.format(L=L, H=H).replace("units           si\n", "units           si\natom_style      sphere\n")
            + "comm_modify     vel yes\nneigh_modify    delay 0 every 1 check yes\n"
            + grains
            + "pair_style      %s 2e7 NULL 5e3 NULL 0.5 1 %s\npair_coeff      * *\n" % (style, extra)
            + "fix             floor all wall/gran hertz/history 2e7 NULL 5e3 NULL 0.5 1 zplane 0 NULL\n"
            + TAIL.format(steps=steps))


def liggghts_input(nx, nz, steps, style, extra, scene="column"):
    L, H, grains = scene_parts(scene, nx, nz, "liggghts")
    return (COMMON_TOP.format(L=L, H=H).replace("units           si\n", "units           si\natom_style      granular\n")
            + "communicate     single vel yes\nneigh_modify    delay 0\n"
            + "fix             m1 all property/global youngsModulus peratomtype 5e6\n"
            + "fix             m2 all property/global poissonsRatio peratomtype 0.45\n"
            + "fix             m3 all property/global coefficientRestitution peratomtypepair 1 0.7\n"
            + "fix             m4 all property/global coefficientFriction peratomtypepair 1 0.5\n"
            + "pair_style      %s model hertz tangential history %s\npair_coeff      * *\n" % (style, extra)
            + grains
            + "fix             floor all wall/gran model hertz tangential history primitive type 1 zplane 0.0\n"
            + TAIL.format(steps=steps))


def parse(out):
    r = {}
    m = re.search(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", out)
    if not m:
        return None
    r["loop"], r["procs"], r["steps"], r["atoms"] = float(m.group(1)), int(m.group(2)), int(m.group(3)), int(m.group(4))
    for sec in ("Pair", "Neigh", "Comm", "Modify", "Output", "Other"):
        mm = re.search(r"^%s\s*\|\s*([0-9.eE+-]+)\s*\|\s*([0-9.eE+-]+)?" % sec, out, re.M)
        if mm:
            vals = [v for v in mm.groups() if v]
            r[sec] = float(vals[1] if len(vals) > 1 else vals[0])  # avg over ranks (Other has one value)
        else:  # LIGGGHTS: "Pair  time (%) = 0.853101 (89.0472)"
            mm = re.search(r"^%s\s+time \(%%\) = ([0-9.eE+-]+)" % sec[:5].strip(), out, re.M)
            if mm:
                r[sec] = float(mm.group(1))
    # thermo rows: step atoms ke c_ncs (first and last)
    rows = re.findall(r"^\s+(\d+)\s+(\d+)\s+([0-9.eE+-]+)\s+([0-9.eE+-]+)\s*$", out, re.M)
    if rows:
        r["contacts"] = 0.25 * (float(rows[0][3]) + float(rows[-1][3]))  # mean of sum(contacts/atom) / 2
    t = re.search(r"timers: (.*)$", out, re.M)
    if t:
        r["timers"] = {k: float(v) for k, v in re.findall(r"(\w+)=([0-9.eE+-]+)", t.group(1))}
    m = re.search(r"sphdem DEM core on the (\w+)", out)
    if m:
        r["backend"] = m.group(1)
    return r


def run(cmd, text, wd, env):
    os.makedirs(wd, exist_ok=True)
    with open(os.path.join(wd, "in.bench"), "w") as fp:
        fp.write(text)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(cmd + ["-in", "in.bench", "-log", "none"], cwd=wd, env=env, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, errors="replace", timeout=3600)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        print("  FAILED (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stdout[-1500:]), flush=True)
        return None
    r = parse(p.stdout)
    if r:  # CPU seconds of the whole process (set-up included), all ranks
        r["cpu"] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return r


CG_PATTERNS = {"loop": r"LAMMPS_NS::Verlet::run\(int\)", "pair": r"LAMMPS_NS::Pair\w*::compute\(int, int\)",
               "neigh": r"LAMMPS_NS::Neighbor::build\(int\)"}


def callgrind(cmd, text, wd, env):
    """instructions (valgrind callgrind, Ir inclusive) of the run loop (Verlet::run), of the pair style's compute and of
    the engine's neighbour-list builds: counts that other jobs on the machine do not change"""
    os.makedirs(wd, exist_ok=True)
    with open(os.path.join(wd, "in.bench"), "w") as fp:
        fp.write(text)
    out = os.path.join(wd, "callgrind.out")
    p = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out] + cmd + ["-in", "in.bench", "-log",
                       "none"], cwd=wd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       errors="replace", timeout=7200)
    if p.returncode != 0:
        print("  FAILED under callgrind (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stdout[-1500:]), flush=True)
        return None
    ann = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", out], stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True, errors="replace").stdout
    r = {k: 0 for k in CG_PATTERNS}
    for line in ann.splitlines():
        m = re.match(r"\s*([0-9,]+) .*?(\S*:)?(LAMMPS_NS::.*?) \[", line)
        if not m:
            continue
        for k, pat in CG_PATTERNS.items():
            if re.fullmatch(pat, m.group(3)):
                r[k] = max(r[k], int(m.group(1).replace(",", "")))
    os.remove(out)
    return r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--sizes", default="1e4,1e5")
    ap.add_argument("--steps", default="1e4:1000,1e5:100,1e6:10")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-mpi", action="store_true")
    ap.add_argument("--engines", default="liggghts,lammps")
    ap.add_argument("--compare-build", default=None, help="another build whose launchers get rows labelled 'before'")
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--scenes", default="column", help="column, gas, pour (comma-separated)")
    ap.add_argument("--pour-steps", type=int, default=20000, help="steps of the pour scene (its size is fixed)")
    ap.add_argument("--callgrind", default=None, metavar="SCENE:STEPS,...",
                    help="also count instructions (valgrind callgrind, one run per code) with these steps per scene, "
                         "e.g. column:100,gas:300,pour:5000")
    a = ap.parse_args()
    a.build = os.path.abspath(a.build)
    if a.compare_build:
        a.compare_build = os.path.abspath(a.compare_build)
    steps_for = {float(k): int(float(v)) for k, v in (kv.split(":") for kv in a.steps.split(","))}
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    mpirun = None if a.no_mpi else shutil.which("mpirun")
    gpu = shutil.which("nvidia-smi") is not None and subprocess.run(
        ["nvidia-smi", "-L"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL).returncode == 0
    wd0 = a.workdir or tempfile.mkdtemp(prefix="dem_bench_")
    launch = {"lammps": ("lmp_sphdem", "/usr/bin/lmp", lammps_input, "gran/hertz/history"),
              "liggghts": ("liggghts_sphdem", "/usr/bin/liggghts", liggghts_input, "gran")}
    print("# dem_bench.py: build %s%s, repeat %d (best loop time kept), OMP_NUM_THREADS=1, GPU %s, workdir %s, "
          "load average %.2f %.2f %.2f" % ((a.build, (", before: " + a.compare_build) if a.compare_build else "", a.repeat,
                                            "present" if gpu else "absent (GPU rows skipped)", wd0) + os.getloadavg()),
          flush=True)
    rows, ratios, cg_rows = [], [], []
    cg_steps = {k: int(v) for k, v in (kv.split(":") for kv in a.callgrind.split(","))} if a.callgrind else {}
    runs = []
    for scene in a.scenes.split(","):
        if scene not in ("column", "gas", "pour"):
            sys.exit("unknown scene %r (column, gas, pour)" % scene)
        for size in ([0.0] if scene == "pour" else [float(s) for s in a.sizes.split(",")]):
            runs.append((scene, size))
    for scene, size in runs:
        nx = max(2, int(round(size ** (1.0 / 3.0)))) if size else 0
        nz = max(1, int(round(size / (nx * nx)))) if size else 0
        steps = a.pour_steps if scene == "pour" else steps_for.get(size, 100)
        for eng in a.engines.split(","):
            exe, stock_exe, gen0, stock_style = launch[eng]
            gen = lambda nx, nz, steps, style, extra, gen0=gen0: gen0(nx, nz, steps, style, extra, scene)
            ours_style = stock_style + ("/gpu" if eng == "liggghts" else "/gpu")
            cases = [("stock %s 1 rank" % stock_style, [stock_exe], gen(nx, nz, steps, stock_style, ""))]
            if mpirun:
                cases.append(("stock %s 2 ranks" % stock_style, [mpirun, "-np", "2", stock_exe],
                              gen(nx, nz, steps, stock_style, "")))
            if a.compare_build:
                cases.append(("%s before, CPU 1 thr" % ours_style, [os.path.join(a.compare_build, "src_fix", exe)],
                              gen(nx, nz, steps, ours_style, "device cpu")))
            cases.append(("%s CPU 1 thr" % ours_style, [os.path.join(a.build, "src_fix", exe)],
                          gen(nx, nz, steps, ours_style, "device cpu timers on")))
            if mpirun:
                cases.append(("%s CPU 1 thr 2 ranks" % ours_style, [mpirun, "-np", "2", os.path.join(a.build, "src_fix", exe)],
                              gen(nx, nz, steps, ours_style, "device cpu timers on")))
            if gpu:
                cases.append(("%s GPU" % ours_style, [os.path.join(a.build, "src_fix", exe)],
                              gen(nx, nz, steps, ours_style, "device gpu timers on")))
            best = {}
            for rep in range(a.repeat):  # interleaved, so that a busy moment hits every code alike
                for k, (label, cmd, text) in enumerate(cases):
                    r = run(cmd, text, os.path.join(wd0, "%s_%s_%g_%d" % (eng, scene, size, k)), env)
                    if r and (label not in best or r["loop"] < best[label]["loop"]):
                        cpu_min = min(r["cpu"], best[label]["cpu_min"]) if label in best else r["cpu"]
                        best[label] = r
                        best[label]["cpu_min"] = cpu_min
                    elif r:
                        best[label]["cpu_min"] = min(best[label]["cpu_min"], r["cpu"])
            for label, cmd, text in cases:
                r = best.get(label)
                if not r:
                    continue
                n, st, loop = r["atoms"], r["steps"], r["loop"]
                contacts = r.get("contacts", float("nan"))
                if "timers" in r:
                    t = r["timers"]
                    calls = max(1.0, t.get("calls", st))
                    transfer = t["pack_s"] + t["upload_s"] + t["download_s"] + t["unpack_s"]
                    split = ("detect %.3f s (%d builds), forces %.3f s, check %.3f s, transfer %.3f ms/step "
                             "(pack %.3f + upload %.3f + download %.3f + unpack %.3f s), pair total %.3f s" %
                             (t["detect_s"], t.get("builds_total", 0), t["force_s"], t["check_s"],
                              1e3 * transfer / calls, t["pack_s"], t["upload_s"], t["download_s"], t["unpack_s"],
                              r.get("Pair", float("nan"))))
                else:
                    split = "Neigh %.3f s, Pair %.3f s" % (r.get("Neigh", float("nan")), r.get("Pair", float("nan")))
                row = "| %s | %d | %s | %s | %d | %.3f | %.4g | %.4g | %.2f | %s |" % (
                    scene, n, eng, label, st, loop, n * st / loop, contacts * st / loop, r["cpu_min"], split)
                rows.append(row)
                print(row, flush=True)
            if scene in cg_steps:
                cg = {}
                for k, (label, cmd, text) in enumerate(cases):
                    if "2 ranks" in label or "GPU" in label:
                        continue
                    text = gen(nx, nz, cg_steps[scene], stock_style if label.startswith("stock") else ours_style,
                               "" if label.startswith("stock") else "device cpu")
                    r = callgrind(cmd, text, os.path.join(wd0, "cg_%s_%s_%g_%d" % (eng, scene, size, k)), env)
                    if r:
                        cg[label] = r
                st = cg.get(cases[0][0])
                for label in cg:
                    r = cg[label]
                    rel = ("%.2f | %.2f | %.2f" % (r["loop"] / st["loop"], r["pair"] / st["pair"],
                                                   (r["pair"] + r["neigh"]) / (st["pair"] + st["neigh"]))) if st else "- | - | -"
                    row = "| %s | %s | %s | %d | %.4g | %.4g | %.4g | %s |" % (scene, eng, label, cg_steps[scene], r["loop"],
                                                                           r["pair"], r["neigh"], rel)
                    cg_rows.append(row)
                    print(row, flush=True)
            s1, g1 = best.get(cases[0][0]), best.get("%s CPU 1 thr" % ours_style)
            if s1 and g1:
                sp = s1.get("Pair", float("nan"))
                ratios.append((scene, s1["atoms"], eng, g1["loop"] / s1["loop"], g1.get("Pair", float("nan")) / sp,
                               g1.get("Pair", float("nan")) / (sp + s1.get("Neigh", 0.0)), g1["cpu_min"] / s1["cpu_min"]))
    print("\n| scene | grains | engine | code | steps | loop s (best of %d) | particle-steps/s | contacts/s | CPU s of "
          "the process (min; set-up included) | split |" % a.repeat)
    print("|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        print(row)
    print("\n/gpu (CPU backend, 1 rank, 1 thread) / stock (1 rank); load average %.2f %.2f %.2f at the end\n" %
          os.getloadavg())
    print("| scene | grains (end) | engine | loop | Pair | Pair / (stock Pair + Neigh) | process CPU |")
    print("|---|---|---|---|---|---|---|")
    for scene, n, eng, rl, rp, rpn, rc in ratios:
        print("| %s | %d | %s | %.2f | %.2f | %.2f | %.2f |" % (scene, n, eng, rl, rp, rpn, rc))
    if cg_rows:
        print("\nInstructions (callgrind Ir, inclusive; one run each; ratios to stock 1 rank)\n")
        print("| scene | engine | code | steps | loop (Verlet::run) | Pair compute | Neighbor::build | loop ratio | "
              "Pair ratio | Pair + Neigh ratio |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for row in cg_rows:
            print(row)


if __name__ == "__main__":
    sys.exit(main())
