#!/usr/bin/env python3
"""test_setup_checks.py - the set-up checks of fix sph/fluid and fix sph/couple on the scenes a user adding water to
a DEM script meets, through a launcher.

  test_setup_checks.py CASE EXE ENGINE [SETTLING-INPUT]
    CASE    grain_size | fixes | pair | terms | hydro_auto | ke
    EXE     lmp_sphdem or liggghts_sphdem;  ENGINE  lammps | liggghts
    SETTLING-INPUT  examples/settling/in.settling (grain_size, fixes: the 3D scene)

Each check is run on a scene that must trigger it (the ERROR or WARNING line must hold the words: the keyword, the
other fix's ID and style, the grain's diameter and the limit, the line to add) and on the correct scene, where it
must stay silent (the same words absent, the run ends normally):
  grain_size  a grain of 4 hc is refused naming its diameter and the limit (2D dam break with grains, 3D settling);
              a grain in the warning band (porosity of a lone grain in [eps_min, 0.5]) runs with a WARNING
  fixes       nve/sphere, fix move, fix adapt, fix gravity on the fluid; nve/sphere on the walls; insert/pack
              into the water (LIGGGHTS) and above it
  pair        the granular pair style on the fluid without neigh_modify exclude (error), with the fluid excluded
              from the grains only (warning), with 'neigh_modify exclude group fluid all' (silent)
  terms       the set-up line of the terms that are on; walls out of the fluid's reach; grains out of the coupling's
  hydro_auto  hydrostatic auto == hydrostatic ZSURF (the printed surface, every fluid density to 1e-12)
  ke          f_couple[15-17] (grain kinetic energy) and f_water[3] (fluid) == sums over a dump of the same step
Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import engine_test as E  # noqa: E402  (the dam-break scenes and the run helper)

TIMEOUT = 60
SIGNALS = (124, 134, 136, 137, 139)
ok = E.Checks(tail=8)


def R(s, *pairs):
    """replace old by new in s; every old must occur (else the variant proves nothing)"""
    for old, new in zip(pairs[::2], pairs[1::2]):
        if old not in s:
            raise ValueError("the base script has no %r" % old)
        s = s.replace(old, new, 1)
    return s


def lines_with(out, tag, words):
    return [l for l in out.splitlines() if tag in l and all(w in l for w in words)]


def expect(exe, wd, what, script, kind, words):
    """kind error: exit > 0 (not a signal) and an ERROR line with every word; warn: exit 0 and a WARNING line with
    every word; silent: exit 0 and no ERROR or WARNING line with the words"""
    rc, out = E.run([exe], wd, script, timeout=TIMEOUT)
    crashed = rc < 0 or rc in SIGNALS or "Segmentation" in out
    if kind == "error":
        hit = lines_with(out, "ERROR", words)
        good = rc > 0 and not crashed and bool(hit)
    elif kind == "warn":
        hit = lines_with(out, "WARNING", words)
        good = rc == 0 and bool(hit) and not lines_with(out, "ERROR", [])
    else:
        hit = lines_with(out, "WARNING", words) + lines_with(out, "ERROR", words)
        good = rc == 0 and not hit and not lines_with(out, "ERROR", [])
    seen = (hit or lines_with(out, "ERROR", []) or ["(no line)"])[0].strip()
    ok(good, "%s: %s, exit %d: %s" % (what, kind, rc, seen[:300]), out)
    if not good:
        print("     expected words: %s" % words)
    return out


# ---- the grain against the coupling length ---------------------------------------------------------------------
def test_grain_size(exe, engine, settling):
    root = "setup_grain_size_" + engine
    hc = 0.013  # the fluid h of the coupled dam break (hc defaults to h)
    base = E.couple_scene(engine, steps=2)
    # 2D: a lone grain leaves 1 - 7/16 (d/hc)^2; refused above d = sqrt(16 (1 - 0.2) / 7) hc = 1.35 hc
    d4 = 4 * hc
    expect(exe, os.path.join(root, "2d_4hc"), "2D grain of 4 hc", R(base, "set group grains diameter 0.006",
           "set group grains diameter %g" % d4), "error",
           ["Fix sph/couple: grain", "diameter d = %g, 4 hc" % d4, "needs d <= 1.35 hc = 0.0175", "eps_min 0.2",
            "larger hc", "smaller grains", "coarser fluid"])
    expect(exe, os.path.join(root, "2d_band"), "2D grain of 1.2 hc (warning band)",
           R(base, "set group grains diameter 0.006", "set group grains diameter %g" % (1.2 * hc)), "warn",
           ["Fix sph/couple: grain", "1.2 hc", "needs d <= 1.35 hc"])
    expect(exe, os.path.join(root, "2d_ok"), "2D grains of 6 mm = 0.46 hc", base, "silent", ["Fix sph/couple: grain"])
    # eps_min moves the limit: 1.2 hc is refused with eps_min 0.5 (limit sqrt(16 0.5 / 7) = 1.07 hc)
    expect(exe, os.path.join(root, "2d_epsmin"), "2D grain of 1.2 hc with eps_min 0.5",
           R(base, "set group grains diameter 0.006", "set group grains diameter %g" % (1.2 * hc),
             "sph/couple water mu 1e-3", "sph/couple water mu 1e-3 eps_min 0.5"), "error",
           ["diameter d = 0.0156, 1.2 hc", "needs d <= 1.07 hc", "eps_min 0.5"])
    # 3D: examples/settling (dx 2 mm, h = hc = 2.6 mm); refused above (32 (1 - 0.2) / 7)^(1/3) hc = 1.54 hc
    with open(settling) as f:
        text = re.sub(r"(?m)^run\s+\S+", "run 0", f.read())
    h3 = 1.3 * 0.002
    expect(exe, os.path.join(root, "3d_4hc"), "3D grain of 4 hc (settling)",
           R(text, "variable d      index 0.001", "variable d      index %.6g" % (4 * h3)), "error",
           ["Fix sph/couple: grain", "diameter d = 0.0104, 4 hc", "needs d <= 1.54 hc = 0.0040", "2 dx",
            "7/32 (d/hc)^3"])
    expect(exe, os.path.join(root, "3d_band"), "3D grain of 1.4 hc (settling, warning band)",
           R(text, "variable d      index 0.001", "variable d      index %.6g" % (1.4 * h3)), "warn",
           ["Fix sph/couple: grain", "1.4 hc"])
    expect(exe, os.path.join(root, "3d_ok"), "3D settling as shipped (d = 1 mm)", text, "silent",
           ["Fix sph/couple: grain"])


# ---- other fixes on fluid or wall atoms --------------------------------------------------------------------------
def test_fixes(exe, engine, settling):
    root = "setup_fixes_" + engine
    base = E.couple_scene(engine, steps=2)
    fluid_fix = "fix water fluid sph/fluid"
    expect(exe, os.path.join(root, "nve_all"), "nve/sphere on all",
           R(base, "fix nvs grains nve/sphere", "fix nvs all nve/sphere"), "error",
           ["fix nvs (style nve/sphere) also integrates atoms of group all", "fluid group fluid",
            "fix nvs grains nve/sphere"])
    expect(exe, os.path.join(root, "move_fluid"), "fix move on the fluid",
           R(base, "fix nvs grains", "fix mv fluid move linear 0 0 0\nfix nvs grains"), "error",
           ["fix mv (style move) also integrates atoms of group fluid", "fluid group fluid"])
    expect(exe, os.path.join(root, "nve_walls"), "nve/sphere on the walls",
           R(base, "fix nvs grains", "fix wmv walls nve/sphere\nfix nvs grains"), "warn",
           ["fix wmv (style nve/sphere, group walls)", "wall atoms", "fix wmv grains nve/sphere", "fix move"])
    expect(exe, os.path.join(root, "move_walls"), "fix move on the walls (legitimate)",
           R(base, "fix nvs grains", "fix wmv walls move linear 0 0 0\nfix nvs grains"), "silent", ["fix wmv"])
    dyn = R(base, "atom_style sphere", "atom_style sphere 1") if engine == "lammps" else base  # dynamic radii
    expect(exe, os.path.join(root, "adapt_all"), "fix adapt on all",
           R(dyn, "fix nvs grains", "variable dd equal 0.006\nfix ad all adapt 1 atom diameter v_dd\nfix nvs grains"),
           "error", ["fix ad (style adapt, group all)", "fluid and wall atoms", "mass", "fix ad grains adapt"])
    expect(exe, os.path.join(root, "gravity_all"), "fix gravity on all, fluid gravity keyword given",
           R(base, "fix grav grains", "fix grav all"), "warn",
           ["fix grav (style gravity, group all)", "no effect", "keyword gravity", "fix grav grains gravity"])
    nograv = R(base, "gravity 0 -9.81 0 ", "", "hydrostatic 0.2 ", "", "fix grav grains", "fix grav all")
    expect(exe, os.path.join(root, "gravity_only_fix"), "fix gravity on all, no fluid gravity keyword", nograv,
           "error", ["fix grav (style gravity, group all)", "would feel no gravity", "keyword gravity gx gy gz"])
    expect(exe, os.path.join(root, "gravity_grains"), "fix gravity on the grains (correct)", base, "silent",
           ["fix grav", "fix nvs"])
    if engine == "lammps":  # pour and deposit test overlaps only: nothing to say beside the fluid
        ins = "region rdep block 0.05 0.13 0.21 0.25 -0.005 0.005 units box\n" \
              "fix dep grains deposit 1 3 1000 12345 region rdep near 0.006\n"
        expect(exe, os.path.join(root, "deposit"), "fix deposit beside the fluid (no fill count)",
               R(base, fluid_fix, ins + fluid_fix), "silent", ["fix dep"])
        return
    # LIGGGHTS' particle templates are 3D only: examples/settling, the insertion postponed past the run
    with open(settling) as f:
        scene = re.sub(r"(?m)^run\s+\S+", "run 2", f.read())
    ins = ("fix pts all particletemplate/sphere 15485863 atom_type 3 density constant 2500 radius constant 0.0005\n"
           "fix pdd all particledistribution/discrete 32452843 1 pts 1.0\n"
           "region rdep block 0 0.03 0 0.03 ZLO ZHI units box\n"
           "fix dep grain insert/pack seed 32452867 distributiontemplate pdd insert_every 1000 start 100000 "
           "overlapcheck yes volumefraction_region 0.1 region rdep\n")
    into = R(scene, "fix           water fluid", ins.replace("ZLO ZHI", "0.03 0.05") + "fix           water fluid")
    # the region holds the fluid layers with z in (0.03, 0.05): 15 x 15 x 10 lattice sites
    expect(exe, os.path.join(root, "insert_into"), "insert/pack into a region of the water", into, "warn",
           ["fix dep (style insert/pack, group grain) fills a region that holds 2250 fluid atoms",
            "volumefraction_region", "region clear of the fluid"])
    above = R(scene, "fix           water fluid", ins.replace("ZLO ZHI", "0.065 0.08") + "fix           water fluid")
    expect(exe, os.path.join(root, "insert_above"), "insert/pack above the water", above, "silent", ["fix dep"])


# ---- the granular pair style -------------------------------------------------------------------------------------
def pair_scene(engine, neigh):
    s = E.couple_scene(engine, steps=2)
    s = R(s, "atom_modify map array", "newton off\natom_modify map array")
    if engine == "lammps":
        pair = "pair_style gran/hertz/history 2e5 NULL 50 NULL 0.5 1\npair_coeff * *\ncomm_modify vel yes\n"
    else:
        pair = ("pair_style gran model hertz tangential history\npair_coeff * *\ncommunicate single vel yes\n"
                "fix m1 all property/global youngsModulus peratomtype 5e6 5e6 5e6\n"
                "fix m2 all property/global poissonsRatio peratomtype 0.45 0.45 0.45\n"
                "fix m3 all property/global coefficientRestitution peratomtypepair 3 0.7 0.7 0.7 0.7 0.7 0.7 0.7 0.7 0.7\n"
                "fix m4 all property/global coefficientFriction peratomtypepair 3 0.5 0.5 0.5 0.5 0.5 0.5 0.5 0.5 0.5\n")
    return R(s, "pair_style none\n", pair, "neigh_modify every 20 delay 0 check no\n",
             "neigh_modify every 20 delay 0 check no\n" + neigh)


def test_pair(exe, engine):
    root = "setup_pair_" + engine
    pstyle = "gran/hertz/history" if engine == "lammps" else "gran"
    expect(exe, os.path.join(root, "none"), "granular pair style, no exclusion", pair_scene(engine, ""), "error",
           ["pair_style %s acts between the fluid atoms of fix water" % pstyle, "type 1", "type 3",
            "'neigh_modify exclude group fluid all'", "'neigh_modify exclude group walls walls'"])
    expect(exe, os.path.join(root, "grains_only"), "fluid excluded from the grains only",
           pair_scene(engine, "neigh_modify exclude type 1 3\n"), "warn",
           ["pair_style %s computes fluid-fluid fluid-wall wall-wall contacts" % pstyle,
            "'neigh_modify exclude group fluid all'", "'neigh_modify exclude group walls walls'"])
    expect(exe, os.path.join(root, "group_exclude"), "neigh_modify exclude group fluid all + walls walls",
           pair_scene(engine, "neigh_modify exclude group fluid all exclude group walls walls\n"), "silent",
           ["pair_style"])
    expect(exe, os.path.join(root, "type_exclude"), "neigh_modify exclude type 1 1 1 2 1 3 2 2",
           pair_scene(engine, "neigh_modify exclude type 1 1 exclude type 1 2 exclude type 1 3 exclude type 2 2\n"),
           "silent", ["pair_style"])


# ---- the terms line, terms the scene does not use ------------------------------------------------------------
def test_terms(exe, engine):
    root = "setup_terms_" + engine
    out = expect(exe, os.path.join(root, "couple"), "the coupled scene", E.couple_scene(engine, steps=2), "silent",
                 ["within 2"])
    line = next((l for l in out.splitlines() if l.startswith("Fix sph/fluid: terms: ")), "")
    want = ["visc artificial 0.05", "gravity 0 -9.81 0", "tensile off", "xsph off", "delta off", "walls walls",
            "repulsion off", "coupling on (fix sph/couple)", "every 2"]
    ok(all(w in line for w in want), "terms line lists the terms: %s" % line)
    out = E.run([exe], os.path.join(root, "plain"), E.scene(engine, steps=2), timeout=TIMEOUT)[1]
    line = next((l for l in out.splitlines() if l.startswith("Fix sph/fluid: terms: ")), "")
    ok("coupling off" in line and "every 1" in line, "terms line without coupling: %s" % line)
    # the fluid 70 mm away from every wall particle (2h = 26 mm)
    far = R(E.scene(engine, steps=2), "region fl block 0.03 0.15 0.03 0.2", "region fl block 0.2 0.3 0.1 0.2")
    expect(exe, os.path.join(root, "walls_far"), "walls out of the fluid's reach", far, "warn",
           ["none of the", "atoms of the wall group walls is within 2h of a fluid particle of fix water"])
    expect(exe, os.path.join(root, "walls_near"), "walls beside the fluid", E.scene(engine, steps=2), "silent",
           ["wall group walls is within 2h"])
    # the grains above the water (surface at y = 0.2, 2 hc = 0.026)
    up = E.couple_scene(engine, steps=2)
    for y in ("0.08", "0.12"):
        for x in ("0.06", "0.09", "0.12"):
            up = R(up, "single %s %s 0.0" % (x, y), "single %s 0.2%s 0.0" % (x, "5" if y == "0.08" else "8"))
    expect(exe, os.path.join(root, "grains_far"), "grains out of the coupling's reach", up, "warn",
           ["no grain of group grains is within 2 hc = 0.026", "fix sph/fluid water"])


# ---- hydrostatic auto ----------------------------------------------------------------------------------------------
def test_hydro_auto(exe, engine):
    root = "setup_hydro_auto_" + engine
    ref = E.scene(engine, steps=0)
    auto = R(ref, "hydrostatic 0.2", "hydrostatic auto")
    E.must_run([exe], os.path.join(root, "explicit"), ref, no_error=True)
    out = E.must_run([exe], os.path.join(root, "auto"), auto, no_error=True)
    m = re.search(r"hydrostatic auto: free surface at y = (\S+) \(the highest fluid particle \+ dx/2", out)
    ok(m and abs(float(m.group(1)) - 0.2) < 1e-12, "the printed free surface %s == 0.2" % (m.group(1) if m else None),
       out)
    a = E.read_dump(os.path.join(root, "explicit", "final.0"))
    b = E.read_dump(os.path.join(root, "auto", "final.0"))
    rho_a = [a[k][4] for k in sorted(a)]
    rho_b = [b[k][4] for k in sorted(b)]
    worst = max(abs(x - y) / x for x, y in zip(rho_a, rho_b)) if rho_a and len(rho_a) == len(rho_b) else 1.0
    spread = max(rho_a) - min(rho_a) if rho_a else 0.0
    ok(worst < 1e-12 and spread > 1.0, "hydrostatic auto == hydrostatic 0.2: %d densities, max rel difference %.3g "
       "(densities span %.3g kg/m^3)" % (len(rho_a), worst, spread))
    rc, out = E.run([exe], os.path.join(root, "nogravity"), R(auto, "gravity 0 -9.81 0 ", ""), timeout=TIMEOUT)
    ok(rc > 0 and lines_with(out, "ERROR", ["hydrostatic auto needs a non-zero gravity"]),
       "hydrostatic auto without gravity is refused", out)


# ---- kinetic energies -------------------------------------------------------------------------------------------
def test_ke(exe, engine):
    wd = "setup_ke_" + engine
    s = E.couple_scene(engine, steps=100)
    fmt = ("dump_modify k sort id format float %.17g" if engine == "lammps" else
           'dump_modify k sort id format "%d %d ' + " ".join(["%.17g"] * 8) + '"')
    # spin: LAMMPS sets it; LIGGGHTS' set has no omega, there the fluid torque (torque yes) spins the grains
    spin = "set group grains omega 0 0 30" if engine == "lammps" else "# spin from the fluid torque"
    if engine != "lammps":
        s = R(s, "sph/couple water mu 1e-3 ", "sph/couple water mu 1e-3 torque yes ")
    s = R(s, "set group grains mass 0.0706858347", "set group grains mass 0.0706858347\n" + spin, "run 100\n",
          "dump k all custom 100 ke.* id type mass radius vx vy vz omegax omegay omegaz\n%s\nrun 100\n"
          "variable ket equal f_couple[15]\nvariable ketr equal f_couple[16]\nvariable ker equal f_couple[17]\n"
          "variable kf equal f_water[3]\nvariable ng equal f_couple[14]\n"
          "print \"KE ${ket} ${ketr} ${ker} ${kf} ${ng}\"\n" % fmt)
    out = E.must_run([exe], wd, s, no_error=True)
    m = re.search(r"(?m)^KE (\S+) (\S+) (\S+) (\S+) (\S+)$", out)
    if not ok(m, "the run prints the four kinetic energies", out):
        return
    ket, ketr, ker, kf, ng = (float(v) for v in m.groups())
    rows = E.read_dump(os.path.join(wd, "ke.100"))
    trans = {1: 0.0, 3: 0.0}
    rot = 0.0
    for r in rows.values():
        t, mass, rad, vx, vy, vz, ox, oy, oz = r
        if int(t) == 2:
            continue
        trans[int(t)] += 0.5 * mass * (vx * vx + vy * vy + vz * vz)
        if int(t) == 3:
            rot += 0.5 * 0.4 * mass * rad * rad * (ox * ox + oy * oy + oz * oz)

    def rel(a, b):
        return abs(a - b) / max(abs(b), 1e-300)
    ok(ng == 6 and trans[3] > 0 and rot > 0, "the grains move and spin (6 grains, translational %.4g J, rotational "
       "%.4g J)" % (trans[3], rot))
    ok(rel(ketr, trans[3]) < 1e-9, "f_couple[16] %.12g == translational sum over the dump %.12g" % (ketr, trans[3]))
    ok(rel(ker, rot) < 1e-9, "f_couple[17] %.12g == rotational sum over the dump %.12g" % (ker, rot))
    ok(rel(ket, trans[3] + rot) < 1e-9, "f_couple[15] %.12g == their sum %.12g" % (ket, trans[3] + rot))
    ok(rel(kf, trans[1]) < 1e-9, "f_water[3] %.12g == fluid sum over the dump %.12g" % (kf, trans[1]))


def main(argv):
    if len(argv) < 4:
        print(__doc__)
        return 2
    case, exe, engine = argv[1], argv[2], argv[3]
    if case in ("grain_size", "fixes"):
        if len(argv) < 5:
            print(__doc__)
            return 2
        globals()["test_" + case](exe, engine, argv[4])
    elif case in ("pair", "terms", "hydro_auto", "ke"):
        globals()["test_" + case](exe, engine)
    else:
        print(__doc__)
        return 2
    print("%s (%s): %d failed" % (case, engine, ok.fails))
    return 1 if ok.fails else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
