#!/usr/bin/env python3
"""test_add_water.py - examples/add_water: a plain DEM script and the same script with water added.

  lines EXAMPLE_DIR            the water scripts change at most 3 lines of in.dem (LIGGGHTS) and 4 of in.dem.lmp
                               (LAMMPS) and otherwise only add lines: every line of the plain script that is not
                               in the water script is counted (comments and blank lines aside)
  entry EXE ENGINE EXAMPLE_DIR the plain and the water script for 5000 DEM steps (0.1 s: the grains reach the water
                               and enter it) through the sphdem launcher: both complete without ERROR, all 1500
                               grains are in the box, the fluid count in the last water dump is what fix sph/fill
                               created, no fluid particle is more than dx/2 outside the box's walls, and the water
                               slows the grains: their mean height at 0.1 s is at least 5 mm above the dry run's
                               (measured: LIGGGHTS 49 vs 7 mm, LAMMPS 39 vs 26 mm)
  ranks EXE ENGINE MPIRUN EXAMPLE_DIR  the water script for RANK_STEPS DEM steps (the grains reach the water near
                               step 1500) at 2 ranks (processors 1 1 2: the cut is horizontal, through the water
                               and the falling grains) and 4 (2 2 1: vertical cuts through the box) against 1 rank:
                               every atom's x, v (matched by its position at step 0; the grains that fix pour adds
                               later by ID) within RANK_BOUND relative (round-off of the other order of the sums,
                               grown over the steps; grains in contact are chaotic), grains within reach of the
                               water at the end. LAMMPS' fix pour draws the same grains at any rank count; LIGGGHTS' fix
                               insert/pack draws them per subdomain (so does stock LIGGGHTS), so for LIGGGHTS the
                               insertion is replaced by the same count of grains on a lattice in the same region
                               (create_atoms), the rest of the script unchanged. LIGGGHTS: the grains touch each
                               other from step ~1450, with `tangential history` (a pair that separated keeps its
                               tangential displacement until the next neighbour build: the runs agree only when the
                               engine reneighbours on the same steps at any rank count; fix sph/fluid asks for the
                               builds the fluid's motion needs on one rank and on many alike)

Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

NSTEPS = 5000
NGRAINS = 1500
BOX = 0.03      # inner half-width of the box (x, y)
DX = 0.005      # the water scripts' spacing


def script_lines(path):
    """the command lines of a script: comments stripped, continuation lines joined, blank lines dropped"""
    out, cur = [], ""
    for raw in open(path):
        line = raw.split("#", 1)[0].rstrip()
        if line.endswith("&"):
            cur += line[:-1] + " "
            continue
        line = " ".join((cur + line).split())
        cur = ""
        if line:
            out.append(line)
    return out


def test_lines(exdir):
    fails = 0
    for plain, wet, limit in (("in.dem", "in.dem_water", 3), ("in.dem.lmp", "in.dem_water.lmp", 4)):
        a = script_lines(os.path.join(exdir, plain))
        b = script_lines(os.path.join(exdir, wet))
        rest = list(b)
        changed = []
        for line in a:
            if line in rest:
                rest.remove(line)
            else:
                changed.append(line)
        ok = len(changed) <= limit and len(b) > len(a)
        print("%s %s -> %s: %d lines changed (limit %d), %d new lines%s" %
              ("PASS" if ok else "FAIL", plain, wet, len(changed), limit, len(b) - len(a) + len(changed),
               "".join("\n    changed: " + c for c in changed)))
        fails += not ok
    return 0 if fails == 0 else 1


def run(exe, wd, script, exdir):
    shutil.copy(os.path.join(exdir, "box.stl"), wd)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.run([exe, "-in", os.path.join(exdir, script), "-var", "nsteps", str(NSTEPS), "-log", "log.run"],
                       cwd=wd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=840)
    return p.returncode, p.stdout.decode(errors="replace")


def read_dump(path):
    lines = open(path).read().split("\n")
    k = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    cols = lines[k].split()[2:]
    return [dict(zip(cols, map(float, l.split()))) for l in lines[k + 1:] if l.strip()]


def mean_z(rows):
    return sum(r["z"] for r in rows) / len(rows) if rows else float("nan")


def test_entry(exe, engine, exdir):
    suffix = "" if engine == "liggghts" else ".lmp"
    fails = []
    res = {}
    for kind, script in (("dry", "in.dem" + suffix), ("wet", "in.dem_water" + suffix)):
        wd = os.path.abspath(tempfile.mkdtemp(prefix="add_water_%s_%s_" % (engine, kind), dir="."))  # in the build tree
        rc, out = run(exe, wd, script, exdir)
        if rc != 0 or "ERROR" in out:
            print("FAIL %s %s exited %d:\n%s" % (engine, script, rc, out[-2500:]))
            return 1
        grains = read_dump(os.path.join(wd, "dump.grains.%d" % NSTEPS))
        if kind == "wet":
            ids = {r["id"] for r in read_dump(os.path.join(wd, "dump.water.%d" % NSTEPS))}
            grains = [r for r in grains if r["id"] not in ids and r["radius"] < 0.002]
            m = re.search(r"sph/fill fill: created (\d+) atoms", out)
            water = read_dump(os.path.join(wd, "dump.water.%d" % NSTEPS))
            nfill = int(m.group(1)) if m else -1
            out_w = [r for r in water if max(abs(r["x"]), abs(r["y"])) > BOX + 0.5 * DX or r["z"] < -0.5 * DX]
            print("%s %s: %d fluid particles in the last water dump, %d created by fix sph/fill; %d more than dx/2 "
                  "outside the walls" % ("PASS" if len(water) == nfill and not out_w else "FAIL", engine, len(water),
                                         nfill, len(out_w)))
            if len(water) != nfill or out_w:
                fails.append("water")
        inbox = [r for r in grains if max(abs(r["x"]), abs(r["y"])) <= BOX and r["z"] >= 0]
        ok = len(grains) == NGRAINS and len(inbox) == NGRAINS
        print("%s %s %s: %d grains, %d inside the box" % ("PASS" if ok else "FAIL", engine, kind, len(grains),
                                                         len(inbox)))
        if not ok:
            fails.append(kind + " grains")
        res[kind] = mean_z(grains)
    ok = res["wet"] >= res["dry"] + 0.005
    print("%s %s: mean grain height at %g s: water %.1f mm, dry %.1f mm (the water must hold them >= 5 mm higher)"
          % ("PASS" if ok else "FAIL", engine, NSTEPS * 2e-5, 1e3 * res["wet"], 1e3 * res["dry"]))
    if not ok:
        fails.append("slowing")
    return 0 if not fails else 1


RANK_STEPS = 2000
RANK_BOUND = 1e-9
LATTICE_GRAINS = """lattice         sc 0.0036 origin 0.5 0.5 0.5
create_atoms    1 region bc units box
set             type 1 diameter 0.003 density 2500
group           nve_group type 1
velocity        nve_group set 0 0 -0.3 units box
"""


def ranks_script(engine, exdir, steps=RANK_STEPS, no_history=False):
    """the water script with a dump of every atom sorted by ID at steps (and, for LIGGGHTS, the grains on a lattice;
    no_history: the granular model with tangential no_history)"""
    text = open(os.path.join(exdir, "in.dem_water" + ("" if engine == "liggghts" else ".lmp"))).read()
    if engine == "liggghts":
        text, n = re.subn(r"(?m)^fix\s+ins\s.*&\n.*\n", LATTICE_GRAINS, text)
        if n != 1:
            raise RuntimeError("in.dem_water: the fix insert/pack command was not found")
        if no_history:
            text = text.replace("tangential history", "tangential no_history")
    fmt = ("dump_modify m sort id format float %.17g" if engine == "lammps" else
           'dump_modify m sort id format "%d %d' + " %.17g" * 7 + '"')
    dump = "dump m all custom %d ranks.*.txt id type x y z vx vy vz radius\n%s\n" % (steps, fmt)
    return re.sub(r"(?m)^run\s+\S+", dump + "run %d" % steps, text)


def test_ranks(exe, engine, mpirun, exdir):
    if engine == "lammps":
        return ranks_case(exe, engine, mpirun, exdir, ranks_script(engine, exdir), RANK_STEPS, "")
    return ranks_case(exe, engine, mpirun, exdir, ranks_script(engine, exdir), RANK_STEPS, " (tangential history)")


def ranks_case(exe, engine, mpirun, exdir, script, steps, label):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    res, fails = {}, 0
    for np_, grid in ((1, None), (2, "1 1 2"), (4, "2 2 1")):
        wd = os.path.abspath(tempfile.mkdtemp(prefix="add_water_ranks_%s_np%d_" % (engine, np_), dir="."))
        shutil.copy(os.path.join(exdir, "box.stl"), wd)
        sc = script if grid is None else re.sub(r"(?m)^(create_box.*)$", "processors %s\n\\1" % grid, script, count=1)
        with open(os.path.join(wd, "in.ranks"), "w") as f:
            f.write(sc)
        cmd = ([exe] if np_ == 1 else [mpirun, "-np", str(np_), "--oversubscribe", "--allow-run-as-root", exe])
        p = subprocess.run(cmd + ["-in", "in.ranks", "-log", "log.run"], cwd=wd, env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, timeout=600)
        out = p.stdout.decode(errors="replace")
        if p.returncode != 0 or "ERROR" in out:
            print("FAIL %s%s at %d ranks exited %d:\n%s" % (engine, label, np_, p.returncode, out[-2500:]))
            return 1
        if np_ > 1 and "%d MPI ranks (processors %s)" % (np_, grid) not in out:
            print("FAIL %s at %d ranks: the set-up line with the processors grid is missing" % (engine, np_))
            fails += 1
        # atoms present at step 0 (fluid, walls, LIGGGHTS' lattice grains: numbered by rank) by their position
        # there, the grains that fix pour adds later by their ID (the same at any rank count)
        first = {int(r["id"]): tuple(round(r[c] * 1e7) for c in ("x", "y", "z"))
                 for r in read_dump(os.path.join(wd, "ranks.0.txt"))}
        res[np_] = {first.get(int(r["id"]), ("id", int(r["id"]))): r
                    for r in read_dump(os.path.join(wd, "ranks.%d.txt" % steps))}
    ref = res[1]
    grains = [r for r in ref.values() if r["radius"] < 0.002]  # the grains' radius 1.5 mm, the fluid's dx / 2
    wet = [r for r in grains if r["z"] < 0.063]  # coupled: the water within their kernel support
    ok = len(wet) > 0
    print("%s %s%s: %d of %d grains within 2 hc = 13 mm of the water surface (z < 63 mm) after %d steps" %
          ("PASS" if ok else "FAIL", engine, label, len(wet), len(grains), steps))
    fails += not ok
    vmax = max(abs(r[c]) for r in ref.values() for c in ("vx", "vy", "vz")) or 1.0
    for np_ in (2, 4):
        if set(res[np_]) != set(ref):
            print("FAIL %s%s at %d ranks: %d atoms against %d at 1 rank (or other IDs)" % (engine, label, np_,
                                                                                              len(res[np_]), len(ref)))
            fails += 1
            continue
        worst, col = 0.0, ""
        for c in ("x", "y", "z", "vx", "vy", "vz"):
            scale = vmax if c.startswith("v") else max(abs(r[c]) for r in ref.values())
            d = max(abs(ref[t][c] - res[np_][t][c]) for t in ref) / scale
            if d > worst:
                worst, col = d, c
        ok = worst < RANK_BOUND
        print("%s %s%s at %d ranks, step %d: %d atoms, max relative difference %.3e in %s (bound %.0e)" %
              ("PASS" if ok else "FAIL", engine, label, np_, steps, len(ref), worst, col, RANK_BOUND))
        fails += not ok
    return 0 if not fails else 1


if __name__ == "__main__":
    fn = globals().get("test_" + sys.argv[1]) if len(sys.argv) > 1 else None
    if not callable(fn):
        print(__doc__)
        sys.exit(2)
    sys.exit(fn(*sys.argv[2:2 + fn.__code__.co_argcount]))
