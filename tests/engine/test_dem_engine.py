#!/usr/bin/env python3
"""test_dem_engine.py - pair_style gran/hertz|hooke/history/gpu against the stock LAMMPS styles.

  same   LMP   head-on, oblique (with spin) and pile (20 grains: a frozen row, grains resting on it
               and on each other, falling grains, periodic x, atom sorting every 50 steps) for
               1000 steps with the stock style and its /gpu twin; the final x, v, omega must agree
               to round-off (max difference / column magnitude < 1e-12) and thermo (ke, press, pxy:
               the virial) must print the same
  example LMP INPUT  examples/dem_drop shortened to 20000 steps (-var steps): runs with the stock
               style and with /gpu, thermo (ke, mean and max height, press) identical
  errors LMP [MPIRUN]  an unsupported argument, a bad dampflag and 2 MPI ranks stop with a message
               naming the cause
Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import subprocess
import sys

HEAD = """units si
atom_style sphere
boundary {boundary}
atom_modify map array sort 50 0.005
comm_modify vel yes
region box block {box} units box
create_box 1 box
"""
TAIL = """set atom * diameter 0.01
set atom * density 2500
pair_style {style} {args}
pair_coeff * *
neighbor 0.001 bin
neigh_modify delay 0 every 1 check yes
fix 1 {integrate} nve/sphere
{extra}
timestep 1e-6
thermo_style custom step ke press pxy
thermo_modify format float %.12g
thermo 250
run 1000
write_dump all custom final.dump id x y z vx vy vz omegax omegay omegaz modify sort id format float %.17g
"""

SCENES = {
    "headon": dict(boundary="f f f", box="-0.05 0.05 -0.05 0.05 -0.05 0.05", integrate="all", extra="",
                   atoms="""create_atoms 1 single -0.00505 0 0 units box
create_atoms 1 single 0.00505 0 0 units box
velocity all set 0 0 0
set atom 1 vx 1.0
set atom 2 vx -1.0
"""),
    "oblique": dict(boundary="f f f", box="-0.05 0.05 -0.05 0.05 -0.05 0.05", integrate="all", extra="",
                    atoms="""create_atoms 1 single -0.00505 0.004 0.001 units box
create_atoms 1 single 0.00505 0 0 units box
velocity all set 0 0 0
set atom 1 vx 1.5
set atom 1 vy -0.3
set atom 1 omega 0 0 200
set atom 2 omega -100 0 0
"""),
    "pile": dict(boundary="p f p", box="0 0.0505 0 0.08 -0.00505 0.00505", integrate="mobile",
                 extra="fix fz bottom freeze\nfix g mobile gravity 9.81 vector 0 -1 0",
                 atoms="".join("create_atoms 1 single %g %g 0 units box\n" % p for p in [
                     (0.00505, 0.005), (0.01515, 0.005), (0.02525, 0.005), (0.03535, 0.005), (0.04545, 0.005),
                     (0.0101, 0.01365), (0.0202, 0.01365), (0.0303, 0.01365), (0.0404, 0.01365), (0.0, 0.01366),
                     (0.0051, 0.0223), (0.0152, 0.0224), (0.0253, 0.0222), (0.0354, 0.0225), (0.0455, 0.0221),
                     (0.008, 0.032), (0.019, 0.034), (0.029, 0.031), (0.040, 0.033), (0.049, 0.035)]) + """group bottom id 1:5
group mobile subtract all bottom
velocity mobile create 0.3 4928459 loop geom
velocity mobile set NULL -0.5 NULL sum yes
velocity mobile ramp vz -0.01 0.01 x 0 0.05 sum yes units box
"""),
}
# style -> stock arguments (Kn Kt gamma_n gamma_t xmu dampflag [limit_damping])
STYLES = {
    "gran/hertz/history": "2e7 NULL 5e3 NULL 0.5 1",
    "gran/hooke/history": "2e4 NULL 3e3 1.5e3 0.4 1 limit_damping",
}


def script(scene, style, args):
    s = SCENES[scene]
    return (HEAD.format(boundary=s["boundary"], box=s["box"]) + s["atoms"] +
            TAIL.format(style=style, args=args, integrate=s["integrate"], extra=s["extra"]))


def run(cmd, workdir, text, timeout=120):
    os.makedirs(workdir, exist_ok=True)
    with open(os.path.join(workdir, "in.test"), "w") as f:
        f.write(text)
    env = dict(os.environ)
    env.setdefault("OMP_NUM_THREADS", "1")
    try:
        p = subprocess.run(cmd + ["-in", "in.test", "-log", "log.test"], cwd=workdir, env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=timeout)
    except subprocess.TimeoutExpired:
        return 124, "timed out"
    return p.returncode, p.stdout.decode(errors="replace")


def load_dump(path):
    lines = open(path).read().splitlines()
    i = lines.index("ITEM: ATOMS id x y z vx vy vz omegax omegay omegaz")
    return [[float(v) for v in l.split()] for l in lines[i + 1:] if l.strip()]


def thermo(out):
    rows, on = [], False
    for l in out.splitlines():
        if l.split()[:1] == ["Step"]:
            on = True
            continue
        if on:
            if l.startswith("Loop time"):
                break
            rows.append(l.split())
    return rows


def same(lmp):
    ok = True
    for scene in SCENES:
        for style, args in STYLES.items():
            res = {}
            for tag, st in (("stock", style), ("gpu", style + "/gpu")):
                wd = os.path.join("dem_same", scene, style.replace("/", "_"), tag)
                rc, out = run([lmp], wd, script(scene, st, args))
                if rc != 0 or "ERROR" in out:
                    print("FAIL %s %s: rc %d\n%s" % (scene, st, rc, out[-1500:]))
                    return False
                res[tag] = (load_dump(os.path.join(wd, "final.dump")), thermo(out))
            a, b = res["stock"][0], res["gpu"][0]
            worst, moved = 0.0, 0.0
            for k in range(1, 10):
                scale = max(abs(r[k]) for r in a) or 1e-300
                worst = max(worst, max(abs(r[k] - q[k]) for r, q in zip(a, b)) / scale)
            th_same = res["stock"][1] == res["gpu"][1]
            # the scene must have had contacts: the kinetic energy changed
            th = res["stock"][1]
            nz = len(th) > 1 and float(th[0][1]) != float(th[-1][1])
            status = worst < 1e-12 and th_same and nz and len(a) == len(b)
            print("%-8s %-20s %2d grains: max |difference| / magnitude %.3g; thermo identical: %s%s" %
                  (scene, style, len(a), worst, th_same, "" if status else "  <-- FAIL"))
            ok &= status
    return ok


def errors(lmp, mpirun=None):
    ok = True
    base = script("headon", "gran/hertz/history/gpu", "{args}")
    cases = [("2e7 NULL 5e3 NULL 0.5 1 tangential", "unsupported argument 'tangential'"),
             ("2e7 NULL 5e3 NULL 0.5 2", "dampflag 0 or 1"),
             ("2e7 NULL 5e3 NULL 0.5", "expected Kn Kt")]
    for k, (args, want) in enumerate(cases):
        rc, out = run([lmp], os.path.join("dem_err", str(k)), base.replace("{args}", args))
        good = rc != 0 and "ERROR" in out and want in out
        print("bad arguments '%s': %s" % (args, "stops naming it" if good else "FAIL\n" + out[-800:]))
        ok &= good
    if mpirun:
        rc, out = run([mpirun, "-np", "2", "--oversubscribe", "--allow-run-as-root", lmp], os.path.join("dem_err", "mpi"),
                      script("headon", "gran/hertz/history/gpu", STYLES["gran/hertz/history"]))
        good = rc != 0 and "one MPI rank only" in out
        print("2 MPI ranks: %s" % ("stops naming it" if good else "FAIL\n" + out[-800:]))
        ok &= good
    return ok


def example(lmp, inp):
    outs = {}
    for tag, style in (("stock", "gran/hertz/history"), ("gpu", "gran/hertz/history/gpu")):
        wd = os.path.join("dem_example", tag)
        os.makedirs(wd, exist_ok=True)
        env = dict(os.environ)
        env.setdefault("OMP_NUM_THREADS", "1")
        p = subprocess.run([lmp, "-in", os.path.abspath(inp), "-var", "style", style, "-var", "steps", "20000",
                            "-log", "log.test"], cwd=wd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           timeout=240)
        out = p.stdout.decode(errors="replace")
        if p.returncode != 0 or "ERROR" in out:
            print("FAIL %s: rc %d\n%s" % (style, p.returncode, out[-1500:]))
            return False
        outs[tag] = thermo(out)
    ok = outs["stock"] == outs["gpu"] and len(outs["stock"]) >= 3
    print("dem_drop, 20000 steps: %d thermo rows, identical: %s" % (len(outs["stock"]), ok))
    if not ok:
        for a, b in zip(outs["stock"], outs["gpu"]):
            print(" ".join(a), "|", " ".join(b))
    return ok


if __name__ == "__main__":
    mode = sys.argv[1]
    if mode == "same":
        sys.exit(0 if same(sys.argv[2]) else 1)
    if mode == "example":
        sys.exit(0 if example(sys.argv[2], sys.argv[3]) else 1)
    if mode == "errors":
        sys.exit(0 if errors(sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None) else 1)
    print(__doc__)
    sys.exit(2)
