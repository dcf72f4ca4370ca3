#!/usr/bin/env python3
"""test_sph_create.py - engine tests of fix sph/wall and fix sph/fill (atom-creating fixes for the SPH fluid).

  tank    EXE ENGINE          3D still water: walls from an open-top STL box (sph/wall mesh) and fluid from sph/fill
                              against the same tank built by hand (lattice + create_atoms); compute sph/probe
                              pressure at z = H/4 and H/2 after 0.25 s: the two within 1 % of each other and each
                              within 5 % of rho0 g (H - z); the created atoms equal the hand-built ones (positions)
  tilted  EXE ENGINE          water in a box mesh tilted by 15 deg about y (fill: the intersection of plane regions):
                              after 0.3 s no fluid particle beyond the first wall layer, max speed < 0.1 sqrt(g H)
  drum    EXE ENGINE          a closed drum mesh (tools/stl_shapes.py cylinder, axis y, 32 facets), half filled from
                              a region cylinder at the facets' inner radius: after 0.3 s no fluid particle beyond the
                              first wall layer (dx/2 beyond the facets), max speed < 0.1 sqrt(g R)
  drum_inside EXE ENGINE      the same drum half filled from a block covering the lower half of the box, kept inside
                              the mesh by sph/fill ... inside (the far points outside the drum included); same bounds
  region2d EXE ENGINE         2D: walls from a region (sph/wall region) equal the lattice walls minus the corner
                              points farther than layers*dx from the region; fill's top printed and in f_ID
  badinput EXE ENGINE         missing file, unknown keyword (named with the allowed ones), spacing <= 0, layers < 1,
                              mesh in 2D, atom style without radius, mass and density together, no mesh/region
  movemesh EXE ENGINE        LIGGGHTS: a fix move/mesh turning the walls' mesh without a fix move on the wall group
                              gives the warning naming the group; with the fix move, none (LAMMPS: skipped)
  mpi     EXE ENGINE MPIEXEC  mesh walls, region walls and an excluding fill on 2 ranks: the same atoms (ID, type,
                              position, diameter, mass) as on 1 rank
Python 3 only; exits 0 on pass, 1 on failure.
"""
import math
import os
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tools"))
import engine_test as E  # noqa: E402  (the shared helpers)
import stl_shapes  # noqa: E402

G = 9.81
RHO0 = 1000.0


def read_atoms(path):
    """write_dump ... custom id type x y z radius mass: {id: (type, x, y, z, radius, mass)}"""
    with open(path) as f:
        lines = f.read().splitlines()
    start = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS")) + 1
    out = {}
    for l in lines[start:]:
        w = l.split()
        if w:
            out[int(w[0])] = tuple([int(w[1])] + [float(v) for v in w[2:]])
    return out


def probe_values(out_text, tag):
    """the numbers of the last line 'TAG v1 v2 ...' that an input script printed"""
    vals = None
    for l in out_text.splitlines():
        if l.startswith(tag + " "):
            try:
                vals = [float(v) for v in l.split()[1:]]
            except ValueError:
                pass
    return vals


# ------------------------------------------------------------------ tank: mesh walls + fill vs lattice by hand
DX = 0.005
TANK = dict(W=10, D=8, H=16, HT=22)  # in dx: water W x D x H, walls up to HT

TANK_HEAD = """units si
atom_style sphere
boundary f f f
atom_modify map array sort 0 0.0
variable dx equal {dx}
region box block -0.03 {bx} -0.03 {by} -0.03 {bz} units box
create_box 2 box
group fluid type 1
group walls type 2
"""


def tank_script(mode, steps, dump=None):
    dx = DX
    W, D, H, HT = (TANK[k] * dx for k in ("W", "D", "H", "HT"))
    t = 3 * dx
    s = TANK_HEAD.format(dx=dx, bx=W + 0.03, by=D + 0.03, bz=HT + 0.03)
    if mode == "hand":
        s += ("lattice sc %g origin 0.5 0.5 0.5\n" % dx +
              "region fl block 0 %.10g 0 %.10g 0 %.10g units box\n" % (W, D, H) +
              "region hole block 0 %.10g 0 %.10g 0 %.10g side out units box\n" % (W, D, HT + 1) +
              "region slab block -%.10g %.10g -%.10g %.10g -%.10g %.10g units box\n" % (t, W + t, t, D + t, t, HT) +
              "region wl intersect 2 slab hole units box\n"
              "create_atoms 2 region wl\ncreate_atoms 1 region fl\ngroup fluid type 1\ngroup walls type 2\n"
              "set type 1 diameter %.10g\nset type 2 diameter %.10g\n" % (dx, dx) +
              "set type 1 mass %.10g\nset type 2 mass %.10g\n" % (RHO0 * dx ** 3, RHO0 * dx ** 3) +
              "variable zs equal %.10g\n" % H)
    else:
        s += ("fix mkw walls sph/wall mesh tank.stl spacing %g layers 3 type 2 density %g\n" % (dx, RHO0) +
              "region fl block 0 %.10g 0 %.10g 0 %.10g units box\n" % (W, D, H) +
              "fix mkf fluid sph/fill region fl spacing %g type 1 density %g exclude walls\n" % (dx, RHO0) +
              "variable zs equal f_mkf\n")
    if dump:
        s += "write_dump all custom %s id type x y z radius mass modify sort id\n" % dump
    h = 1.5 * dx
    c0 = 10 * math.sqrt(G * H)
    dt = 0.2 * h / (1.2 * c0)
    s += ("timestep %.10g\npair_style none\nneighbor %g bin\nneigh_modify every 100 delay 0 check no\n" % (dt, dx) +
          "fix water fluid sph/fluid rho0 %g h %.10g c0 %.10g gravity 0 0 -%g visc artificial 0.05 wall walls "
          "hydrostatic ${zs}\n" % (RHO0, h, c0, G) +
          "compute probe all sph/probe water %.10g %.10g %.10g %.10g %.10g %.10g\n"
          % (W / 2, D / 2, H / 4, W / 2, D / 2, H / 2) +
          "thermo_style custom step c_probe[1][1] c_probe[2][1]\nthermo %d\n" % max(1, steps) +
          "run %d\n" % steps)
    return s, dt


def test_tank(exe, engine):
    wd = os.path.abspath("sph_create_tank_%s" % engine)
    os.makedirs(wd, exist_ok=True)
    dx = DX
    W, D, HT = TANK["W"] * dx, TANK["D"] * dx, TANK["HT"] * dx
    stl_shapes.write_stl(os.path.join(wd, "tank.stl"), stl_shapes.box((0, 0, 0), (W, D, HT), open_top=True), "tank")
    _, dt = tank_script("hand", 0)
    steps = int(round(0.25 / dt))
    res = {}
    atoms = {}
    for mode in ("hand", "mesh"):
        script, _ = tank_script(mode, steps, dump="atoms.%s" % mode)
        rc, out = E.run([exe], wd, script, timeout=300)
        if rc != 0 or "ERROR" in out:
            print("FAIL: the %s tank exited %d:\n%s" % (mode, rc, out[-3000:]))
            return 1
        rows = E.thermo_rows(out)
        res[mode] = rows[-1][1:3] if rows and rows[-1][0] == steps else None
        if res[mode] is None:
            print("FAIL: no thermo row at step %d in the %s tank" % (steps, mode))
            return 1
        atoms[mode] = read_atoms(os.path.join(wd, "atoms.%s" % mode))
    ok = True
    # the atoms: the same set of (type, position, radius, mass), whatever their IDs
    def key(a):
        return (a[0],) + tuple(round(v / dx * 1e6) for v in a[1:4]) + (round(a[4] / dx * 1e6), round(a[5] * 1e12))
    sh = sorted(key(a) for a in atoms["hand"].values())
    sm = sorted(key(a) for a in atoms["mesh"].values())
    same = sh == sm
    nw = sum(1 for a in atoms["mesh"].values() if a[0] == 2)
    nf = sum(1 for a in atoms["mesh"].values() if a[0] == 1)
    print("%s created atoms equal the hand-built tank (%d walls, %d fluid; hand-built %d atoms)"
          % ("PASS" if same else "FAIL", nw, nf, len(sh)))
    ok &= same
    H = TANK["H"] * dx
    for i, z in enumerate((H / 4, H / 2)):
        ph, pm = res["hand"][i], res["mesh"][i]
        exact = RHO0 * G * (H - z)
        d = abs(pm - ph) / exact
        eh, em = ph / exact - 1, pm / exact - 1
        good = d <= 0.01 and abs(em) <= 0.05 and abs(eh) <= 0.05
        print("%s %s tank at z = %.4f after %d steps (0.25 s): p(mesh + fill) %.2f Pa, p(hand) %.2f Pa, rho0 g (H-z) "
              "%.2f Pa: mesh vs hand %.2e (bound 1e-2), vs exact %+.2f %% / %+.2f %% (bound 5 %%)"
              % ("PASS" if good else "FAIL", engine, z, steps, pm, ph, exact, d, 100 * em, 100 * eh))
        ok &= good
    return 0 if ok else 1


# ------------------------------------------------------------------ containers at rest
def settle_script(box, dx, make_walls, fill_region, fill_top, gravity_dir, settle, extra_check):
    h = 1.5 * dx
    c0 = 10 * math.sqrt(G * fill_top)
    dt = 0.2 * h / (1.2 * c0)
    steps = int(round(settle / dt))
    s = ("units si\natom_style sphere\nboundary f f f\natom_modify map array sort 0 0.0\n"
         "region box block %s units box\ncreate_box 2 box\ngroup fluid type 1\ngroup walls type 2\n" % box +
         make_walls + fill_region +
         "fix mkf fluid sph/fill region inside spacing %g type 1 density %g exclude walls\n" % (dx, RHO0) +
         "timestep %.10g\npair_style none\nneighbor %g bin\nneigh_modify every 20 delay 0 check no\n" % (dt, dx) +
         "fix water fluid sph/fluid rho0 %g h %.10g c0 %.10g gravity 0 0 -%g visc artificial 0.05 wall walls "
         "hydrostatic $(f_mkf)\n" % (RHO0, h, c0, G) +
         "compute v fluid property/atom vx vy vz\n"
         "variable sp atom sqrt(vx*vx+vy*vy+vz*vz)\ncompute vmax fluid reduce max v_sp\n"
         "thermo_style custom step atoms c_vmax\nthermo %d\n" % max(1, steps // 10) +
         "run %d\n" % steps +
         "write_dump fluid custom final.dump id x y z vx vy vz modify sort id\n")
    return s, steps


def check_rest(exe, engine, name, script, depth, dx, vbound):
    """runs script; depth(x, y, z) is how far a point lies beyond the container's surface (< 0 inside). Pass: the
    largest fluid speed below vbound and no fluid particle beyond the first wall layer (depth dx/2)."""
    wd = os.path.abspath("sph_create_%s_%s" % (name, engine))
    rc, out = E.run([exe], wd, script, timeout=300)
    if rc != 0 or "ERROR" in out:
        print("FAIL: the %s scene exited %d:\n%s" % (name, rc, out[-3000:]))
        return 1
    r = E.thermo_rows(out)
    v = [r[-1][2]] if r and len(r[-1]) == 3 else None
    rows = E.read_dump(os.path.join(wd, "final.dump"))
    dmax = max(depth(r[0], r[1], r[2]) for r in rows.values()) if rows else float("nan")
    nout = sum(1 for r in rows.values() if depth(r[0], r[1], r[2]) > 0.5 * dx)
    ok = v is not None and v[0] < vbound and nout == 0 and len(rows) > 0
    print("%s %s %s: %d fluid atoms at rest: max speed %.4f m/s (bound %.4f), deepest fluid particle %+.2f dx beyond "
          "the surface (bound +0.50: the first wall layer), %d beyond it"
          % ("PASS" if ok else "FAIL", name, engine, len(rows), v[0] if v else float("nan"), vbound, dmax / dx, nout))
    return 0 if ok else 1


def test_tilted(exe, engine):
    dx = 0.005
    W, D, Hb, Hw = 12 * dx, 6 * dx, 16 * dx, 9 * dx  # box, water depth (along the box's own axis)
    ang = math.radians(15.0)
    piv = (W / 2, D / 2, Hb / 2)
    wd = os.path.abspath("sph_create_tilted_%s" % engine)
    os.makedirs(wd, exist_ok=True)
    stl_shapes.write_stl(os.path.join(wd, "tilted.stl"),
                         stl_shapes.tilted_box((0, 0, 0), (W, D, Hb), 15.0, (0, 1, 0), piv), "tilted")
    # the box's faces as plane regions (normals into the box), their intersection with z < water level
    def rotp(x, z):
        c, s = math.cos(ang), math.sin(ang)
        x0, z0 = x - piv[0], z - piv[2]
        return piv[0] + c * x0 + s * z0, piv[2] - s * x0 + c * z0
    planes = []
    for (px, pz, nx, nz) in ((0, Hb / 2, 1, 0), (W, Hb / 2, -1, 0), (W / 2, 0, 0, 1)):
        qx, qz = rotp(px, pz)
        c, s = math.cos(ang), math.sin(ang)
        planes.append((qx, qz, c * nx + s * nz, -s * nx + c * nz))
    reg = ""
    for i, (qx, qz, nx, nz) in enumerate(planes):
        reg += "region p%d plane %.12g 0 %.12g %.12g 0 %.12g units box\n" % (i, qx, qz, nx, nz)
    zlo_box = min(rotp(x, z)[1] for x in (0, W) for z in (0, Hb))
    zs = zlo_box + Hw
    reg += ("region p3 block -1 1 0 %.12g -1 %.12g units box\n" % (D, zs) +
            "region inside intersect 4 p0 p1 p2 p3 units box\n")
    walls = "fix mkw walls sph/wall mesh tilted.stl spacing %g layers 3 type 2 density %g\n" % (dx, RHO0)
    script, _ = settle_script("-0.04 0.1 -0.03 0.06 -0.04 0.12", dx, walls, reg, zs, 2, 0.3, None)

    def depth(x, y, z):
        c, s = math.cos(-ang), math.sin(-ang)
        x0, z0 = x - piv[0], z - piv[2]
        bx, bz = piv[0] + c * x0 + s * z0, piv[2] - s * x0 + c * z0
        return max(-bx, bx - W, -y, y - D, -bz, bz - Hb)
    return check_rest(exe, engine, "tilted", script, depth, dx, 0.1 * math.sqrt(G * Hw))


def drum_scene(exe, engine, variant):
    """variant "region": fill a region cylinder at the facets' inner radius; "inside": fill the lower half of the
    simulation box and keep the points inside the drum's mesh (sph/fill ... inside mkw)"""
    dx = 0.005
    R, L, NF = 12 * dx, 6 * dx, 32
    name = "drum" if variant == "region" else "drum_inside"
    wd = os.path.abspath("sph_create_%s_%s" % (name, engine))
    os.makedirs(wd, exist_ok=True)
    stl_shapes.write_stl(os.path.join(wd, "drum.stl"),
                         stl_shapes.cylinder((0, 0, 0), (0, 1, 0), R, L, NF, True), "drum")
    walls = "fix mkw walls sph/wall mesh drum.stl spacing %g layers 3 type 2 density %g\n" % (dx, RHO0)
    if variant == "region":
        reg = ("region cyl cylinder y 0 0 %.10g -%.10g %.10g units box\n" % (R * math.cos(math.pi / NF), L / 2, L / 2) +
               "region low block INF INF INF INF INF 0 units box\n"
               "region inside intersect 2 cyl low units box\n")
        inside = ""
    else:
        reg = "region inside block INF INF INF INF INF 0 units box\n"
        inside = " inside mkw"
    script, _ = settle_script("-0.09 0.09 -0.04 0.04 -0.09 0.09", dx, walls, reg, R, 2, 0.3, None)
    script = script.replace(" exclude walls", inside + " exclude walls")

    def depth(x, y, z):
        # beyond the polygon's facet through the particle's angle (the facets' inner radius R cos(pi/NF))
        a = math.atan2(z, x)
        k = math.floor(a / (2 * math.pi / NF))
        mid = (k + 0.5) * 2 * math.pi / NF
        return max(x * math.cos(mid) + z * math.sin(mid) - R * math.cos(math.pi / NF), abs(y) - L / 2)
    return check_rest(exe, engine, name, script, depth, dx, 0.1 * math.sqrt(G * R))


def test_drum(exe, engine):
    return drum_scene(exe, engine, "region")


def test_drum_inside(exe, engine):
    return drum_scene(exe, engine, "inside")


# ------------------------------------------------------------------ 2D region walls
def test_region2d(exe, engine):
    dx = 0.0025
    wd = os.path.abspath("sph_create_region2d_%s" % engine)
    script = ("dimension 2\nunits si\natom_style sphere\nboundary f f p\natom_modify map array sort 0 0.0\n"
              "region box block -0.03 0.13 -0.03 0.35 -%g %g units box\ncreate_box 2 box\n" % (dx, dx) +
              "region tank block 0 0.1 0 0.3 -%g %g units box\n" % (dx / 2, dx / 2) +
              "region water block 0 0.1 0 0.2 -%g %g units box\n" % (dx / 2, dx / 2) +
              "group walls type 2\ngroup fluid type 1\n"
              "fix mkw walls sph/wall region tank spacing %g layers 3 type 2 mass 0.00625 diameter 0.003\n" % dx +
              "fix mkf fluid sph/fill region water spacing %g type 1 density 1000 exclude walls gap %g\n" % (dx, dx / 2) +
              'print "FILL $(f_mkf) $(f_mkf[1]) $(f_mkf[2]) $(count(walls)) $(count(fluid))"\n'
              "write_dump all custom atoms.dump id type x y z radius mass modify sort id\n")
    rc, out = E.run([exe], wd, script, timeout=60)
    if rc != 0 or "ERROR" in out:
        print("FAIL: exited %d:\n%s" % (rc, out[-3000:]))
        return 1
    atoms = read_atoms(os.path.join(wd, "atoms.dump"))
    walls = sorted((round(a[1] / dx - 0.5), round(a[2] / dx - 0.5)) for a in atoms.values() if a[0] == 2)
    # expected: lattice points (i+1/2) dx outside [0,40] x [0,120] (in dx) within 3 dx of the rectangle
    want = []
    for i in range(-3, 43):
        for j in range(-3, 123):
            x, y = i + 0.5, j + 0.5
            ddx = max(0 - x, x - 40, 0)
            ddy = max(0 - y, y - 120, 0)
            if (ddx > 0 or ddy > 0) and math.hypot(ddx, ddy) < 3:
                want.append((i, j))
    want.sort()
    ok = walls == want
    print("%s region walls: %d atoms, expected %d (lattice points outside the region within 3 dx of it)"
          % ("PASS" if ok else "FAIL", len(walls), len(want)))
    fl = [a for a in atoms.values() if a[0] == 1]
    wa = [a for a in atoms.values() if a[0] == 2]
    # the walls' radius 0.0015 + gap dx/2 (given) = 0.00275 > dx: the fluid column/row next to the left, right and bottom
    # walls (dx away) is left out: 38 x 79 of the 40 x 80 points
    good = len(fl) == 38 * 79 and all(abs(a[4] - 0.0015) < 1e-15 and abs(a[5] - 0.00625) < 1e-15 for a in wa) \
        and all(abs(a[4] - dx / 2) < 1e-15 and abs(a[5] - 1000 * dx * dx) < 1e-15 for a in fl)
    print("%s fill: %d fluid atoms (38 x 79 expected: the walls' radius + gap excludes one row), radius and mass as given (walls: diameter 0.003, mass "
          "0.00625; fluid: dx, rho0 dx^2)" % ("PASS" if good else "FAIL", len(fl)))
    ok &= good
    v = probe_values(out, "FILL")
    good = v is not None and abs(v[0] - 0.2) < 1e-12 and v[1] == 38 * 79 and abs(v[2] - 0.2) < 1e-12 and \
        v[3] == len(wa) and v[4] == len(fl) and "top of the fluid (highest y + spacing/2): 0.2" in out
    print("%s fill top printed and in f_mkf: %s" % ("PASS" if good else "FAIL", v))
    ok &= good
    return 0 if ok else 1


# ------------------------------------------------------------------ bad input
BAD3 = ("units si\natom_style sphere\nboundary f f f\nregion box block -1 1 -1 1 -1 1 units box\n"
        "create_box 2 box\nregion r block -0.5 0.5 -0.5 0.5 -0.5 0.5 units box\ngroup walls type 2\n")


def test_badinput(exe, engine):
    box = os.path.abspath("sph_create_bad_box.stl")
    stl_shapes.write_stl(box, stl_shapes.box((0, 0, 0), (0.5, 0.5, 0.5)), "b")
    W = "fix w walls sph/wall "
    cases = [
        ("missing STL file", BAD3 + W + "mesh /nonexistent/tank.stl spacing 0.1 layers 3 type 2 density 1000\n",
         "cannot open STL file '/nonexistent/tank.stl'"),
        ("unknown keyword", BAD3 + W + "region r spacing 0.1 layers 3 type 2 density 1000 lyers 2\n",
         "unknown keyword 'lyers' (allowed: mesh, region, spacing, layers, type, mass, density, diameter, scale, "
         "move, orient, flip"),
        ("spacing 0", BAD3 + W + "region r spacing 0 layers 3 type 2 density 1000\n", "spacing must be > 0"),
        ("spacing < 0", BAD3 + W + "region r spacing -0.1 layers 3 type 2 density 1000\n", "spacing must be > 0"),
        ("layers 0", BAD3 + W + "region r spacing 0.1 layers 0 type 2 density 1000\n", "layers must be >= 1"),
        ("layers not an integer", BAD3 + W + "region r spacing 0.1 layers 2.5 type 2 density 1000\n",
         "layers expects an integer >= 1, got '2.5'"),
        ("mass and density", BAD3 + W + "region r spacing 0.1 layers 2 type 2 density 1000 mass 1\n",
         "give one of mass M and density RHO0"),
        ("no mesh or region", BAD3 + W + "spacing 0.1 layers 2 type 2 density 1000\n", "give mesh FILE or region"),
        ("type out of range", BAD3 + W + "region r spacing 0.1 layers 2 type 3 density 1000\n",
         "type must be 1 .. 2 (got 3)"),
        ("unknown region", BAD3 + W + "region nope spacing 0.1 layers 2 type 2 density 1000\n",
         "region nope does not exist"),
        ("flip value", BAD3 + W + "mesh %s spacing 0.1 layers 2 type 2 density 1000 flip maybe\n" % box,
         "flip must be yes or no (got 'maybe')"),
        ("walls outside the box", BAD3 + W + "mesh %s spacing 0.1 layers 2 type 2 density 1000 move 0.4 0 0\n" % box,
         "lie outside the simulation box"),
        ("mesh in 2D", "dimension 2\nunits si\natom_style sphere\nboundary f f p\n"
         "region box block -1 1 -1 1 -0.1 0.1 units box\ncreate_box 2 box\ngroup walls type 2\n" + W +
         "mesh %s spacing 0.1 layers 2 type 2 density 1000\n" % box, "mesh is for 3D only (dimension 2)"),
        ("atom style without radius", "units si\natom_style atomic\nboundary f f f\n"
         "region box block -1 1 -1 1 -1 1 units box\ncreate_box 2 box\nregion r block -0.5 0.5 -0.5 0.5 -0.5 0.5 "
         "units box\ngroup walls type 2\n" + W + "region r spacing 0.1 layers 2 type 2 density 1000\n",
         "needs atom_style sphere (LIGGGHTS: sphere or granular)"),
        ("fill: unknown keyword", BAD3 + "fix f all sph/fill region r spacing 0.1 type 1 density 1000 excl walls\n",
         "unknown keyword 'excl' (allowed: region, spacing, type, mass, density, diameter, inside, exclude, gap, "
         "origin"),
        ("fill: inside an unknown fix", BAD3 + "fix f all sph/fill region r spacing 0.1 type 1 density 1000 inside w\n",
         "inside: no fix with ID w (define the fix sph/wall before the fill)"),
        ("fill: inside a fix of another style", BAD3 + "fix nv all nve\n"
         "fix f all sph/fill region r spacing 0.1 type 1 density 1000 inside nv\n",
         "inside: fix nv is a fix nve, not a fix sph/wall"),
        ("fill: gap < 0", BAD3 + "fix f all sph/fill region r spacing 0.1 type 1 density 1000 gap -0.1\n",
         "gap must be >= 0"),
        ("fill: spacing 0", BAD3 + "fix f all sph/fill region r spacing 0 type 1 density 1000\n",
         "spacing must be > 0"),
        ("fill: exclude unknown group", BAD3 + "fix f all sph/fill region r spacing 0.1 type 1 density 1 exclude g\n",
         "exclude: group g does not exist"),
        ("fill: atom style without radius", "units si\natom_style atomic\nboundary f f f\n"
         "region box block -1 1 -1 1 -1 1 units box\ncreate_box 2 box\nregion r block -0.5 0.5 -0.5 0.5 -0.5 0.5 "
         "units box\nfix f all sph/fill region r spacing 0.1 type 1 density 1000\n", "needs atom_style sphere"),
    ]
    fails = 0
    for i, (what, script, want) in enumerate(cases):
        if not E.refused(exe, os.path.abspath("sph_create_bad_%s_%d" % (engine, i)), what, script, want,
                         crash_codes=(134, 139)):
            fails += 1
    return 0 if fails == 0 else 1


# ------------------------------------------------------------------ a moving mesh (LIGGGHTS)
def test_movemesh(exe, engine):
    """fix move/mesh turns the mesh the walls were made from: without a fix move on the wall group fix sph/wall
    warns (naming the group) at the run; with one it does not"""
    if engine != "liggghts":
        print("SKIP movemesh: fix move/mesh is LIGGGHTS only")
        return 0
    wd = os.path.abspath("sph_create_movemesh")
    os.makedirs(wd, exist_ok=True)
    stl_shapes.write_stl(os.path.join(wd, "drum.stl"), stl_shapes.cylinder((0, 0, 0), (0, 1, 0), 0.05, 0.03, 24), "d")
    base = ("units si\natom_style granular\natom_modify map array sort 0 0\nboundary f f f\n"
            "communicate single vel yes\nnewton off\n"
            "region box block -0.08 0.08 -0.04 0.04 -0.08 0.08 units box\ncreate_box 2 box\ngroup walls type 2\n"
            "fix m1 all property/global youngsModulus peratomtype 1e7 1e7\n"
            "fix m2 all property/global poissonsRatio peratomtype 0.3 0.3\n"
            "fix m3 all property/global coefficientRestitution peratomtypepair 2 0.5 0.5 0.5 0.5\n"
            "fix m4 all property/global coefficientFriction peratomtypepair 2 0.5 0.5 0.5 0.5\n"
            "fix drum all mesh/surface file drum.stl type 2\n"
            "fix spin all move/mesh mesh drum rotate origin 0. 0. 0. axis 0. 1. 0. period 1.0\n"
            "fix mkw walls sph/wall mesh drum.stl spacing 0.005 layers 2 type 2 density 1000\n")
    fails = 0
    for name, extra, want_warn in (("no fix move", "", True),
                                   ("fix move on the walls", "fix turn walls move rotate 0 0 0 0 1 0 1.0\n", False)):
        sub = os.path.join(wd, "w" if want_warn else "m")
        os.makedirs(sub, exist_ok=True)
        shutil.copy(os.path.join(wd, "drum.stl"), sub)
        rc, out = E.run([exe], sub, base + extra + "timestep 1e-5\nrun 2\n")
        warned = "a fix move/mesh moves a mesh but no fix move acts on group walls" in out
        ok = rc == 0 and "ERROR" not in out and warned == want_warn
        print("%s movemesh, %s: exit %d, warning %s (expected %s)" % ("PASS" if ok else "FAIL", name, rc,
                                                                      "printed" if warned else "absent",
                                                                      "printed" if want_warn else "absent"))
        if not ok:
            print(out[-1500:])
            fails += 1
    return 0 if fails == 0 else 1


# ------------------------------------------------------------------ many ranks
def test_mpi(exe, engine, mpiexec):
    dx = 0.005
    R, L = 10 * dx, 8 * dx
    wd1 = os.path.abspath("sph_create_mpi1_%s" % engine)
    wd2 = os.path.abspath("sph_create_mpi2_%s" % engine)
    for wd in (wd1, wd2):
        os.makedirs(wd, exist_ok=True)
        stl_shapes.write_stl(os.path.join(wd, "drum.stl"), stl_shapes.cylinder((0, 0, 0), (0, 1, 0), R, L, 24), "d")
    script = ("units si\natom_style sphere\nboundary f f f\natom_modify map array\n"
              "region box block -0.09 0.2 -0.05 0.05 -0.07 0.07 units box\ncreate_box 3 box\n"
              "group walls type 2\ngroup fluid type 1\ngroup walls2 type 3\n"
              "fix mkw walls sph/wall mesh drum.stl spacing %g layers 3 type 2 density 1000\n" % dx +
              "region r2 block 0.1 0.15 -0.02 0.02 -0.03 0.03 units box\n"
              "fix mkw2 walls2 sph/wall region r2 spacing %g layers 2 type 3 mass 0.1\n" % dx +
              "region cyl cylinder y 0 0 %g -%g %g units box\n" % (R, L / 2, L / 2) +
              "fix mkf fluid sph/fill region cyl spacing %g type 1 density 1000 exclude walls walls2\n" % dx +
              'print "COUNTS $(count(walls)) $(count(walls2)) $(count(fluid)) $(atoms)"\n'
              "write_dump all custom atoms.dump id type x y z radius mass modify sort id\n")
    rc1, out1 = E.run([exe], wd1, script, timeout=120)
    rc2, out2 = E.run([mpiexec, "-np", "2", "--oversubscribe", "--allow-run-as-root", exe], wd2, script,
                      timeout=120)
    if rc1 or rc2 or "ERROR" in out1 + out2:
        print("FAIL: exit %d / %d:\n%s\n%s" % (rc1, rc2, out1[-2000:], out2[-2000:]))
        return 1
    a1 = read_atoms(os.path.join(wd1, "atoms.dump"))
    a2 = read_atoms(os.path.join(wd2, "atoms.dump"))
    ranks = "2 by 1 by 1" in out2 or "1 by 2 by 1" in out2 or "1 by 1 by 2" in out2
    same = a1 == a2 and len(a1) > 0
    c = probe_values(out1, "COUNTS")
    print("%s %s: the atoms created on 2 ranks (%s) equal those on 1 rank: %d atoms (walls %d, region walls %d, "
          "fluid %d), IDs, types, positions, radii, masses %s"
          % ("PASS" if same and ranks else "FAIL", engine, "decomposed" if ranks else "NOT decomposed", len(a1),
             c[0] if c else -1, c[1] if c else -1, c[2] if c else -1, "equal" if same else "DIFFER"))
    return 0 if same and ranks else 1


if __name__ == "__main__":
    sys.exit(E.dispatch(sys.argv, globals(), __doc__))
