#!/usr/bin/env python3
"""test_dem_statistics.py - long-run statistics of the /gpu DEM pair styles against the stock run-to-run spread.

Granular flow is chaotic: a change in the order of a sum (or a 1e-15 displacement of the grains) grows until
two runs of the same scene share only their statistics. This test runs each scene seven times in the same
launcher, all split into 'run N1', an optional displacement, 'run N2':
  S0  the stock style
  S1  the stock style, every grain displaced at random by up to 1e-15 of the grain diameter after N1 steps
  S2 .. S4  the same with other seeds
  G   the /gpu style (LAMMPS gran/hertz/history/gpu, LIGGGHTS gran/gpu), the stock arguments
  C   a control: the stock style with the friction coefficient 0.5 -> 0.3 (a different physics)
From dumps every K steps it computes per frame the grain count, the mean height, the packing fraction of the
bed (grain volume / (floor area x 95th percentile of z + r above the floor)), the grain-grain contacts
(overlapping pairs) and the translational kinetic energy; hoppers also the grains discharged below the outlet.
Each statistic is averaged over the frames of the second half of the run (the discharge: the mean count
discharged over the frames, i.e. the area under the discharge curve). The spread of a statistic is
max over i of |Si - S0| (i = 1..4); the /gpu run passes when |G - S0| <= 2 x spread + floor (floor: 1e-6 of |S0|, and
half a contact or grain for counts) for every statistic. The control must fail that bound for at least one
statistic, so the comparison can tell a different physics from chaos. The final positions of S1 against S0
(the largest displacement, in d) show whether the runs have decorrelated.

Scenes, the kinds of the LIGGGHTS tutorials and LAMMPS granular examples (written here):
  lammps   pour    LAMMPS examples/granular/in.pour: fix pour of 1000 grains (lj units) onto a wall/gran floor
           funnel  ~600 grains in a conical hopper of fix wall/gran/region (region cone, both ends open, outlet
                   6 d), discharging onto a floor 0.1 m below
           pack    ~1000 grains of a bcc lattice settling into a dense bed (periodic x y)
           shake   the same bed on a floor moving up and down (fix wall/gran ... wiggle z, 3 g)
  liggghts pour    fix insert/pack of frictional Hertz grains onto a wall/gran floor (periodic x y)
           mesh    insert/pack onto an STL floor (fix mesh/surface + wall/gran mesh), rolling friction cdt,
                   fix check/timestep/gran
           hopper  insert/pack into an STL conical hopper (24 facets per ring), discharging onto a floor
           shake   the mesh floor moved up and down by fix move/mesh wiggle (a moving mesh), 3 g

  lammps EXE      the LAMMPS scenes (short runs), through lmp_sphdem
  liggghts EXE    the LIGGGHTS scenes (short runs), through liggghts_sphdem
bench/dem_statistics.py runs the same scenes longer and larger.
Python 3 only; exits 0 on pass, 1 on failure.
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_test as E  # noqa: E402  (the run helper)

# ------------------------------------------------------------------------------------------------ scenes
# Every script has {style} {coeff} (the pair style and its arguments; LIGGGHTS: the model words), {mu} (the
# friction coefficient), {n1} {n2} (the two runs), {perturb} (a displace_atoms line or nothing), {every} (the
# dump interval) and {size} (a scene's size parameter). The dump is 'id x y z vx vy vz radius mass'.
DUMP_LMP = ("dump            d all custom {every} dump.*.txt id x y z vx vy vz radius mass\n"
            "dump_modify     d sort id format float %.10g\n")
DUMP_LIG = ("dump            d all custom {every} dump.*.txt id x y z vx vy vz radius mass\n"
            "dump_modify     d sort id\n")
SPLIT = "run             {n1}\n{perturb}\nrun             {n2}\n"

# LAMMPS examples/granular/in.pour (lj units, d = 1)
POUR_LMP = """units           lj
atom_style      sphere
boundary        p p fm
newton          off
comm_modify     vel yes
region          reg block -10 10 -10 10 -0.5 16 units box
create_box      1 reg
neighbor        0.2 bin
neigh_modify    delay 0
pair_style      {style} 2000.0 NULL 50.0 NULL {mu} 0
pair_coeff      * *
timestep        0.001
fix             1 all nve/sphere
fix             2 all gravity 1.0 spherical 0.0 -180.0
fix             zlower all wall/gran hertz/history 2000.0 NULL 50.0 NULL {mu} 0 zplane 0.0 2000.0
region          slab block -9.0 9.0 -9.0 9.0 10.0 15.0
fix             ins all pour {size} 1 300719 vol 0.13 50 region slab
thermo_style    custom step atoms ke
thermo_modify   lost ignore norm no
thermo          5000
""" + DUMP_LMP + SPLIT

# SI scenes: d = 5 mm, 2500 kg/m^3, Hertz 2e7 NULL 5e3 NULL mu 1, dt 2e-6 s
SI_LMP_HEAD = """units           si
atom_style      sphere
newton          off
atom_modify     map array sort 1000 0.002
comm_modify     vel yes
"""
SI_LMP_TAIL = """set             type 1 diameter 0.005
set             type 1 density 2500
velocity        all create 1e-4 4928 dist gaussian
pair_style      {style} 2e7 NULL 5e3 NULL {mu} 1
pair_coeff      * *
neighbor        0.001 bin
neigh_modify    delay 0 every 1 check yes
fix             g all gravity 9.81 vector 0 0 -1
fix             integrate all nve/sphere
timestep        2e-6
thermo_style    custom step atoms ke
thermo          5000
""" + DUMP_LMP + SPLIT

# a conical hopper (half angle 26.6 deg, outlet 6 d) of fix wall/gran/region, both ends open, filled with a bcc
# lattice, discharging onto a floor 0.1 m below
FUNNEL_LMP = SI_LMP_HEAD + """boundary        f f f
region          box block -0.05 0.05 -0.05 0.05 -0.11 0.08 units box
create_box      1 box
region          hop cone z 0 0 0.015 0.045 0 0.06 side in units box open 1 open 2
region          hopin cone z 0 0 0.0132 0.0402 0.003 0.057 side in units box
region          fill block -0.05 0.05 -0.05 0.05 0.003 {size} units box
region          ins intersect 2 hopin fill
lattice         bcc 0.006
create_atoms    1 region ins
fix             hopw all wall/gran/region hertz/history 2e7 NULL 5e3 NULL {mu} 1 region hop
fix             floor all wall/gran hertz/history 2e7 NULL 5e3 NULL {mu} 1 zplane -0.1 NULL
""" + SI_LMP_TAIL

PACK_LMP = SI_LMP_HEAD + """boundary        p p f
region          box block 0 0.06 0 0.06 0 0.1 units box
create_box      1 box
lattice         bcc 0.006
region          ins block 0.001 0.059 0.001 0.059 0.003 {size} units box
create_atoms    1 region ins
fix             floor all wall/gran hertz/history 2e7 NULL 5e3 NULL {mu} 1 zplane 0 NULL {wiggle}
""" + SI_LMP_TAIL

# LIGGGHTS: d = 2 mm (pour, mesh, shake) or 4 mm (hopper), 2500 kg/m^3, E = 5 MPa, nu 0.45, e 0.7, dt 5e-6 s
LIG_HEAD = """units           si
atom_style      granular
boundary        {boundary}
newton          off
communicate     single vel yes
region          box block {box} units box
create_box      1 box
neighbor        0.0005 bin
neigh_modify    delay 0
fix             m1 all property/global youngsModulus peratomtype 5e6
fix             m2 all property/global poissonsRatio peratomtype 0.45
fix             m3 all property/global coefficientRestitution peratomtypepair 1 0.7
fix             m4 all property/global coefficientFriction peratomtypepair 1 {mu}
fix             m5 all property/global coefficientRollingFriction peratomtypepair 1 0.02
pair_style      {style} {coeff}
pair_coeff      * *
"""
LIG_TAIL = """fix             g all gravity 9.81 vector 0 0 -1
fix             pts all particletemplate/sphere 15485863 atom_type 1 density constant 2500 radius constant {r}
fix             pdd all particledistribution/discrete 32452843 1 pts 1.0
fix             ins all insert/pack seed 49979687 distributiontemplate pdd insert_every once overlapcheck yes &
                vel constant 0.3 -0.2 -1.0 particles_in_region {size} region ins
fix             integrate all nve/sphere
timestep        5e-6
thermo_style    custom step atoms ke
thermo          5000
""" + DUMP_LIG + SPLIT
POUR_LIG = LIG_HEAD + """fix             floor all wall/gran {coeff} primitive type 1 zplane 0.0
region          ins block 0.0 0.03 0.0 0.03 0.0012 0.05 units box
""" + LIG_TAIL
MESH_LIG = LIG_HEAD + """fix             cad all mesh/surface file floor.stl type 1
fix             floor all wall/gran {coeff} mesh n_meshes 1 meshes cad
{wiggle}region          ins block 0.002 0.028 0.002 0.028 0.0012 0.03 units box
""" + LIG_TAIL.replace("fix             integrate all nve/sphere\n",
                       "fix             integrate all nve/sphere\nfix             ts all check/timestep/gran 5000 0.2 0.2\n")
HOPPER_LIG = LIG_HEAD + """fix             cad all mesh/surface file hopper.stl type 1
fix             hopw all wall/gran {coeff} mesh n_meshes 1 meshes cad
fix             floor all wall/gran {coeff} primitive type 1 zplane -0.1
region          ins cylinder z 0 0 0.04 0.035 0.075 units box
""" + LIG_TAIL

FLOOR_STL = """solid floor
 facet normal 0 0 1
  outer loop
   vertex 0 0 0
   vertex 0.03 0 0
   vertex 0.03 0.03 0
  endloop
 endfacet
 facet normal 0 0 1
  outer loop
   vertex 0 0 0
   vertex 0.03 0.03 0
   vertex 0 0.03 0
  endloop
 endfacet
endsolid floor
"""


def hopper_stl(nseg=24, rings=((0.0, 0.015), (0.03, 0.045), (0.08, 0.045))):
    """an STL of a conical hopper with a cylinder on top: rings (z, r), nseg facets around, two triangles each"""
    out = ["solid hopper"]
    for (z0, r0), (z1, r1) in zip(rings, rings[1:]):
        for k in range(nseg):
            a, b = 2 * math.pi * k / nseg, 2 * math.pi * (k + 1) / nseg
            p = [(r0 * math.cos(a), r0 * math.sin(a), z0), (r0 * math.cos(b), r0 * math.sin(b), z0),
                 (r1 * math.cos(b), r1 * math.sin(b), z1), (r1 * math.cos(a), r1 * math.sin(a), z1)]
            for tri in ((p[0], p[1], p[2]), (p[0], p[2], p[3])):
                out += [" facet normal 0 0 0", "  outer loop"] + ["   vertex %.9g %.9g %.9g" % v for v in tri] + \
                       ["  endloop", " endfacet"]
    return "\n".join(out + ["endsolid hopper", ""])


WIGGLE_LMP = "wiggle z 0.001 0.0365"            # a = A (2 pi / T)^2 = 29.6 m/s^2 = 3.0 g
WIGGLE_LIG = "fix             shake all move/mesh mesh cad wiggle amplitude 0 0 0.001 period 0.0365\n"

# name -> the scene: script, d, floor (z of the floor and its area, for the packing fraction), outlet (z below
# which a grain is discharged) or None, the stock and /gpu style words and the arguments of the script
LMP_STYLES = (("gran/hertz/history", ""), ("gran/hertz/history/gpu", ""))
LIG_COEFF = "model hertz tangential history rolling_friction cdt"
LIG_STYLES = (("gran", LIG_COEFF), ("gran/gpu", LIG_COEFF))
SCENES = {
    "lammps": {
        "pour": dict(text=POUR_LMP, d=1.0, floor=(0.0, 400.0), outlet=None, styles=LMP_STYLES),
        "funnel": dict(text=FUNNEL_LMP, d=0.005, floor=None, outlet=0.0, styles=LMP_STYLES),
        "pack": dict(text=PACK_LMP, d=0.005, floor=(0.0, 0.0036), outlet=None, styles=LMP_STYLES,
                     fmt=dict(wiggle="")),
        "shake": dict(text=PACK_LMP, d=0.005, floor=None, outlet=None, styles=LMP_STYLES,
                      fmt=dict(wiggle=WIGGLE_LMP)),
    },
    "liggghts": {
        "pour": dict(text=POUR_LIG, d=0.002, floor=(0.0, 0.0009), outlet=None, styles=LIG_STYLES,
                     fmt=dict(boundary="p p f", box="0 0.03 0 0.03 0 0.06", r=0.001)),
        "mesh": dict(text=MESH_LIG, d=0.002, floor=(0.0, 0.0009), outlet=None, styles=LIG_STYLES,
                     files={"floor.stl": FLOOR_STL},
                     fmt=dict(boundary="f f f", box="-0.005 0.035 -0.005 0.035 -0.02 0.04", r=0.001, wiggle="")),
        "hopper": dict(text=HOPPER_LIG, d=0.004, floor=None, outlet=0.0, styles=LIG_STYLES,
                       files={"hopper.stl": hopper_stl()},
                       fmt=dict(boundary="f f f", box="-0.05 0.05 -0.05 0.05 -0.11 0.09", r=0.002)),
        "shake": dict(text=MESH_LIG, d=0.002, floor=None, outlet=None, styles=LIG_STYLES,
                      files={"floor.stl": FLOOR_STL},
                      fmt=dict(boundary="f f f", box="-0.005 0.035 -0.005 0.035 -0.02 0.04", r=0.001,
                               wiggle=WIGGLE_LIG)),
    },
}
# the short runs of ctest: scene -> (size, n1, n2, every)
SHORT = {
    "lammps": {"pour": (400, 1000, 19000, 1000), "funnel": (0.04, 200, 59800, 3000), "pack": (0.033, 200, 59800, 3000), "shake": (0.02, 200, 59800, 3000)},
    "liggghts": {"pour": (1500, 200, 7800, 400), "mesh": (800, 200, 7800, 400),
                 "hopper": (600, 200, 15800, 800), "shake": (600, 200, 11800, 600)},
}
SEEDS = (86028121, 104729, 15485867, 49979693)  # primes above 10000 (LIGGGHTS asks for them)
PERTURBED = ("S1", "S2", "S3", "S4")
RUNS = ("S0",) + PERTURBED + ("G", "C")


def script(engine, name, run, size, n1, n2, every):
    """the input text of run (one of RUNS) of a scene"""
    sc = SCENES[engine][name]
    (stock, coeff), (gpu, _) = sc["styles"]
    style = gpu if run == "G" else stock
    perturb = ""
    if run in PERTURBED:
        eps = 1e-15 * sc["d"]
        perturb = "displace_atoms  all random %.3g %.3g %.3g %d units box" % (eps, eps, eps, SEEDS[PERTURBED.index(run)])
    fmt = dict(style=style, coeff=coeff, mu="0.3" if run == "C" else "0.5", n1=n1, n2=n2, perturb=perturb,
               every=every, size=size)
    fmt.update(sc.get("fmt", {}))
    return sc["text"].format(**fmt)


# ------------------------------------------------------------------------------------------------ statistics
def read_frames(wd):
    """[(step, rows)] of the dump files dump.STEP.txt in wd, rows [id x y z vx vy vz radius mass] by id"""
    frames = []
    for f in os.listdir(wd):
        if f.startswith("dump.") and f.endswith(".txt"):
            lines = open(os.path.join(wd, f)).read().splitlines()
            i = next(k for k, l in enumerate(lines) if l.startswith("ITEM: ATOMS")) + 1
            rows = sorted([float(v) for v in l.split()] for l in lines[i:] if l.strip())
            frames.append((int(f.split(".")[1]), rows))
    return sorted(frames)


def contacts(rows):
    """grain-grain pairs that overlap (cell list of the largest diameter)"""
    if not rows:
        return 0
    h = 2 * max(r[7] for r in rows)
    cells = {}
    for k, r in enumerate(rows):
        cells.setdefault((int(math.floor(r[1] / h)), int(math.floor(r[2] / h)), int(math.floor(r[3] / h))), []).append(k)
    n = 0
    for (cx, cy, cz), ks in cells.items():
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    other = cells.get((cx + dx, cy + dy, cz + dz))
                    if not other:
                        continue
                    for i in ks:
                        a = rows[i]
                        for j in other:
                            if j <= i:
                                continue
                            b = rows[j]
                            d2 = (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2 + (a[3] - b[3]) ** 2
                            if d2 < (a[7] + b[7]) ** 2:
                                n += 1
    return n


def frame_stats(sc, rows):
    """the statistics of one frame: dict name -> value"""
    n = len(rows)
    st = {"grains": n, "contacts": contacts(rows),
          "KE": sum(0.5 * r[8] * (r[4] ** 2 + r[5] ** 2 + r[6] ** 2) for r in rows)}
    if n:
        st["mean height"] = sum(r[3] for r in rows) / n
    if sc["floor"] and n:
        z0, area = sc["floor"]
        z = sorted(r[3] + r[7] for r in rows)
        h95 = z[int(0.95 * (n - 1))] - z0
        st["packing fraction"] = sum(4.0 / 3.0 * math.pi * r[7] ** 3 for r in rows) / (area * h95)
    if sc["outlet"] is not None:
        st["discharged"] = sum(1 for r in rows if r[3] < sc["outlet"])
    return st


def run_stats(sc, frames):
    """each statistic averaged over the frames of the second half of the run"""
    late = [f for f in frames if f[0] >= frames[-1][0] / 2]
    per = [frame_stats(sc, rows) for _, rows in late]
    keys = [k for k in per[-1] if all(k in p for p in per)]
    return {k: sum(p[k] for p in per) / len(per) for k in keys}


def max_shift(a, b):
    """the largest |x_a - x_b| over the grains of two frames that share an id"""
    bb = {r[0]: r for r in b}
    return max([max(abs(r[c] - bb[r[0]][c]) for c in (1, 2, 3)) for r in a if r[0] in bb] or [0.0])


def compare(engine, name, results, frames):
    """print the table of one scene and return (pass, control detected)"""
    sc = SCENES[engine][name]
    s0 = results["S0"]
    ok, control_out = True, []
    shift = max_shift(frames["S0"][-1][1], frames["S1"][-1][1]) / sc["d"]
    gshift = max_shift(frames["S0"][-1][1], frames["G"][-1][1]) / sc["d"]
    print("  %s %s: final positions S1 vs S0 differ by up to %.3g d, G vs S0 by %.3g d (%d frames, %d grains)" %
          (engine, name, shift, gshift, len(frames["S0"]), len(frames["S0"][-1][1])))
    print("    %-17s %14s %14s %14s %14s %14s  %s" % ("statistic", "S0 stock", "spread", "|G - S0|", "|C - S0|",
                                                  "bound", "/gpu"))
    for k in s0:
        spread = max(abs(results[r][k] - s0[k]) for r in PERTURBED)
        floor = 1e-6 * abs(s0[k]) + (0.5 if k in ("grains", "contacts", "discharged") else 0.0)
        bound = 2 * spread + floor
        dg, dc = abs(results["G"][k] - s0[k]), abs(results["C"][k] - s0[k])
        good = dg <= bound
        ok &= good
        if dc > bound:
            control_out.append(k)
        print("    %-17s %14.6g %14.3g %14.3g %14.3g %14.3g  %s" % (k, s0[k], spread, dg, dc, bound,
                                                                  "within" if good else "OUTSIDE"))
    print("    control (friction 0.3) outside the bound in: %s" % (", ".join(control_out) or "nothing"))
    return ok, bool(control_out), shift


def scene_runs(exe, engine, name, params, root, timeout=600):
    """run the seven runs of a scene; return (stats per run, frames per run) or None on a failed run"""
    sc = SCENES[engine][name]
    results, frames = {}, {}
    for run in RUNS:
        wd = os.path.join(root, engine, name, run)
        os.makedirs(wd, exist_ok=True)
        for f in os.listdir(wd):
            if f.startswith("dump."):
                os.remove(os.path.join(wd, f))
        for fname, text in sc.get("files", {}).items():
            with open(os.path.join(wd, fname), "w") as f:
                f.write(text)
        rc, out = E.run([exe], wd, script(engine, name, run, *params), timeout=timeout)
        if rc != 0 or "ERROR" in out:
            print("FAIL %s %s run %s: rc %d\n%s" % (engine, name, run, rc, out[-1500:]))
            return None
        frames[run] = read_frames(wd)
        results[run] = run_stats(sc, frames[run])
    return results, frames


def check(exe, engine, table=None, root="dem_statistics"):
    ok = True
    table = table or SHORT[engine]
    for name, params in table.items():
        got = scene_runs(exe, engine, name, params, root)
        if got is None:
            ok = False
            continue
        good, control, shift = compare(engine, name, *got)
        print("%s %s %s: every statistic of /gpu within twice the stock run-to-run spread: %s; the control run "
              "outside it: %s" % ("PASS" if good and control else "FAIL", engine, name, good, control))
        ok &= good and control
    return ok


def lammps(exe):
    return check(exe, "lammps")


def liggghts(exe):
    return check(exe, "liggghts")


if __name__ == "__main__":
    sys.exit(E.dispatch(sys.argv, {"lammps": lammps, "liggghts": liggghts}, __doc__, prefix=""))
