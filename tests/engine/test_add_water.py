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
        wd = tempfile.mkdtemp(prefix="add_water_%s_%s_" % (engine, kind))
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


if __name__ == "__main__":
    fn = globals().get("test_" + sys.argv[1]) if len(sys.argv) > 1 else None
    if not callable(fn):
        print(__doc__)
        sys.exit(2)
    sys.exit(fn(*sys.argv[2:2 + fn.__code__.co_argcount]))
