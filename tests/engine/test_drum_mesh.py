#!/usr/bin/env python3
"""test_drum_mesh.py - examples/drum_mesh/in.dem_water (the He 2018 rotating drum with an STL mesh wall, water
added by fix sph/wall, fix sph/fill, fix sph/fluid and fix sph/couple) and its LAMMPS syntax in.dem_water.lmp (a
region drum), shortened:

  water EXE EXAMPLE_DIR   a short settling and a few hundred steps of rotation: the run completes without ERROR,
                          every grain stays inside the drum (r <= R, 0 <= y <= L, the grain radius inside the
                          wall to 1 % of it), the fluid count in the last fluid dump is the count fix sph/fill
                          printed, no fluid particle left the drum, the wall particles lie outside the mesh
                          (r >= R or beyond the end caps), and the wall particles turned with the drum: each one
                          keeps its distance from the axis and its y, and has turned by the drum's angle
                          (liggghts_sphdem)
  ranks EXE ENGINE MPIRUN EXAMPLE_DIR
                          the example at processors 2 1 1 (a vertical cut through the axis), 1 1 2 (horizontal,
                          through the axis, the bed and the water surface) and 2 1 2 against one rank: NSETTLE_R
                          steps of settling (the lattice bed falls onto the wall and onto itself: contacts between
                          grains of different ranks), then NROT_R steps of rotation with the water. Grains and fluid
                          at the end, matched by their positions at creation: max |difference| / (the largest
                          coordinate; velocities: the largest velocity component) < 1e-9 (test_fluid_mpi.BOUND: only the order of
                          floating-point sums differs between rank counts; the round-off of 1e-16 grows by the
                          contacts to 1e-13-1e-11 in these steps, as in the other rank tests). LAMMPS runs
                          in.dem_water.lmp as written (its grains: the lowest lattice sites by a key of their
                          position, the same at any rank count). LIGGGHTS' fix insert/pack draws positions per
                          subdomain (another bed on another rank count, as stock LIGGGHTS), so there the insertion
                          is replaced by the lattice block of in.dem_water.lmp; the mesh, its rotation, the water
                          and the coupling are the example's.

Python 3 only; exits 0 on pass, 1 on failure.
"""
import glob
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_test as et  # noqa: E402
from test_fluid_mpi import by_start, drum_ranks, dump_lines, write_start  # noqa: E402

R, L = 0.05, 0.1            # drum.stl: radius and length (y from 0 to L)
RPM = 104.0
DT = 1e-5
NSETTLE, NROT, NDUMP = 2000, 300, 100
NSETTLE_R, NROT_R = 3000, 199   # the run ends at step NROT_R + 1 of the rotation (after its one-step start)


def read_dump(path):
    with open(path) as f:
        lines = f.read().split("\n")
    step = int(lines[1])
    k = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    cols = lines[k].split()[2:]
    rows = [dict(zip(cols, map(float, l.split()))) for l in lines[k + 1:] if l.strip()]
    return step, rows


def last_dump(wd, what):
    files = glob.glob(os.path.join(wd, "dump.%s.*" % what))
    if not files:
        return None, []
    return read_dump(max(files, key=lambda f: int(f.rsplit(".", 1)[1])))


def first_dump(wd, what):
    files = glob.glob(os.path.join(wd, "dump.%s.*" % what))
    return read_dump(min(files, key=lambda f: int(f.rsplit(".", 1)[1])))


def test_water(exe, exdir):
    fails = []
    wd = os.path.abspath(tempfile.mkdtemp(prefix="drum_mesh_", dir="."))  # in the build tree, not /tmp
    shutil.copy(os.path.join(exdir, "drum.stl"), wd)
    cmd = [exe, "-in", os.path.join(exdir, "in.dem_water"), "-var", "nsettle", str(NSETTLE),
           "-var", "nrot", str(NROT), "-var", "ndump", str(NDUMP), "-log", "log.drum_mesh"]
    p = subprocess.run(cmd, cwd=wd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=540)
    out = p.stdout.decode(errors="replace")
    if p.returncode != 0 or "ERROR" in out:
        print(out[-3000:])
        print("FAIL: the run stopped (exit %d)" % p.returncode)
        return 1
    if "Loop time" not in out.split("rotation for")[-1]:
        fails.append("the rotation run did not reach its end")

    # the fluid count fix sph/fill printed
    m = re.findall(r"fix sph/fill \S+: created (\d+) atoms", out)
    if not m:
        print(out[-3000:])
        print("FAIL: no 'fix sph/fill ID: created N atoms' line in the output")
        return 1
    nfill = int(m[-1])

    step, grains = last_dump(wd, "grains")
    if step != NROT:
        fails.append("last grain dump at step %s, expected %d" % (step, NROT))
    if len(grains) != 969:
        fails.append("%d grains in the last dump, expected 969" % len(grains))
    worst = 0.0
    for g in grains:
        r = math.hypot(g["x"], g["z"])
        # how far the grain's surface passes the wall (mantle, end caps), relative to its radius
        over = max(r + g["radius"] - R, g["radius"] - g["y"], g["y"] + g["radius"] - L) / g["radius"]
        worst = max(worst, over)
    print("grains: %d, deepest reach into the wall %.3f of a grain radius" % (len(grains), worst))
    if worst > 0.01:   # Hertz overlaps here are ~1e-3 of the radius; a grain through the wall is > 1
        fails.append("a grain passes the drum wall by %.3f of its radius" % worst)

    fstep, fluid = last_dump(wd, "fluid")
    print("fluid: fix sph/fill printed %d, the last fluid dump (step %s) has %d" % (nfill, fstep, len(fluid)))
    if len(fluid) != nfill or nfill == 0:
        fails.append("fluid count %d in the dump, fix sph/fill printed %d" % (len(fluid), nfill))
    outside = [f for f in fluid if math.hypot(f["x"], f["z"]) > R or not (0.0 <= f["y"] <= L)]
    if outside:
        fails.append("%d fluid particles outside the drum" % len(outside))

    s0, w0 = first_dump(wd, "wall")
    s1, w1 = last_dump(wd, "wall")
    if not w1:
        fails.append("no wall dump")
    else:
        inside = [w for w in w1 if math.hypot(w["x"], w["z"]) < R - 1e-9 and 0.0 < w["y"] < L]
        if inside:
            fails.append("%d wall particles inside the drum" % len(inside))
        # the rotation of fix move rotate about +y by omega t: (x, z) -> (x cos + z sin, -x sin + z cos)
        om = 2 * math.pi * RPM / 60.0
        a = om * (s1 - s0) * DT
        by0 = {int(w["id"]): w for w in w0}
        err = 0.0
        for w in w1:
            q = by0[int(w["id"])]
            xr = q["x"] * math.cos(a) + q["z"] * math.sin(a)
            zr = -q["x"] * math.sin(a) + q["z"] * math.cos(a)
            err = max(err, math.hypot(w["x"] - xr, w["z"] - zr), abs(w["y"] - q["y"]))
        print("walls: %d particles, turned by %.4f rad between steps %d and %d, largest deviation %.2e m"
              % (len(w1), a, s0, s1, err))
        if err > 1e-6:   # dumps carry 6 significant digits
            fails.append("wall particles deviate from the drum's rotation by %.2e m" % err)

    for f in fails:
        print("FAIL:", f)
    if not fails:
        print("PASS")
        shutil.rmtree(wd, ignore_errors=True)
    return 1 if fails else 0


def lattice_block(exdir):
    """the grain lattice of in.dem_water.lmp: from its 'lattice' line to 'set group grains density', without the
    region fillreg (in.dem_water defines the same)"""
    with open(os.path.join(exdir, "in.dem_water.lmp")) as f:
        lmp = f.read()
    a = lmp.index("lattice       sc $(1.25*v_dg)")
    b = lmp.index("set           group grains density ${rhop}\n", a)
    block = lmp[a:b] + "set           group grains density ${rhop}\n"
    return re.sub(r"(?m)^region\s+fillreg\s.*\n", "", block)


def test_ranks(exe, engine, mpirun, exdir):
    name = "in.dem_water.lmp" if engine == "lammps" else "in.dem_water"
    with open(os.path.join(exdir, name)) as f:
        text = f.read()
    edits = [(r"(?m)^variable nsettle\s+index\s+\S+", "variable nsettle index %d" % NSETTLE_R),
             (r"(?m)^variable nrot\s+index\s+\S+", "variable nrot index %d" % NROT_R),
             (r"(?m)^dump\s.*$", "")]
    if engine == "liggghts":
        edits.append((r"(?m)^fix\s+ins\s+grains\s+insert/pack.*&\n.*\n", lattice_block(exdir)))
    start = ("set           group grains density ${rhop}\n" if engine == "lammps" else
             "set           group grains density ${rhop}\n")
    text = re.sub(r"(?m)^dump_modify\s.*$", "", text)
    for pat, rep in edits:
        text, n = re.subn(pat, rep.replace("\\", "\\\\"), text)
        if n == 0:
            print("FAIL: the example %s no longer has '%s' where the test changes it" % (name, pat))
            return 1
    if text.count(start) != 1 or "\nrun " not in text:
        print("FAIL: the example %s no longer sets the grain density once, or has no run" % name)
        return 1
    text = text.replace(start, start + write_start(engine, "grains", "startg.txt"))
    last = text.rfind("\nrun ")
    text = text[:last] + "\n" + write_start(engine, "fluid", "startf.txt") + "group moving union grains fluid\n" + \
        dump_lines(engine, "moving", NROT_R + 1, "x y z vx vy vz") + text[last:]
    wd = "drum_mesh_ranks_%s" % engine
    shutil.rmtree(wd, ignore_errors=True)
    names = ["x", "y", "z", "vx", "vy", "vz"]
    for sub in ("np1", "np2_211", "np2_112", "np4_212"):
        os.makedirs(os.path.join(wd, sub))
        shutil.copy(os.path.join(exdir, "drum.stl"), os.path.join(wd, sub))
    et.must_run([exe], wd + "/np1", text, timeout=400)
    step, ref, nstart = by_start(wd + "/np1", ("startg.txt", "startf.txt"))
    ng = len(et.read_dump(os.path.join(wd, "np1", "startg.txt")))
    vmax = max(abs(r[c]) for r in ref for c in (3, 4, 5))
    # grains stopped by the wall and the bed: free fall since the start would give vz = -g t to every grain
    tend = (NSETTLE_R + NROT_R + 1) * DT
    ids = sorted(et.read_dump(os.path.join(wd, "np1", "startg.txt")))
    now = et.read_dump(os.path.join(wd, "np1", "mpi.%d.txt" % step))
    slow = sum(1 for i in ids if now[i][5] > -0.5 * 9.81 * tend)
    print("grains falling slower than half the free fall (stopped by a contact): %d of %d" % (slow, len(ids)))
    contacts = slow > len(ids) // 10
    print("drum_mesh (%s) at 1 rank: %d grains, %d fluid, step %d, max |v| %.3g m/s" %
          (engine, ng, nstart - ng, step, vmax))
    if not (ng == 969 and nstart - ng > 1000 and vmax > 0.05 and len(ref) == nstart and contacts):
        print("FAIL drum_mesh: not 969 grains, too few fluid atoms, nothing moved or no grain stopped")
        return 1
    return 1 if drum_ranks(exe, engine, mpirun, wd, text, step, ref, nstart, names, timeout=400) else 0


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "ranks":
        sys.exit(test_ranks(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]))
    if len(sys.argv) < 4 or sys.argv[1] != "water":
        sys.exit(__doc__)
    sys.exit(test_water(sys.argv[2], sys.argv[3]))
