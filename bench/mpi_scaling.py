#!/usr/bin/python3
"""mpi_scaling.py - strong scaling of the sphdem styles over MPI ranks, in one invocation.

Scenes (the project's own examples and DEM bench scene, through the sphdem launchers of BUILD/src_fix):
  dambreak2d_40, dambreak2d_80  examples/dambreak2d (a/dx = 40, 80), fix sph/fluid, lmp_sphdem
  dambreak3d                    examples/dambreak3d (-var dx, coarse), fix sph/fluid, lmp_sphdem
  bubbling_bed                  examples/bubbling_bed, fix cfd/grid + gran/hooke/history, lmp_sphdem
  dem_column                    bench/dem_bench.py's settling column (LAMMPS input), gran/hertz/history/gpu
                                device cpu timers on, lmp_sphdem
  dem_column_liggghts           the same column through liggghts_sphdem, pair gran/gpu model hertz
  settling                      examples/settling, fix sph/fluid + fix sph/couple (one sphere), lmp_sphdem
  drum200                       examples/drum at D = 200 mm (drum_bench.py's coarse grains), fix sph/couple, lmp_sphdem
each at 1 and 2 MPI ranks pinned (--bind-to core) and 4 ranks oversubscribed (--bind-to none; on a 2-core
machine this checks correctness and overhead only, it is not a scaling point). OMP_NUM_THREADS=1.

The example inputs are copied into a work directory with three changes: the final `run` becomes `run WARMUP`
+ `run STEPS` (the numbers come from the second run), dump/print output is dropped, and on several ranks a
`balance 1.0 shift <dims> 20 1.0` before the runs (LAMMPS only; the dam breaks weight a wall particle 0.05 of a
fluid one) moves the cuts so that every rank owns a share of the particles (the examples' boxes are much larger than the initial fluid or bed: the engine's uniform split would
leave a rank with walls or empty gas only). A static balance: the fluid moves afterwards.

Per scene and rank count it prints: loop time (best of --repeat, the repeats interleaved), parallel efficiency
T1/(N TN), the fix's own timing line (Fix sph/fluid timing / Fix cfd/grid gas time / the pair style's timers),
the engine's Comm time (avg over ranks), owned atoms (Nlocal ave/max) and ghost atoms per rank (Nghost ave/max),
and the modelled bytes per step per rank of the forward communication:
    fluid fix : 9 doubles (v, rho, drho, a, mass) x ghost atoms (fluid + walls) x fluid steps / steps
    engine    : 3 doubles (x) x ghost atoms every step, 9 (x, v, omega) with comm_modify vel yes (DEM, bed)
    cfd/grid  : the allreduce volume it reports (MB per run / steps)
(ghost counts are the engine's Nghost average; on 1 rank the ghosts are periodic copies, no MPI traffic.)

Then a weak-scaling projection for the 3D dam break to 64-1024 ranks (model printed with its numbers), and
LIGGGHTS' own SPH (bench/liggghts/in.dambreak2d: pair sph/artVisc/tensCorr, fix sph/density/continuity,
fix sph/pressure, fix nve/sph) against fix sph/fluid in liggghts_sphdem on the same particles of
examples/dambreak2d (a/dx = 40) at 1 and 2 ranks. LIGGGHTS has no `balance` command, so for this pair the box is
extended to the left until its middle lies in the middle of the water column (the 2-rank cut then splits the
column in two for both codes).

  /usr/bin/python3 bench/mpi_scaling.py BUILD [--repeat 3] [--quick] [--results bench/RESULTS.md]
A benchmark: it prints numbers (and a markdown section with --write) and asserts nothing.
"""
import argparse
import datetime
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import dem_bench  # noqa: E402  (the DEM scene generator of the project's DEM bench)

# assumed network for the projection (a typical InfiniBand-class cluster)
NET_LAT = 2e-6      # s per message
NET_BW = 10e9       # bytes/s per rank
NEIGHBOURS = 6      # face neighbours of a cubic subdomain; LAMMPS forwards in 6 swaps (2 per dimension)
ALLREDUCES = 3      # per fluid step: displacement check (max) + the statistics (dt, rho error, ke)


def loadavg():
    with open("/proc/loadavg") as f:
        return f.read().split()[0]


def env():
    return dict(os.environ, OMP_NUM_THREADS="1", OMPI_MCA_rmaps_base_oversubscribe="1")


def mpi_prefix(n):
    mpirun = shutil.which("mpirun")
    base = [mpirun, "-np", str(n), "--oversubscribe", "--allow-run-as-root"]
    if n <= (os.cpu_count() or 1):
        return base + ["--bind-to", "core"]
    return base + ["--bind-to", "none"]


def with_runs(text, warm, steps, nranks, dims, weight=""):
    """Replace the last run command by balance (several ranks) + run warm + run steps; drop dump/print output."""
    lines = text.splitlines()
    out, k_run = [], None
    skip_cont = False
    for ln in lines:
        s = ln.strip()
        if skip_cont:
            skip_cont = s.endswith("&")
            continue
        if re.match(r"^(dump|dump_modify)\s", s) or re.match(r"^fix\s+\S+\s+\S+\s+print\s", s):
            skip_cont = s.endswith("&")
            continue
        out.append(ln)
        if re.match(r"^run\s", s):
            k_run = len(out) - 1
    if k_run is None:
        raise RuntimeError("no run command in the input")
    tail = []
    if nranks > 1 and dims:
        tail.append("balance 1.0 shift %s 20 1.0%s" % (dims, weight))
    tail += ["run %d" % warm, "run %d" % steps]
    out[k_run:k_run + 1] = tail
    return "\n".join(out) + "\n"


NUM = r"([0-9.eE+-]+)"


def parse(text):
    r = {}
    loops = re.findall(r"Loop time of %s on (\d+) procs for (\d+) steps with (\d+) atoms" % NUM, text)
    if not loops:
        return None
    r["loop"], r["procs"], r["steps"], r["atoms"] = float(loops[-1][0]), int(loops[-1][1]), int(loops[-1][2]), int(loops[-1][3])
    last = text[text.rfind("Loop time of"):]
    m = re.search(r"^Comm\s*\|\s*%s\s*\|\s*%s\s*\|\s*%s" % (NUM, NUM, NUM), last, re.M)
    if m:
        r["comm_avg"], r["comm_max"] = float(m.group(2)), float(m.group(3))
    else:  # LIGGGHTS: Comm  time (%) = 0.0123 (1.2)
        m = re.search(r"^Comm\s+time \(%%\) = %s" % NUM, last, re.M)
        if m:
            r["comm_avg"] = r["comm_max"] = float(m.group(1))
    for key in ("Nlocal", "Nghost"):
        m = re.search(r"^%s:\s*%s ave\s*%s max\s*%s min" % (key, NUM, NUM, NUM), last, re.M)
        if m:
            r[key] = (float(m.group(1)), float(m.group(2)), float(m.group(3)))
    m = re.findall(r"^(Fix sph/fluid timing.*)$", text, re.M)
    if m:
        r["fixline"] = m[-1].strip()
        mm = re.search(r"over (\d+) fluid steps", m[-1])
        r["fluid_steps"] = int(mm.group(1)) if mm else r["steps"]
    m = re.findall(r"^(Fix cfd/grid: gas time.*)$", text, re.M)
    if m:
        r["fixline"] = m[-1].strip()
        mm = re.search(r"in (\d+) reductions of %s MB" % NUM, m[-1])
        if mm:
            r["cfd_red"], r["cfd_mb"] = int(mm.group(1)), float(mm.group(2))
    m = re.findall(r"^(.*timers: .*)$", text, re.M)
    if m and "fixline" not in r:
        r["fixline"] = m[-1].strip()
    m = re.search(r"Fix sph/fluid: .*?; (\d+) fluid \+ (\d+) wall particles", text)
    if m:
        r["nfluid"], r["nwall"] = int(m.group(1)), int(m.group(2))
    m = re.findall(r"walls ([0-9.eE+-]+), rates .*total ([0-9.eE+-]+) over", text)
    if m:
        r["fix_walls"], r["fix_total"] = float(m[-1][0]), float(m[-1][1])
    m = re.findall(r"^(Fix sph/fluid: \d+ MPI ranks.*)$", text, re.M)
    if m:
        r["ghostline"] = m[-1].strip()
    m = re.search(r"^%s%% CPU use with" % NUM, last, re.M)
    if m:
        r["cpu_use"] = float(m.group(1))
    r["errors"] = [ln for ln in text.splitlines() if "ERROR" in ln][:3]
    return r


def run_one(cmd, wd, inp, logname, extra_env=None):
    os.makedirs(wd, exist_ok=True)
    with open(os.path.join(wd, "in.run"), "w") as f:
        f.write(inp)
    la = loadavg()
    t0 = time.monotonic()
    u0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(cmd + ["-in", "in.run", "-log", logname], cwd=wd, env=dict(env(), **(extra_env or {})), stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, errors="replace", timeout=1800)
    wall = time.monotonic() - t0
    u1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (u1.ru_utime - u0.ru_utime) + (u1.ru_stime - u0.ru_stime)
    r = parse(p.stdout)
    bad = [ln for ln in p.stdout.splitlines() if "ERROR" in ln]
    if p.returncode != 0 or r is None or bad:
        return dict(failed=True, rc=p.returncode, cmd=" ".join(cmd + ["-in", "in.run"]), wd=wd, load=la,
                    tail=p.stdout[-1500:], errors=bad[:3])
    r.update(load=la, wall=wall, cpu=cpu, cmd=" ".join(cmd + ["-in", "in.run"]))
    return r


# ---------------------------------------------------------------------------------------------------------
# scenes

def read(p):
    with open(os.path.join(ROOT, p)) as f:
        return f.read()


# the fluid balance counts a wall particle as 1/20 of a fluid one (1-rank 3D dam break: walls 0.56 s for 69747
# wall particles, rates 3.16 s for 16200 fluid); unweighted, the cut would equalise atoms, i.e. walls
WALL_WEIGHT = " weight group 2 fluid 1.0 walls 0.05"


def scenes(a):
    q = a.quick
    S = []
    src = read("examples/dambreak2d/in.dambreak2d")
    for nres, steps in ((40, 150 if q else 1000), (80, 50 if q else 300)):
        S.append(dict(name="dambreak2d_%d" % nres, exe="lmp_sphdem", text=src, vars={"nres": str(nres)}, weight=WALL_WEIGHT,
                      steps=steps, dims="xy", nfluid=nres * 2 * nres, evars=3, fluid=True,
                      what="examples/dambreak2d -var nres %d" % nres))
    src = read("examples/dambreak3d/in.dambreak3d")
    dx3 = a.dx3d
    S.append(dict(name="dambreak3d", exe="lmp_sphdem", text=src, weight=WALL_WEIGHT, vars={"dx": repr(dx3), "steps": "10", "ndump": "1000000"},
                  steps=30 if q else 100, dims="xyz", nfluid=None, evars=3, fluid=True,
                  what="examples/dambreak3d -var dx %g" % dx3))
    src = read("examples/bubbling_bed/in.bubbling_bed")
    S.append(dict(name="bubbling_bed", exe="lmp_sphdem", text=src,
                  vars={"tend": "0.0001", "nvtk": "100000000", "ndump": "100000000"},
                  steps=250 if q else 1000, dims="xyz", nfluid=None, evars=9, fluid=False,
                  what="examples/bubbling_bed (fix cfd/grid, gran/hooke/history)"))
    nx, nz = 22, 21  # dem_bench.py's 1e4 column: 22 x 22 x 21 = 10164 grains
    S.append(dict(name="dem_column", exe="lmp_sphdem",
                  text=dem_bench.lammps_input(nx, nz, 200 if q else 1000, "gran/hertz/history/gpu", "device cpu timers on"),
                  vars={}, steps=200 if q else 1000, dims="xyz", nfluid=None, evars=9, fluid=False,
                  what="bench/dem_bench.py 1e4 column, gran/hertz/history/gpu device cpu"))
    src = read("examples/settling/in.settling")
    S.append(dict(name="settling", exe="lmp_sphdem", text=src, weight=WALL_WEIGHT, vars={},
                  steps=200 if q else 600, dims="xyz", nfluid=None, evars=3, fluid=True,
                  what="examples/settling (fix sph/fluid + fix sph/couple, one sphere), fluid every 2 steps"))
    D, ngrain = 0.2, int(round(969 * 8))  # bench/drum_bench.py --coarse at D = 0.2 m (grains ~ D^3)
    src = read("examples/drum/in.drum")
    S.append(dict(name="drum200", exe="lmp_sphdem", text=src, weight=" weight group 3 fluid 1.0 grains 1.0 walls 0.05",
                  vars={"D": "0.2", "ngrain": str(ngrain), "dg": "0.0054", "dx": "0.006", "dt": "1e-05", "every": "2",
                        "tsettle": "0.002" if q else "0.01", "trot": "0.002", "tavg": "0.002", "nsamp": "1",
                        "nfluid": "1"},
                  steps=50 if q else 100, dims="xyz", nfluid=None, evars=3, fluid=True,
                  what="examples/drum at D = 200 mm, bench/drum_bench.py's coarse variables (%d grains 5.4 mm, dx 6 mm, "
                       "dt 1e-5 s, fluid every 2), settling %s s untimed (the bed is still settling), then the rotation "
                       "timed" % (ngrain, "0.002" if q else "0.01")))
    S.append(dict(name="dem_column_liggghts", exe="liggghts_sphdem",
                  text=dem_bench.liggghts_input(nx, nz, 200 if q else 1000, "gran/gpu", "device cpu timers on"),
                  vars={}, steps=200 if q else 1000, dims=None, nfluid=None, evars=9, fluid=False,
                  what="the same column in LIGGGHTS, pair gran/gpu model hertz tangential history device cpu "
                       "(LIGGGHTS has no balance command: the engine's uniform cut along z)"))
    return S


def scene_cmd(build, sc, n):
    exe = os.path.join(build, "src_fix", sc["exe"])
    cmd = ([exe] if n == 1 else mpi_prefix(n) + [exe]) + ["-echo", "none"]
    for k, v in sc["vars"].items():
        cmd += ["-var", k, v]
    return cmd


def comm_bytes(sc, r):
    """Modelled forward-communication bytes per step per rank (see the module doc)."""
    if "Nghost" not in r or r["procs"] == 1:
        return None
    g = r["Nghost"][0]
    b = 8.0 * sc["evars"] * g
    if sc["fluid"]:
        b += 8.0 * 9 * g * r.get("fluid_steps", r["steps"]) / max(1, r["steps"])
    if "cfd_mb" in r:
        b += 1e6 * r["cfd_mb"] / max(1, r["steps"])
    return b


# ---------------------------------------------------------------------------------------------------------
# LIGGGHTS' SPH vs fix sph/fluid on the examples/dambreak2d particles

def dambreak2d_particles(nres):
    """The particles of examples/dambreak2d (same lattice, regions), with Tait hydrostatic densities."""
    a, rho0, g = 0.1, 1000.0, 9.81
    dx = a / nres
    h = 1.3 * dx
    c0 = 10 * math.sqrt(g * 2 * a)
    gam = 7.0
    B = rho0 * c0 * c0 / gam
    xw, wt, ht = 5 * a, 3 * dx, 3 * a
    H = 2 * a

    def rho_at(y):
        depth = H - y
        return rho0 * (1 + rho0 * g * depth / B) ** (1 / gam) if depth > 0 else rho0

    def lat(x0, x1, y0, y1):
        i0, i1 = math.ceil(x0 / dx - 0.5 - 1e-9), math.floor(x1 / dx - 0.5 + 1e-9)
        j0, j1 = math.ceil(y0 / dx - 0.5 - 1e-9), math.floor(y1 / dx - 0.5 + 1e-9)
        return [((i + 0.5) * dx, (j + 0.5) * dx) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]

    fl = lat(0, a, 0, H)
    walls = lat(-wt, xw + wt, -wt, 0) + lat(-wt, 0, 0, ht) + lat(xw, xw + wt, 0, ht)
    return dict(dx=dx, h=h, c0=c0, B=B, rho0=rho0, gam=gam, g=g, dt=0.2 * h / (1.2 * c0), fl=fl, walls=walls,
                rho=[rho_at(y) for _, y in fl], rhow=[rho_at(y) if 0 <= x <= a else rho0 for x, y in walls], a=a)


def liggghts_sph_pair(a, build, wd, steps, warm):
    P = dambreak2d_particles(40)
    # box of the example (-0.05 .. 0.55 in x), extended to the left until its middle is at x = a/2
    xlo, xhi = P["a"] / 2 - (0.55 - P["a"] / 2), 0.55
    ylo, yhi = -0.05, 0.5
    dx = P["dx"]
    os.makedirs(wd, exist_ok=True)
    data = os.path.join(wd, "dambreak2d_40.data")
    m = P["rho0"] * dx * dx
    with open(data, "w") as f:
        f.write("examples/dambreak2d particles, a/dx 40 (mpi_scaling.py)\n\n%d atoms\n2 atom types\n\n" %
                (len(P["fl"]) + len(P["walls"])))
        f.write("%.17g %.17g xlo xhi\n%.17g %.17g ylo yhi\n%.17g %.17g zlo zhi\n\n" % (xlo, xhi, ylo, yhi, -dx, dx))
        f.write("Masses\n\n1 %.17g\n2 %.17g\n\nAtoms\n\n" % (m, m))
        k = 0
        # atom_style sph in LIGGGHTS 3.8 reads "id type rho 0 x y z ix iy" (see bench_dambreak.c)
        for (x, y), rho in zip(P["fl"], P["rho"]):
            k += 1
            f.write("%d 1 %.12g 0 %.12g %.12g 0 0 0\n" % (k, rho, x, y))
        for (x, y), rho in zip(P["walls"], P["rhow"]):
            k += 1
            f.write("%d 2 %.12g 0 %.12g %.12g 0 0 0\n" % (k, rho, x, y))
    lig_vars = dict(data=data, h=repr(P["h"]), dx=repr(dx), c0=repr(P["c0"]), B=repr(P["B"]), rho0="1000",
                    gam="7", alpha="0.02", eta=repr(0.01 * P["h"] ** 2), tens="0.01", skin=repr(dx), g="9.81",
                    dt=repr(P["dt"]), warmup=str(warm), steps=str(steps), kernel="wendland2d", sort="1000")
    # fix sph/fluid on the same particles: the example input with the extended box
    src = read("examples/dambreak2d/in.dambreak2d")
    src = src.replace("region        box block -0.05 0.55", "region        box block %.17g 0.55" % xlo)
    if "%.17g 0.55" % xlo not in src:
        raise RuntimeError("examples/dambreak2d: box line not found")
    ours = with_runs(src, warm, steps, 1, None)
    cases = []
    for n in (1, 2):
        pre = [] if n == 1 else mpi_prefix(n)
        lcmd = pre + ["/usr/bin/liggghts", "-echo", "none"]
        for k2, v in lig_vars.items():
            lcmd += ["-var", k2, v]
        cases.append(("LIGGGHTS sph/artVisc/tensCorr", n, lcmd, read("bench/liggghts/in.dambreak2d")))
        cases.append(("sphdem fix sph/fluid (liggghts_sphdem)", n,
                      pre + [os.path.join(build, "src_fix", "liggghts_sphdem"), "-echo", "none", "-var", "nres", "40"],
                      ours))
    best = {}
    for rep in range(a.repeat):
        for k, (label, n, cmd, text) in enumerate(cases):
            r = run_one(cmd, os.path.join(wd, "case%d" % k), text, "log.run")
            key = (label, n)
            if r.get("failed"):
                best.setdefault(key, r)
                print("  FAILED %s np %d (rc %s): %s\n%s" % (label, n, r["rc"], r["cmd"], r["tail"]), flush=True)
                continue
            if key not in best or best[key].get("failed") or r["loop"] < best[key]["loop"]:
                r["all"] = best.get(key, {}).get("all", []) + [r["loop"]]
                best[key] = r
            else:
                best[key]["all"].append(r["loop"])
    nf = len(P["fl"])
    rows = []
    for label, n, cmd, _ in cases[:2] + cases[2:]:
        r = best[(label, n)]
        if r.get("failed"):
            rows.append((label, n, None, r))
            continue
        rows.append((label, n, nf * r["steps"] / r["loop"], r))
    return rows, nf, len(P["walls"])


# ---------------------------------------------------------------------------------------------------------
# weak-scaling projection

def projection(tp, w_over_dx, evars):
    """Projected weak-scaling efficiency for n fluid particles per rank on P ranks (cubic subdomains);
    tp: seconds per fluid particle-step, a number or a dict n -> number."""
    out = []
    for n in (1e4, 1e5, 1e6):
        t = tp[n] if isinstance(tp, dict) else tp
        side = n ** (1.0 / 3.0)
        g = (side + 2 * w_over_dx) ** 3 - n
        t_comp = n * t
        bytes_step = 8.0 * (9 + evars) * g
        t_p2p = 2 * NEIGHBOURS * NET_LAT + bytes_step / NET_BW  # two forward comms (fix + engine x), 6 swaps each
        row = dict(n=n, ghosts=g, ghost_frac=g / n, t_comp=t_comp, bytes=bytes_step, t_p2p=t_p2p, eff={})
        for P in (64, 128, 256, 512, 1024):
            t_red = ALLREDUCES * 2 * math.log2(P) * NET_LAT  # recursive doubling, tiny payloads
            row["eff"][P] = t_comp / (t_comp + t_p2p + t_red)
        out.append(row)
    return out


# fluid particle-steps/s of the CUDA backend (bench/RESULTS.md, 3D dam break on an H100: 72.8 M at 1e5 fluid,
# 129.9 M at 1e6); 1e4 takes the 1e5 rate (optimistic: smaller launches are slower per particle)
GPU_TP = {1e4: 1 / 72.8e6, 1e5: 1 / 72.8e6, 1e6: 1 / 129.9e6}


# ---------------------------------------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build", help="build directory holding src_fix/lmp_sphdem and src_fix/liggghts_sphdem")
    ap.add_argument("--repeat", type=int, default=3, help="runs per case, the best loop time kept (interleaved)")
    ap.add_argument("--ranks", default="1,2,2y,4",
                    help="rank counts; a trailing y: the same with OMPI_MCA_mpi_yield_when_idle=1 (waiting ranks yield the core)")
    ap.add_argument("--warmup", type=int, default=5, help="untimed steps before the timed run")
    ap.add_argument("--dx3d", type=float, default=0.008, help="particle spacing of the 3D dam break")
    ap.add_argument("--scenes", default=None, help="comma list of scene names (default: all)")
    ap.add_argument("--no-liggghts", action="store_true", help="skip LIGGGHTS' SPH vs fix sph/fluid")
    ap.add_argument("--quick", action="store_true", help="few steps, one repeat (smoke run)")
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--markdown", default=None, help="also write the tables as markdown to this file")
    a = ap.parse_args()
    if a.quick:
        a.repeat = 1
    build = os.path.abspath(a.build)
    for exe in ("lmp_sphdem", "liggghts_sphdem"):
        if not os.access(os.path.join(build, "src_fix", exe), os.X_OK):
            sys.exit("no %s in %s/src_fix" % (exe, build))
    ranks = a.ranks.split(",")
    wd0 = a.workdir or tempfile.mkdtemp(prefix="mpi_scaling_")
    ncpu = os.cpu_count()
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], stdout=subprocess.PIPE,
                            text=True).stdout.strip()
    t_start = time.monotonic()
    md = []
    say = print

    def both(s=""):
        say(s, flush=True)
        md.append(s)

    both("# mpi_scaling.py %s, commit %s, %d CPUs, load average at start %s, OMP_NUM_THREADS=1, repeat %d, "
         "workdir %s" % (datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"), commit, ncpu,
                         open("/proc/loadavg").read().split()[:3], a.repeat, wd0))
    S = scenes(a)
    if a.scenes:
        want = a.scenes.split(",")
        S = [s for s in S if s["name"] in want]
    results = {}
    failures = []
    for sc in S:
        cases = []
        for tok in ranks:
            n = int(tok.rstrip("y"))
            cases.append((tok, n, scene_cmd(build, sc, n), with_runs(sc["text"], a.warmup, sc["steps"], n, sc["dims"], sc.get("weight", ""))))
        best = {}
        for rep in range(a.repeat):
            for tok, n, cmd, text in cases:
                extra = {"OMPI_MCA_mpi_yield_when_idle": "1"} if tok.endswith("y") else {}
                r = run_one(cmd, os.path.join(wd0, "%s_np%s" % (sc["name"], tok)), text, "log.run", extra)
                if r.get("failed"):
                    failures.append((sc["name"], tok, r))
                    say("  FAILED %s np %s (rc %s, load %s): cd %s && %s\n  %s\n%s" %
                        (sc["name"], tok, r["rc"], r["load"], r["wd"], r["cmd"], r["errors"], r["tail"]), flush=True)
                    best.setdefault(tok, r)
                    continue
                b0 = best.get(tok)
                if b0 is None or b0.get("failed") or r["loop"] < b0["loop"]:
                    r["all"] = ((b0 or {}).get("all") or []) + [r["loop"]]
                    r["loads"] = ((b0 or {}).get("loads") or []) + [r["load"]]
                    r["cpu_min"] = min([r["cpu"]] + ([b0["cpu_min"]] if b0 and "cpu_min" in b0 else []))
                    best[tok] = r
                else:
                    b0["all"].append(r["loop"])
                    b0["loads"].append(r["load"])
                    b0["cpu_min"] = min(b0["cpu_min"], r["cpu"])
        results[sc["name"]] = (sc, best)
        both("")
        both("### %s: %s, %d timed steps after %d warm-up" % (sc["name"], sc["what"], sc["steps"], a.warmup))
        r1 = best.get("1")
        cmd_show = " ".join(cases[-1][2]).replace(build, "BUILD")
        both("command (%d ranks): `cd WORKDIR && %s -in in.run -log log.run`" % (cases[-1][1], cmd_show))
        both("")
        both("| ranks | atoms | loop (s), best of runs | load avg (1 min) per run | T1/(N TN) | CPU use (engine) "
             "| process CPU s, all ranks (min) | Comm avg/max (s) | Nlocal ave/max | Nghost ave/max | modelled B/step/rank |")
        both("|---|---|---|---|---|---|---|---|---|---|---|")
        for tok, n, _, _ in cases:
            r = best.get(tok)
            if r is None or r.get("failed"):
                both("| %s | FAILED | %s | | | | | | | | |" % (tok, (r or {}).get("errors", "")))
                continue
            eff = (r1["loop"] / (n * r["loop"])) if r1 and not r1.get("failed") else float("nan")
            b = comm_bytes(sc, r)
            note = " (oversubscribed)" if n > ncpu else (" (yield when idle)" if tok.endswith("y") else "")
            both("| %d%s | %d | %.3f (%s) | %s | %.2f | %s | %.2f | %s | %s | %s | %s |" % (
                n, note, r["atoms"], r["loop"], ", ".join("%.2f" % x for x in r["all"]), ", ".join(r["loads"]), eff,
                "%.0f %%" % r["cpu_use"] if "cpu_use" in r else "-", r["cpu_min"],
                "%.3f/%.3f" % (r.get("comm_avg", float("nan")), r.get("comm_max", float("nan"))),
                "%.0f/%.0f" % r["Nlocal"][:2] if "Nlocal" in r else "-",
                "%.0f/%.0f" % r["Nghost"][:2] if "Nghost" in r else "-",
                "%.0f" % b if b is not None else "- (1 rank)"))
        for tok, n, _, _ in cases:
            r = best.get(tok)
            if r and not r.get("failed") and r.get("fixline"):
                both("- np %s: `%s`" % (tok, r["fixline"]))
            if r and not r.get("failed") and r.get("ghostline") and tok == cases[-1][0]:
                both("- np %s: `%s`" % (tok, r["ghostline"]))

    # weak-scaling projection from the 3D dam break
    if "dambreak3d" in results:
        sc, best = results["dambreak3d"]
        r1 = best.get("1")
        if r1 and not r1.get("failed"):
            dx = a.dx3d
            h = 1.3 * dx
            w = 2 * 2 * h + dx  # 2 levels (walls) x 2h + neighbour skin (neighbor dx)
            nf = r1.get("nfluid", r1["atoms"])
            tp = (r1["fix_total"] - r1["fix_walls"]) / (nf * r1["fluid_steps"])
            both("")
            both("### Weak-scaling projection, 3D dam break (model)")
            both("Compute per fluid particle-step from the 1-rank run: (fix total - walls) / (%d fluid x %d fluid steps) "
                 "= %.3g s (CPU backend, one core, %s %% CPU use). Cubic bulk subdomain of n fluid particles, ghost "
                 "band w = 2 levels x 2h + skin = %.2f dx: ghosts g = (n^(1/3) + 2 w/dx)^3 - n; per step 2 forward "
                 "communications (fix: 9 doubles, engine: 3 doubles x g) in %d swaps each, %d allreduces of a few "
                 "doubles (recursive doubling, 2 log2 P latencies each). Network assumed: latency %.0f us, bandwidth "
                 "%.0f GB/s per rank; efficiency = compute / (compute + communication): no overlap, no load imbalance, "
                 "no cost for the ghosts' own work (the wall state and kernel sums are evaluated on ghosts too), "
                 "neighbour builds (every 50 steps: borders, exchange) and, for GPUs, the host staging of the ghost "
                 "state left out."
                 % (nf, r1["fluid_steps"], tp, r1.get("cpu_use", "?"), w / dx, NEIGHBOURS, ALLREDUCES,
                    NET_LAT * 1e6, NET_BW / 1e9))
            for label, t in (("CPU backend, 1 core per rank (measured rate)", tp),
                             ("CUDA backend, 1 GPU per rank (H100 rates of bench/RESULTS.md)", GPU_TP)):
                both("")
                both(label + ":")
                both("")
                both("| n per rank | ghosts g (g/n) | compute/step | bytes/step | p2p/step | eff P=64 | 128 | 256 | 512 | 1024 |")
                both("|---|---|---|---|---|---|---|---|---|---|")
                for row in projection(t, w / dx, 3):
                    both("| %.0e | %.3g (%.2f) | %.3g s | %.3g | %.3g s | %s |" % (
                        row["n"], row["ghosts"], row["ghost_frac"], row["t_comp"], row["bytes"], row["t_p2p"],
                        " | ".join("%.3f" % row["eff"][P] for P in (64, 128, 256, 512, 1024))))
            r2 = best.get("2")
            if r2 and not r2.get("failed"):
                both("Measured 2 ranks on this machine: T1/(2 T2) = %.2f with g/n = %.2f per rank (Nghost/Nlocal)."
                     % (r1["loop"] / (2 * r2["loop"]), r2["Nghost"][0] / max(1.0, r2["Nlocal"][0])))

    if not a.no_liggghts:
        rows, nf, nw = liggghts_sph_pair(a, build, os.path.join(wd0, "liggghts_sph"), 300, a.warmup)
        both("")
        both("### LIGGGHTS' SPH vs fix sph/fluid, examples/dambreak2d particles (a/dx 40: %d fluid + %d wall), "
             "300 timed steps after %d, box extended to x >= %.2f so that the 2-rank cut halves the column" %
             (nf, nw, a.warmup, 0.05 - 0.5))
        both("")
        both("| code | ranks | loop (s), best of runs | load per run | fluid particle-steps/s | Comm avg/max (s) | Nlocal ave/max |")
        both("|---|---|---|---|---|---|---|")
        for label, n, ps, r in rows:
            if ps is None:
                both("| %s | %d | FAILED rc %s %s | | | | |" % (label, n, r.get("rc"), r.get("errors")))
                continue
            both("| %s | %d | %.3f (%s) | %s | %.3g | %s | %s |" % (
                label, n, r["loop"], ", ".join("%.2f" % x for x in r["all"]), r["load"], ps,
                "%.3f/%.3f" % (r.get("comm_avg", float("nan")), r.get("comm_max", float("nan"))),
                "%.0f/%.0f" % r["Nlocal"][:2] if "Nlocal" in r else "-"))
        for label, n, ps, r in rows:
            if ps is not None and n == 2:
                both("- %s np 2 command: `cd WORKDIR && %s -in in.run`" % (label, " ".join(
                    x if len(x) < 60 else "..." for x in r["cmd"].replace(build, "BUILD").split()[:-2])))
    both("")
    both("total %.0f s, load average at end %s" % (time.monotonic() - t_start, open("/proc/loadavg").read().split()[:3]))
    if failures:
        both("FAILURES: " + "; ".join("%s np %s: %s" % (s, n, r["errors"] or ("rc %s" % r["rc"])) for s, n, r in failures))
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write("\n".join(md) + "\n")


if __name__ == "__main__":
    main()
