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

  python3 bench/dem_bench.py [--build build] [--sizes 1e4,1e5] [--steps 1e4:1000,1e5:100,1e6:10]
                             [--repeat 3] [--no-mpi] [--engines lammps,liggghts] [--compare-build DIR]
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


def lammps_input(nx, nz, steps, style, extra):
    L, Hins = nx * A, nz * A
    return (COMMON_TOP.format(L=L, H=Hins + 0.02).replace("units           si\n", "units           si\natom_style      sphere\n")
            + "comm_modify     vel yes\nneigh_modify    delay 0 every 1 check yes\n"
            + LATTICE.format(a=A, L=L, Hins=Hins)
            + "pair_style      %s 2e7 NULL 5e3 NULL 0.5 1 %s\npair_coeff      * *\n" % (style, extra)
            + "fix             floor all wall/gran hertz/history 2e7 NULL 5e3 NULL 0.5 1 zplane 0 NULL\n"
            + TAIL.format(steps=steps))


def liggghts_input(nx, nz, steps, style, extra):
    L, Hins = nx * A, nz * A
    return (COMMON_TOP.format(L=L, H=Hins + 0.02).replace("units           si\n", "units           si\natom_style      granular\n")
            + "communicate     single vel yes\nneigh_modify    delay 0\n"
            + "fix             m1 all property/global youngsModulus peratomtype 5e6\n"
            + "fix             m2 all property/global poissonsRatio peratomtype 0.45\n"
            + "fix             m3 all property/global coefficientRestitution peratomtypepair 1 0.7\n"
            + "fix             m4 all property/global coefficientFriction peratomtypepair 1 0.5\n"
            + "pair_style      %s model hertz tangential history %s\npair_coeff      * *\n" % (style, extra)
            + LATTICE.format(a=A, L=L, Hins=Hins)
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
    print("# dem_bench.py: build %s%s, repeat %d (best loop time kept), OMP_NUM_THREADS=1, GPU %s, workdir %s" %
          (a.build, (", before: " + a.compare_build) if a.compare_build else "", a.repeat,
           "present" if gpu else "absent (GPU rows skipped)", wd0), flush=True)
    rows = []
    for size in (float(s) for s in a.sizes.split(",")):
        nx = max(2, int(round(size ** (1.0 / 3.0))))
        nz = max(1, int(round(size / (nx * nx))))
        steps = steps_for.get(size, 100)
        for eng in a.engines.split(","):
            exe, stock_exe, gen, stock_style = launch[eng]
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
                    r = run(cmd, text, os.path.join(wd0, "%s_%g_%d" % (eng, size, k)), env)
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
                row = "| %d | %s | %s | %d | %.3f | %.4g | %.4g | %.2f | %s |" % (
                    n, eng, label, st, loop, n * st / loop, contacts * st / loop, r["cpu_min"], split)
                rows.append(row)
                print(row, flush=True)
    print("\n| grains | engine | code | steps | loop s (best of %d) | particle-steps/s | contacts/s | CPU s of the "
          "process (min; set-up included) | split |" % a.repeat)
    print("|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        print(row)


if __name__ == "__main__":
    sys.exit(main())
