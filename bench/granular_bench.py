#!/usr/bin/python3
"""granular_bench.py - pair_style granular/gpu (sphdem CPU backend) against the stock LAMMPS pair_style granular.

Scenes (SI units, d = 5 mm, 2500 kg/m^3, periodic x y, a wall/gran floor, gravity, dt 2e-6 s, skin 1 mm,
atom sorting every 1000 steps), each run with the stock style and with granular/gpu in the same launcher
(lmp_sphdem), one MPI rank, OMP_NUM_THREADS=1:
  column  a dense column: simple cubic lattice of spacing 4.999 mm (every grain touches its lattice
          neighbours from the start), nx * nx * nz grains, random velocities of ~0.01 m/s
  gas     a loose granular gas: lattice spacing 5.5 mm, random velocities of ~0.5 m/s
Models (pair_coeff * *): mindlin = hertz/material 5e6 0.5 0.45 tangential mindlin NULL 1.0 0.5 (damping
viscoelastic), roll_twist = the same plus rolling sds 1e-3 1e-6 0.2 twisting marshall.
Printed per run (the best loop time of --repeat runs): the loop time and the Pair time of the engine's timing
table, the contacts at the end, the CPU seconds of the process (set-up included; less sensitive than the loop
time to other jobs on a shared machine); then the ratios granular/gpu / stock, and the load average (1 minute)
before and after.

  python3 bench/granular_bench.py [--build build] [--nx 20] [--nz 25] [--steps 1000] [--repeat 1]
python3 standard library only. A benchmark: it prints numbers and asserts nothing.
"""
import os
import re
import resource
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchlib  # noqa: E402

SCRIPT = """units           si
atom_style      sphere
boundary        p p fm
atom_modify     map array sort 1000 0.002
comm_modify     vel yes
region          box block 0 {L:.9g} 0 {L:.9g} 0 {H:.9g} units box
create_box      1 box
neighbor        0.001 bin
neigh_modify    delay 0 every 1 check yes
lattice         sc {a} origin 0.5 0.5 0.5
region          ins block 0 {L:.9g} 0 {L:.9g} 0 {Hins:.9g} units box
create_atoms    1 region ins
set             type 1 diameter 0.005
set             type 1 density 2500
variable        vx atom {v}*sin(12.9898*id)
variable        vy atom {v}*sin(78.233*id)
variable        vz atom {v}*sin(37.719*id)
velocity        all set v_vx v_vy v_vz
pair_style      {style}
pair_coeff      * * {coeff}
fix             1 all nve/sphere
fix             g all gravity 9.81 vector 0 0 -1
fix             w all wall/gran hertz/history 2e7 NULL 5e3 NULL 0.5 1 zplane 0.0 NULL
compute         c all contact/atom
compute         cs all reduce sum c_c
timestep        2e-6
thermo_style    custom step atoms ke c_cs
thermo          {steps}
run             {steps}
"""
SCENES = {"column": dict(a=0.004999, v=0.01), "gas": dict(a=0.0055, v=0.5)}
MODELS = {
    "mindlin": "hertz/material 5e6 0.5 0.45 tangential mindlin NULL 1.0 0.5",
    "roll_twist": "hertz/material 5e6 0.5 0.45 tangential mindlin NULL 1.0 0.5 rolling sds 1e-3 1e-6 0.2 "
                  "twisting marshall",
}


def loadavg():
    with open("/proc/loadavg") as f:
        return f.read().split()[0]


def run(lmp, text, wd):
    with open(os.path.join(wd, "in.bench"), "w") as f:
        f.write(text)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run([lmp, "-in", "in.bench", "-log", "none"], cwd=wd, env=env, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    out = p.stdout.decode(errors="replace")
    loop = re.search(r"Loop time of ([0-9.eE+-]+)", out)
    pair = re.search(r"^Pair\s+\|\s+([0-9.eE+-]+)", out, re.M)
    rows = [l.split() for l in out.splitlines() if re.match(r"\s+\d+\s+\d+\s+[0-9.eE+-]+\s+[0-9.eE+-]+\s*$", l)]
    if p.returncode or not loop or not pair:
        sys.exit("run failed in %s:\n%s" % (wd, out[-2000:]))
    return float(loop.group(1)), float(pair.group(1)), int(rows[-1][1]), float(rows[-1][3]) / 2, cpu


def main():
    ap = benchlib.parser(__doc__)
    ap.add_argument("--nx", type=int, default=20)
    ap.add_argument("--nz", type=int, default=25)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    lmp = os.path.abspath(os.path.join(args.build, "src_fix", "lmp_sphdem"))
    if not os.path.exists(lmp):
        sys.exit("no %s: build the project first" % lmp)
    print("load average (1 min) before: %s" % loadavg())
    print("%-7s %-10s %-13s %7s %9s %10s %9s %8s %8s" % ("scene", "model", "style", "grains", "contacts", "loop s",
                                                         "pair s", "pair %", "cpu s"))
    ratios = []
    for scene, sc in SCENES.items():
        a = sc["a"]
        L = args.nx * a
        text0 = dict(L=L, H=args.nz * a * 1.6 + 0.01, Hins=args.nz * a, a=a, v=sc["v"], steps=args.steps)
        for model, coeff in MODELS.items():
            res = {}
            for style in ("granular", "granular/gpu"):
                best = None
                for _ in range(args.repeat):
                    with tempfile.TemporaryDirectory() as wd:
                        r = run(lmp, SCRIPT.format(style=style, coeff=coeff, **text0), wd)
                    best = r if best is None or r[0] < best[0] else best
                res[style] = best
                loop, pair, n, nc, cpu = best
                print("%-7s %-10s %-13s %7d %9.0f %10.3f %9.3f %7.1f%% %8.2f" % (scene, model, style, n, nc, loop, pair,
                                                                               100 * pair / loop, cpu))
            s, g = res["granular"], res["granular/gpu"]
            ratios.append((scene, model, g[0] / s[0], g[1] / s[1], g[4] / s[4]))
    print("load average (1 min) after: %s" % loadavg())
    print("granular/gpu (CPU backend, 1 core) / stock granular:")
    for scene, model, rl, rp, rc in ratios:
        print("  %-7s %-10s loop time x%.2f, pair time x%.2f, process CPU time x%.2f" % (scene, model, rl, rp, rc))


if __name__ == "__main__":
    main()
