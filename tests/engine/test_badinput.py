#!/usr/bin/env python3
"""test_badinput.py - malformed input per style: a table of variants, each run through a launcher.

  test_badinput.py STYLE EXE ENGINE
    STYLE  fluid | couple | cfd | probe | gran_gpu | gran_hertz_history_gpu | gran_hooke_history_gpu
  test_badinput.py failure_dump EXE ENGINE   (see test_failure_dump: blow-ups leave a dump file named in the error)
    EXE    lmp_sphdem or liggghts_sphdem;  ENGINE  lammps | liggghts

Every variant changes one thing of a small scene that runs (missing / non-finite / negative / zero / huge
values, unknown and duplicate keywords, wrong / empty / overlapping groups, 2D/3D mismatch, atoms outside the
box, coincident atoms, corrupted restart records) and asserts:
  - the launcher exits with a code > 0 that is not a signal (no 134/136/137/139, no negative code),
  - within the timeout (no hang),
  - one ERROR line holds every expected word (the keyword and the allowed values or the cause).
A 'warn' variant is legitimate input the style cannot refuse (grains inserted later into an empty group): the
run ends normally and a WARNING line holds the words. A variant that one engine cannot express lists that
engine in 'skip' with the reason (printed).
The pair styles exist in one engine each (gran/gpu: LIGGGHTS; gran/hertz|hooke/history/gpu: LAMMPS).
Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import engine_test as E  # noqa: E402  (the dam-break scenes and the run helper)
import test_cfd_engine as C  # noqa: E402  (the gas column)

TIMEOUT = 60
LOST = ("LIGGGHTS drops atoms that leave a non-periodic box without a message (its thermo_modify lost default); "
        "the engine, not the style, decides")
SIGNALS = (124, 134, 136, 137, 139)


class V:
    """one variant: name, a change of the base script, the words of the ERROR (or WARNING) line"""

    def __init__(self, name, change, words, kind="error", skip=None, base=None, pre=None):
        self.name, self.change, self.words, self.kind = name, change, words, kind
        self.skip = skip or {}   # engine -> reason
        self.base = base         # a different base script (function of the engine), else the style's
        self.pre = pre           # (script function of the engine, corrupt(workdir)) run before the variant


def R(*pairs):
    """replace old by new in the base script; every old must occur (else the variant proves nothing)"""
    def f(s):
        for old, new in zip(pairs[::2], pairs[1::2]):
            if old not in s:
                raise ValueError("the base script has no %r" % old)
            s = s.replace(old, new, 1)
        return s
    return f


def corrupt_record(path, ncol_plus_1, bad):
    """replace the length field (a double ncol+1) of every per-atom record of a fix in a binary restart file"""
    data = open(path, "rb").read()
    old, new = struct.pack("d", float(ncol_plus_1)), struct.pack("d", float(bad))
    n = data.count(old)
    if n == 0:
        raise ValueError("no record length %d in %s" % (ncol_plus_1, path))
    open(path, "wb").write(data.replace(old, new))
    return n


# ---- fix sph/fluid: the tiny 2D dam break (engine_test.py) ---------------------------------------------------
def fluid_base(engine):
    return E.scene(engine, steps=2)


FLUID_FIX = "fix water fluid sph/fluid rho0 1000 h 0.013 c0 15 "
# fix sph/fluid's per-atom record: 17 columns + the length
FLUID_REC = 18


def fluid_restart_write(engine):
    return E.scene(engine, steps=2).replace("run 2\n", "run 2\nwrite_restart bad.restart\n")


def fluid_restart_read(engine):
    return ("read_restart bad.restart\ntimestep 1e-4\n" + E.NEIGH + E.FIX.format(extra="") + "run 1\n")


def shift_x(script, x0):
    """the scene moved by x0 along x: every region's x bounds (the dam break far from the origin)"""
    import re
    return re.sub(r"(region \w+ block) (\S+) (\S+) ",
                  lambda m: "%s %.17g %.17g " % (m.group(1), float(m.group(2)) + x0, float(m.group(3)) + x0), script)


FLUID = [
    V("missing c0", R("c0 15 ", ""), ["missing required keyword(s): c0"]),
    V("rho0 nan", R("rho0 1000", "rho0 nan"), ["rho0 expects a number, got 'nan'"]),
    V("h inf", R("h 0.013", "h inf"), ["h expects a number, got 'inf'"]),
    V("rho0 negative", R("rho0 1000", "rho0 -1000"), ["rho0", "must be > 0", "-1000"]),
    V("c0 zero", R("c0 15", "c0 0"), ["c0", "must be > 0"]),
    V("h huge", R("h 0.013", "h 1e300"), ["h", "1e+300"]),
    V("h wider than the box", R("h 0.013", "h 0.5"), ["h 0.5", "kernel support 2h exceeds the box"]),
    V("rho0 huge", R("rho0 1000", "rho0 1e300"), ["rho0", "particle mass", "dx"]),
    V("cfl above 1", lambda s: s.replace("wall walls", "cfl 2 wall walls"), ["cfl must be in (0, 1]"]),
    V("unknown keyword", lambda s: s.replace("wall walls", "bogus 1 wall walls"),
      ["unknown keyword 'bogus'", "keywords are rho0, h, c0"]),
    V("duplicate keyword", lambda s: s.replace("wall walls", "c0 20 wall walls"), ["c0", "given twice"]),
    V("missing value", lambda s: s.replace("hydrostatic 0.2", "hydrostatic 0.2 every"),
      ["missing value(s) for every", "every N"]),
    V("wall group missing", R("wall walls", "wall nosuch"), ["wall group 'nosuch' does not exist"]),
    V("wall group = fluid group", R("wall walls", "wall fluid"), ["wall group must differ from the fluid group"]),
    V("wall group overlaps fluid", R("wall walls", "wall all"), ["wall group all overlaps the fluid group fluid"]),
    V("empty fluid group", R("fix water fluid", "group none subtract all all\nfix water none"),
      ["fluid group none has no atoms"]),
    V("gravity along z in 2D", R("gravity 0 -9.81 0", "gravity 0 0 -9.81"),
      ["gravity", "z", "2D", "dimension 2"]),
    V("2D scene as 3D", R("dimension 2", "dimension 3", "lattice sq", "lattice sc"), ["periodic box length", "axis z", "3 (2h + skin)"]),
    V("coincident fluid atoms", R("group fluid type 1", "create_atoms 1 single 0.035 0.035 0 units box\n"
                                  "group fluid type 1"),
      ["fluid particles closer than 0.5 dx", "atoms 1 and 487"]),
    V("fluid atom on a wall atom", R("group fluid type 1", "create_atoms 1 single 0.005 0.005 0 units box\n"
                                     "group fluid type 1"),
      ["closer than 0.5 dx", "fluid atom 487", "wall atom 205"]),
    V("atom outside the box", R("timestep 1e-4", "timestep 1e-4\nset atom 1 x 0.5"), ["Lost atoms"],
      skip={"liggghts": LOST}),
    V("visc morris negative", R("visc artificial 0.05", "visc morris -1e-3"), ["visc morris", "mu > 0"]),
    V("every zero", lambda s: s.replace("wall walls", "every 0 wall walls"),
      ["every expects an integer N >= 1, got '0'"]),
    V("precision unknown", lambda s: s.replace("wall walls", "precision half wall walls"),
      ["precision must be double, mixed or single", "half"]),
    V("precision single far from the origin", lambda s: shift_x(s, 1e4).replace("wall walls", "precision single wall walls"),
      ["precision single", "float spacing", "precision mixed"]),
    V("failure_dump bad value", lambda s: s.replace("wall walls", "failure_dump maybe wall walls"),
      ["failure_dump must be yes, no or a file name", "maybe"]),
    V("corrupted restart record", lambda s: s, ["restart record of atom", "18"], base=fluid_restart_read,
      pre=(fluid_restart_write, lambda wd: corrupt_record(os.path.join(wd, "bad.restart"), FLUID_REC, 5))),
]


# ---- fix sph/couple: the dam break with 6 grains (engine_test.py) ---------------------------------------------
def couple_base(engine):
    return E.couple_scene(engine, steps=2)


COUPLE_REC = 14  # fix sph/couple's per-atom record: 13 columns + the length


def couple_restart_write(engine):
    return E.couple_scene(engine, steps=2).replace("run 2\n", "run 2\nwrite_restart bad.restart\n")


def couple_restart_read(engine):
    return ("read_restart bad.restart\ntimestep 5e-5\n" + E.NEIGH + E.COUPLE_FIX.format(extra="") + "run 1\n")


CPL = "sph/couple water mu 1e-3 "
COUPLE = [
    V("drag unknown", R(CPL, CPL + "drag foo "), ["drag must be ergun-wenyu, difelice, schiller-naumann or none",
                                                  "'foo'"]),
    V("mu nan", R("mu 1e-3", "mu nan"), ["mu expects a number, got 'nan'"]),
    V("mu negative", R("mu 1e-3", "mu -1"), ["mu must be > 0 (got -1)"]),
    V("mu huge", R("mu 1e-3", "mu 1e300"), ["mu 1e+300", "relaxation time", "fluid step"]),
    V("hc zero", R(CPL, CPL + "hc 0 "), ["hc must be > 0 (got 0)"]),
    V("hc huge", R(CPL, CPL + "hc 1e300 "), ["hc 1e+300", "box"]),
    V("eps_min above 1", R(CPL, CPL + "eps_min 1.5 "), ["eps_min must be in (0, 1) (got 1.5)"]),
    V("unknown keyword", R(CPL, CPL + "bogus 1 "), ["unknown keyword 'bogus'", "keywords are drag, mu, hc"]),
    V("duplicate keyword", R(CPL, CPL + "mu 2e-3 "), ["mu", "given twice"]),
    V("missing value", R(CPL, CPL + "dmax"), ["missing value for dmax (usage: dmax V)"]),
    V("fluid fix missing", R("sph/couple water", "sph/couple nosuch"), ["fix ID 'nosuch' does not exist"]),
    V("not a fluid fix", R("sph/couple water", "sph/couple grav"), ["fix 'grav' is not a fix sph/fluid"]),
    V("grains overlap the fluid group", R("fix couple grains", "fix couple moving"),
      ["grain group moving overlaps the fluid or wall group"]),
    V("two couplers", R("fix grav grains", "fix couple2 grains sph/couple water mu 1e-3\nfix grav grains"),
      ["already coupled by another fix sph/couple"]),
    V("empty grain group", R("fix couple grains", "group none subtract all all\nfix couple none",
                             "fix grav grains", "fix grav none", "fix nvs grains", "fix nvs none"),
      ["grain group none has no atoms"], kind="warn"),
    V("immersion above 1", R(CPL, CPL + "immersion 2 "), ["immersion must be in [0, 1]"]),
    V("no viscosity", R("sph/couple water mu 1e-3", "sph/couple water"),
      ["needs the fluid viscosity: give mu V, or use visc morris MU"]),
    V("grain outside the box", R("group grains type 3", "set atom 487 x 0.5\ngroup grains type 3"), ["Lost atoms"],
      skip={"liggghts": LOST}),
    V("corrupted restart record", lambda s: s, ["restart record of atom", "14"], base=couple_restart_read,
      pre=(couple_restart_write, lambda wd: corrupt_record(os.path.join(wd, "bad.restart"), COUPLE_REC, 3))),
]


# ---- fix cfd/grid: the gas column (test_cfd_engine.py) --------------------------------------------------------
def cfd_base(engine):
    return C.column(engine, [(0.0015, 0.0015, 0.005), (0.0015, 0.0015, 0.007)], steps=2)


GASKW = "bc yhi slip "


def gas(extra):
    return R(GASKW, GASKW + extra + " ")


def cfd_restart_write(engine):
    return cfd_base(engine).replace("run 2\n", "run 2\nwrite_restart bad.restart\n")


def cfd_restart_read(engine):
    return ("read_restart bad.restart\ntimestep 1e-4\nneighbor 1e-4 bin\n" +
            C.GAS.format(nx=3, ny=3, nz=10, bc=C.BC_COLUMN, extra="") + "run 1\n")


def cfd_state_size(nx=3, ny=3, nz=10):
    return (nx + 1) * ny * nz + nx * (ny + 1) * nz + nx * ny * (nz + 1) + 2 * nx * ny * nz


CFD = [
    V("missing grid", R("grid 3 3 10 ", ""), ["missing required keyword(s): grid"]),
    V("rho nan", R("rho 1.2", "rho nan"), ["rho expects a number, got 'nan'"]),
    V("mu inf", R("mu 1.8e-5", "mu inf"), ["mu expects a number, got 'inf'"]),
    V("rho negative", R("rho 1.2", "rho -1.2"), ["rho must be > 0 (got -1.2)"]),
    V("grid zero cells", R("grid 3 3 10", "grid 3 0 10"), ["grid expects an integer >= 1, got '0'"]),
    V("rho huge", R("rho 1.2", "rho 1e300"), ["rho 1e+300", "grain density"]),
    V("mu huge", R("mu 1.8e-5", "mu 1e300"), ["mu 1e+300", "relaxation time", "gas step"]),
    V("grid huge", R("grid 3 3 10", "grid 2000 2000 2000"), ["8000000000 cells exceed the limit"]),
    V("unknown keyword", gas("bogus 1"), ["unknown keyword 'bogus'", "keywords are grid, box, rho"]),
    V("duplicate keyword", gas("rho 1.5"), ["rho", "given twice"]),
    V("duplicate bc side", gas("bc yhi noslip"), ["bc yhi", "given twice"]),
    V("bc unknown type", gas("bc xlo wall"), ["bc xlo: TYPE must be noslip, slip, inlet U", "'wall'"]),
    V("missing value", gas("maxiter"), ["missing value(s) for maxiter"]),
    V("no outlet", R("bc zhi outlet", "bc zhi slip"), ["no side is an outlet"]),
    V("gas box outside the domain", gas("box 0 0.003 0 0.003 0.002 0.012"),
      ["box", "outside the simulation box", "z"]),
    V("empty grain group", R("fix gas all", "group none subtract all all\nfix gas none"),
      ["grain group none has no atoms"], kind="warn"),
    V("two gas fixes on the same grains", R("fix grav all", "fix gas2 all cfd/grid grid 3 3 10 rho 1.2 mu 1.8e-5 "
                                            + C.BC_COLUMN + "\nfix grav all"),
      ["fix gas2", "cfd/grid", "same grains", "twice"]),
    V("periodic box with gas walls", R("boundary f f f", "boundary p f f"),
      ["periodic", "x", "gas"]),
    # a valid 2D box (z straddles 0, as current LAMMPS requires), grains in the plane, gravity along -y
    V("2D run", R("units si", "units si\ndimension 2", "boundary f f f", "boundary f f p",
                  "0 0.003 0 0.003 0 0.01 units box", "0 0.003 0 0.01 -0.0005 0.0005 units box",
                  "0.0015 0.0015 0.005 units box", "0.0015 0.005 0 units box",
                  "0.0015 0.0015 0.007 units box", "0.0015 0.007 0 units box",
                  "vector 0 0 -1", "vector 0 -1 0"),
      ["3D", "dimension 2"]),
    V("grain outside the box", R("create_atoms 1 single 0.0015 0.0015 0.007 units box",
                                 "create_atoms 1 single 0.0015 0.0015 0.007 units box\nset atom 2 z 0.02"),
      ["Lost atoms"], skip={"liggghts": LOST}),
    V("corrupted restart state count", lambda s: s, ["restart", "gas state", str(cfd_state_size())],
      base=cfd_restart_read,
      pre=(cfd_restart_write, lambda wd: corrupt_record(os.path.join(wd, "bad.restart"), cfd_state_size(), 1e15))),
]


# ---- compute sph/probe on the dam break ----------------------------------------------------------------------
def probe_script(args, extra=""):
    def f(engine):
        return (E.HEAD + E.CREATE + E.NEIGH + E.FIX.format(extra="") + extra +
                "compute p all sph/probe %s\nthermo_style custom step c_p[1][1]\nrun 0\n" % args)
    return f


def probe_base(engine):
    return probe_script("water 0.09 0.1 0")(engine)


def probe_file(name, text):
    def f(s):
        with open(name, "w") as fh:
            fh.write(text)
        return s.replace("water 0.09 0.1 0", "water file " + os.path.abspath(name))
    return f


USAGE = "usage: compute ID group sph/probe FLUID-FIX-ID x y z"
PROBE = [
    V("missing fix ID", R("sph/probe water 0.09 0.1 0", "sph/probe"), ["missing the ID of the fix sph/fluid", USAGE]),
    V("fix does not exist", R("water 0.09", "nosuch 0.09"), ["fix ID 'nosuch' does not exist"]),
    V("not a fluid fix", R("water 0.09", "nothing 0.09"), ["fix 'nothing' is not a fix sph/fluid"],
      base=probe_script("water 0.09 0.1 0", "fix nothing walls setforce 0 0 0\n")),
    V("coordinate not a number", R("0.09 0.1 0", "0.09 abc 0"), ["point coordinate 'abc' is not a number"]),
    V("coordinate nan", R("0.09 0.1 0", "nan 0.1 0"), ["point coordinate 'nan' is not a number"]),
    V("coordinate inf", R("0.09 0.1 0", "0.09 0.1 inf"), ["point coordinate 'inf' is not a number"]),
    V("not a triple", R("0.09 0.1 0", "0.09 0.1"), ["point coordinates must come in x y z triples"]),
    V("no points", R("water 0.09 0.1 0", "water"), ["no probe points given"]),
    V("file without name", R("water 0.09 0.1 0", "water file"), ["file needs a file name"]),
    V("file missing", R("water 0.09 0.1 0", "water file nosuch.txt"), ["cannot open point file 'nosuch.txt'"]),
    V("file with a bad line", probe_file("bad_points.txt", "0.09 0.1 0\n0.09 x 0\n"),
      ["each line of the point file needs x y z"]),
    V("empty file", probe_file("empty_points.txt", "# nothing\n"), ["no probe points given"]),
    V("point outside the box", R("0.09 0.1 0", "0.09 0.5 0"), ["point 1", "outside the simulation box", "y"]),
    V("point huge", R("0.09 0.1 0", "1e300 0.1 0"), ["point 1", "outside the simulation box", "x"]),
    V("point negative outside", R("0.09 0.1 0", "0.09 0.1 0 -0.1 0.1 0"), ["point 2", "outside the simulation box"]),
    V("point z off the 2D plane", R("0.09 0.1 0", "0.09 0.1 0.5"), ["point 1", "outside the simulation box", "z"]),
    V("arguments after the file", lambda s: probe_file("ok_points.txt", "0.09 0.1 0\n")(s) + "",
      ["unexpected arguments after the point file"],
      base=lambda engine: probe_script("water 0.09 0.1 0 extra")(engine)),
]


# ---- pair styles -------------------------------------------------------------------------------------------
LMP_DEM = """units si
atom_style sphere
boundary f f f
atom_modify map array
comm_modify vel yes
region box block -0.05 0.05 -0.05 0.05 -0.05 0.05 units box
create_box 1 box
create_atoms 1 single -0.00505 0 0 units box
create_atoms 1 single 0.00505 0 0 units box
set atom * diameter 0.01
set atom * density 2500
pair_style STYLE ARGS
pair_coeff * *
neighbor 0.001 bin
neigh_modify delay 0 every 1 check yes
fix 1 all nve/sphere
timestep 1e-6
run 10
"""
HERTZ_ARGS = "2e7 NULL 5e3 NULL 0.5 1"


def lmp_pair_table(style):
    base = lambda engine: LMP_DEM.replace("STYLE", style).replace("ARGS", HERTZ_ARGS)
    pre = "Pair %s: " % style
    return base, [
        V("too few arguments", R(HERTZ_ARGS, "2e7 NULL 5e3"), [pre + "expected", "got 3 arguments"]),
        V("Kn not a number", R("2e7 NULL", "abc NULL"), ["Kn 'abc' is not a number"]),
        V("Kn nan", R("2e7 NULL", "nan NULL"), ["Kn 'nan' is not a number"]),
        V("gamma_n inf", R("5e3 NULL", "inf NULL"), ["gamma_n 'inf' is not a number"]),
        V("Kn negative", R("2e7 NULL", "-2e7 NULL"), ["illegal value", "Kn, Kt, gamma_n, gamma_t >= 0"]),
        V("Kt negative", R("2e7 NULL", "2e7 -1"), ["illegal value", "Kn, Kt, gamma_n, gamma_t >= 0"]),
        V("gamma_t negative", R("5e3 NULL", "5e3 -1"), ["illegal value", "gamma_t >= 0"]),
        V("xmu negative", R("0.5 1", "-0.5 1"), ["illegal value", "0 <= xmu <= 10000"]),
        V("xmu huge", R("0.5 1", "1e300 1"), ["illegal value", "0 <= xmu <= 10000"]),
        V("dampflag 2", R("0.5 1", "0.5 2"), ["illegal value", "dampflag 0 or 1"]),
        V("dampflag not an integer", R("0.5 1", "0.5 1.5"), ["dampflag '1.5' is not an integer"]),
        V("unknown argument", R(HERTZ_ARGS, HERTZ_ARGS + " bogus"), ["unsupported argument 'bogus'"]),
        V("device unknown", R(HERTZ_ARGS, HERTZ_ARGS + " device tpu"), ["device must be auto, cpu or gpu",
                                                                       "'tpu'"]),
        V("algo unknown", R(HERTZ_ARGS, HERTZ_ARGS + " algo foo"), ["algo must be pair or particle", "'foo'"]),
        V("timers bad value", R(HERTZ_ARGS, HERTZ_ARGS + " timers maybe"), ["timers must be on or off"]),
        V("keyword without value", R(HERTZ_ARGS, HERTZ_ARGS + " device"), ["unsupported argument 'device'"]),
        V("pair_coeff extra values", R("pair_coeff * *", "pair_coeff * * 1.0"), ["pair_coeff takes only the two type"]),
        V("no per-atom radius", R("atom_style sphere", "atom_style atomic", "set atom * diameter 0.01\n"
                                  "set atom * density 2500", "mass 1 1e-3", "fix 1 all nve/sphere", "fix 1 all nve"),
          ["requires atom attributes radius, rmass, omega, torque"]),
        V("atom outside the box", R("timestep 1e-6", "set atom 1 x 0.5\ntimestep 1e-6"), ["Lost atoms"]),
        V("coincident grains", R("create_atoms 1 single 0.00505 0 0", "create_atoms 1 single -0.00505 0 0"),
          ["grains 1 and 2 are at the same position"]),
    ]


LIG_DEM = """units si
atom_style granular
boundary f f f
newton off
atom_modify map array
communicate single vel yes
region box block -0.05 0.05 -0.05 0.05 -0.05 0.05 units box
create_box 1 box
neighbor 0.001 bin
neigh_modify delay 0
""" + E.lig_materials() + """fix m5 all property/global coefficientRollingFriction peratomtypepair 1 0.05
fix m6 all property/global characteristicVelocity scalar 0.8
pair_style gran/gpu ARGS
pair_coeff * *
create_atoms 1 single -0.00505 0 0 units box
create_atoms 1 single 0.00505 0 0 units box
set atom * diameter 0.01
set atom * density 2500
fix 1 all nve/sphere
timestep 1e-6
run 10
"""
LIG_ARGS = "model hertz tangential history"


def lig_base(engine):
    return LIG_DEM.replace("ARGS", LIG_ARGS)


GRAN_GPU = [
    V("model missing", R(LIG_ARGS, "tangential history"), ["needs 'model hertz', 'model hooke' or 'model hooke/hysteresis'"]),
    V("model unknown", R("model hertz", "model hooke/stiffness"), ["model 'hooke/stiffness' is not supported",
                                                                   "hertz, hooke or hooke/hysteresis"]),
    V("tangential missing", R(LIG_ARGS, "model hertz"), ["needs 'tangential history'"]),
    V("tangential unknown", R("tangential history", "tangential no_history"),
      ["tangential 'no_history' is not supported (only history)"]),
    V("ktToKnUser with hertz", R(LIG_ARGS, LIG_ARGS + " ktToKnUser on"), ["ktToKnUser is a keyword of model hooke"]),
    V("ktToKnUser bad value", R(LIG_ARGS, "model hooke tangential history ktToKnUser yes"),
      ["ktToKnUser must be on or off", "'yes'"]),
    V("rolling_friction unknown", R(LIG_ARGS, LIG_ARGS + " rolling_friction epsd3"),
      ["rolling_friction 'epsd3' is not supported (cdt, epsd, epsd2 or off)"]),
    V("limitForce bad value", R(LIG_ARGS, LIG_ARGS + " limitForce 1"), ["limitForce must be on or off", "'1'"]),
    V("cohesion", R(LIG_ARGS, LIG_ARGS + " cohesion washino/capillary/viscous"),
      ["cohesion 'washino/capillary/viscous' is not supported (sjkr, sjkr2 or off)"]),
    V("surface", R(LIG_ARGS, LIG_ARGS + " surface superquadric"), ["surface 'superquadric' is not supported"]),
    V("device unknown", R(LIG_ARGS, LIG_ARGS + " device tpu"), ["device must be auto, cpu or gpu", "'tpu'"]),
    V("algo unknown", R(LIG_ARGS, LIG_ARGS + " algo foo"), ["algo must be pair or particle", "'foo'"]),
    V("keyword without value", R(LIG_ARGS, LIG_ARGS + " timers"), ["keyword 'timers' needs a value"]),
    V("unknown keyword", R(LIG_ARGS, LIG_ARGS + " bogus 1"), ["unsupported keyword 'bogus'"]),
    V("material missing", R("fix m1 all property/global youngsModulus peratomtype 5e6\n", ""),
      ["youngsModulus"]),
    V("youngsModulus negative", R("youngsModulus peratomtype 5e6", "youngsModulus peratomtype -5e6"),
      ["youngsModulus", "must be > 0"]),
    V("poissonsRatio above 0.5", R("poissonsRatio peratomtype 0.45", "poissonsRatio peratomtype 0.7"),
      ["poissonsRatio", "outside [0, 0.5]"]),
    V("coefficientRestitution above 1", R("coefficientRestitution peratomtypepair 1 0.7",
                                          "coefficientRestitution peratomtypepair 1 1.5"),
      ["coefficientRestitution", "outside [0, 1]"]),
    V("coefficientFriction negative", R("coefficientFriction peratomtypepair 1 0.5",
                                        "coefficientFriction peratomtypepair 1 -0.5"),
      ["coefficientFriction", "must be >= 0"]),
    V("atom outside the box", R("timestep 1e-6", "set atom 1 x 0.5\ntimestep 1e-6"), ["Lost atoms"],
      skip={"liggghts": LOST}),
    V("coincident grains", R("create_atoms 1 single 0.00505 0 0", "create_atoms 1 single -0.00505 0 0"),
      ["grains 1 and 2 are at the same position"]),
    V("fix multisphere", R("fix 1 all nve/sphere", "fix ms all multisphere"),
      ["multisphere", "not supported"]),
]


# ---- a run that blows up keeps the evidence (fix sph/fluid keyword failure_dump) ---------------------------------
TOOLS = os.path.join(HERE, "..", "..", "tools")


def error_line(out):
    return next((l for l in out.splitlines() if "ERROR" in l), "")


class Dump:
    """the last snapshot of a dump custom text file: step, columns, rows (lists of floats)"""

    def __init__(self, path):
        lines = open(path).read().splitlines()
        i = max(k for k, l in enumerate(lines) if l.startswith("ITEM: TIMESTEP"))
        self.step = int(lines[i + 1])
        j = next(k for k in range(i, len(lines)) if lines[k].startswith("ITEM: ATOMS"))
        self.columns = lines[j].split()[2:]
        self.rows = [[float(w) for w in l.split()] for l in lines[j + 1:] if l.strip()]

    def col(self, name):
        c = self.columns.index(name)
        return [r[c] for r in self.rows]


def python_with_numpy():
    """tools/dump2vtk.py needs numpy: this interpreter, else the system one"""
    import subprocess
    for py in (sys.executable, "/usr/bin/python3"):
        if os.path.exists(py) and subprocess.run([py, "-c", "import numpy"], stderr=subprocess.DEVNULL).returncode == 0:
            return py
    return sys.executable


def test_failure_dump(exe, engine):
    """Blow-up scenes of the dam break (and the coupled one): the error names the failure dump, the dump holds
    every atom with id type x y z vx vy vz density pressure porosity, tools/dump2vtk.py converts it; failure_dump
    no writes nothing; failure_dump FILE writes FILE. Also the messages: a too-low c0 names the c0 that would do,
    a time step just above the stable one is printed with the digits that tell them apart."""
    import re
    import subprocess
    ok = E.Checks(tail=6)

    root = "failure_dump_" + engine
    # (1) the time step becomes unstable as the column collapses (2e-4 s is stable at the start, not at step 400)
    unstable = E.scene(engine, steps=400).replace("timestep 1e-4", "timestep 2e-4")
    # (2) a blow-up between two checks (check 0: only at the end of the run): the regular message at the next
    # re-neighbouring, never the internal one of the upload
    between = E.scene(engine, steps=2000).replace("timestep 1e-4", "timestep 8e-4").replace(
        "wall walls", "cfl 1 check 0 wall walls")
    # (3) the coupled scene: grains in the dump too
    coupled = E.couple_scene(engine, steps=2000).replace("timestep 5e-5", "timestep 4e-4").replace(
        "wall walls", "cfl 1 check 0 wall walls")
    for name, script, natoms in (("unstable", unstable, 486), ("between", between, None), ("coupled", coupled, None)):
        wd = os.path.join(root, name)
        rc, out = E.run([exe], wd, script, timeout=TIMEOUT)
        line = error_line(out)
        m = re.search(r"is in (sphdem_failure\.(\d+)\.dump) \(tools/dump2vtk.py converts it", line)
        if not ok(rc > 0 and rc not in SIGNALS and m, "%s: the error names the failure dump (%s)" % (name, line[:160]),
                  out):
            continue
        ok("set_fluid" not in line, "%s: the regular blow-up message, not the upload's" % name, out)
        path = os.path.join(wd, m.group(1))
        snap = Dump(path) if os.path.exists(path) else None
        cols = "id type x y z vx vy vz density pressure porosity".split()
        good = snap is not None and snap.columns == cols and snap.step == int(m.group(2))
        if good and natoms:
            good = len(snap.rows) == natoms
        if not ok(good, "%s: %s holds %s atoms with columns %s" % (name, m.group(1),
                                                                   len(snap.rows) if snap else 0, cols)):
            continue
        types = set(int(t) for t in snap.col("type"))
        rho = [r for t, r in zip(snap.col("type"), snap.col("density")) if t == 1]
        finite = [r for r in rho if r == r and abs(r) != float("inf")]
        ok(finite and max(finite) > 0, "%s: fluid densities written (%d of %d finite)" % (name, len(finite), len(rho)))
        if name == "coupled":
            g = [r for t, r in zip(snap.col("type"), snap.col("density")) if t == 3]
            ok(len(g) >= 1 and all(abs(r - 2500) < 1 for r in g) and 2 in types,
               "coupled: the grains still in the box (%d of 6, material density 2500) and the walls are in the dump"
               % len(g))
        vtk = os.path.join(wd, "vtk")
        p = subprocess.run([python_with_numpy(), os.path.join(TOOLS, "dump2vtk.py"), path, "-o", vtk],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        made = sorted(os.listdir(vtk)) if os.path.isdir(vtk) else []
        ok(p.returncode == 0 and any(f.endswith(".vtk") for f in made) and any(f.endswith(".vtp") for f in made),
           "%s: tools/dump2vtk.py converts it (%s)" % (name, ", ".join(made)), p.stdout.decode(errors="replace"))
    # (4) grains that go non-finite (an infinite force from fix addforce): the coupling stops through the fluid
    # fix's failure dump
    wd = os.path.join(root, "grains")
    rc, out = E.run([exe], wd, E.couple_scene(engine, steps=20).replace(
        "fix grav grains", "variable big equal 1e300*1e300\nfix kick grains addforce v_big 0 0\nfix grav grains"),
        timeout=TIMEOUT)
    line = error_line(out)
    m = re.search(r"Fix sph/couple: set_grains at step \d+: .*non-finite.*is in (sphdem_failure\.\d+\.dump) \(", line)
    ok(rc > 0 and rc not in SIGNALS and m and os.path.exists(os.path.join(wd, m.group(1))),
       "grains blown up: the coupling's error names the failure dump (%s)" % line[:160], out)
    # failure_dump no: the same message without a file; failure_dump FILE
    for kw, want in (("failure_dump no", None), ("failure_dump blowup.dump", "blowup.dump")):
        wd = os.path.join(root, kw.replace(" ", "_").replace(".", "_"))
        rc, out = E.run([exe], wd, unstable.replace("wall walls", kw + " wall walls"), timeout=TIMEOUT)
        line = error_line(out)
        files = sorted(f for f in os.listdir(wd) if "failure" in f or f.endswith(".dump"))
        if want is None:
            ok(rc > 0 and "exceeds the stable SPH time step" in line and "failure dump" not in line.lower()
               and "is in " not in line and not files, "failure_dump no: the message, no file (%s)" % files, out)
        else:
            ok(rc > 0 and ("is in %s (" % want) in line and files == [want], "%s: writes %s (%s)" % (kw, want, files),
               out)
    # the messages: c0 too low on a static column (vmax 0) names the c0 that would do
    wd = os.path.join(root, "c0")
    rc, out = E.run([exe], wd, E.scene(engine, steps=10).replace("c0 15", "c0 4").replace(
        "hydrostatic 0.2", "hydrostatic 0.2 rho_err_max 0.01"), timeout=TIMEOUT)
    line = error_line(out)
    m = re.search(r"so c0 4 would need about ([0-9.e+]+) to stay below rho_err_max", line)
    ok(rc > 0 and m and float(m.group(1)) > 4, "c0 too low: the message names the c0 that would do (%s)" %
       (m.group(1) if m else line[:200]), out)
    # a time step just above the stable one (2.1666...e-4 s): the two printed values differ, the suggestion passes
    wd = os.path.join(root, "dt")
    rc, out = E.run([exe], wd, E.scene(engine, steps=10).replace("timestep 1e-4", "timestep 0.00021666667"),
                    timeout=TIMEOUT)
    line = error_line(out)
    m = re.search(r"time step (\S+) s exceeds the stable SPH time step (\S+) s.*Set the timestep to (\S+) or less",
                  line)
    good = rc > 0 and m and m.group(1) != m.group(2) and float(m.group(3)) <= float(m.group(2)) < float(m.group(1))
    ok(good, "dt above the stable step: printed %s" % (str(m.groups()) if m else line[:200]), out)
    if good:
        # the set-up check (run 0) accepts it; the flow then speeds up and lowers the stable step
        rc, out = E.run([exe], wd + "_suggested", E.scene(engine, steps=0).replace("timestep 1e-4",
                                                                                  "timestep " + m.group(3)),
                        timeout=TIMEOUT)
        ok(rc == 0, "the suggested time step %s passes the set-up check" % m.group(3), out)
    print("failure_dump (%s): %d failed" % (engine, ok.fails))
    return 1 if ok.fails else 0


def tables(style):
    if style == "fluid":
        return fluid_base, FLUID, ("lammps", "liggghts")
    if style == "couple":
        return couple_base, COUPLE, ("lammps", "liggghts")
    if style == "cfd":
        return cfd_base, CFD, ("lammps", "liggghts")
    if style == "probe":
        return probe_base, PROBE, ("lammps", "liggghts")
    if style == "gran_gpu":
        return lig_base, GRAN_GPU, ("liggghts",)
    if style in ("gran_hertz_history_gpu", "gran_hooke_history_gpu"):
        base, rows = lmp_pair_table(style.replace("_", "/"))
        return base, rows, ("lammps",)
    raise SystemExit("unknown style %s" % style)


def verdict(v, rc, out):
    """(ok, what was seen)"""
    crashed = rc < 0 or rc in SIGNALS or "Segmentation" in out or "Aborted" in out or "terminate called" in out
    tag = "WARNING" if v.kind == "warn" else "ERROR"
    lines = [l for l in out.splitlines() if tag in l]
    hit = [l for l in lines if all(w in l for w in v.words)]
    if v.kind == "warn":
        ok = rc == 0 and bool(hit) and not crashed
    else:
        ok = rc > 0 and not crashed and bool(hit)
    shown = (hit or lines or ["(no %s line)" % tag])[0].strip()
    return ok, "exit %d%s, %s" % (rc, " (signal/timeout)" if crashed else "", shown[:240])


def main(argv):
    if len(argv) != 4:
        print(__doc__)
        return 2
    style, exe, engine = argv[1], argv[2], argv[3]
    if style == "failure_dump":
        return test_failure_dump(exe, engine)
    base, rows, engines = tables(style)
    if engine not in engines:
        print("%s is not a style of %s" % (style, engine))
        return 2
    root = "badinput_%s_%s" % (style, engine)
    os.makedirs(root, exist_ok=True)
    fails, ran = 0, 0
    for i, v in enumerate(rows):
        if engine in v.skip:
            print("SKIP %-34s (%s: %s)" % (v.name, engine, v.skip[engine]))
            continue
        wd = os.path.join(root, "%02d" % i)
        os.makedirs(wd, exist_ok=True)
        cwd = os.getcwd()
        try:
            if v.pre:
                rc, out = E.run([exe], wd, v.pre[0](engine), timeout=TIMEOUT)
                if rc != 0:
                    raise ValueError("the run before the variant failed (exit %d): %s" % (rc, out[-800:]))
                v.pre[1](wd)
            os.chdir(wd)  # point files of the probe variants are written beside the run
            try:
                script = v.change((v.base or base)(engine))
            finally:
                os.chdir(cwd)
        except ValueError as e:
            print("FAIL %-34s cannot build the variant: %s" % (v.name, e))
            fails += 1
            continue
        rc, out = E.run([exe], wd, script, timeout=TIMEOUT)
        ok, seen = verdict(v, rc, out)
        ran += 1
        print("%s %-34s %s" % ("PASS" if ok else "FAIL", v.name, seen))
        if not ok:
            print("     expected %s line with: %s" % ("a WARNING" if v.kind == "warn" else "an ERROR", v.words))
            print("     " + "\n     ".join(out.splitlines()[-8:]))
            fails += 1
    print("%s: %d variants run through %s, %d failed" % (style, ran, engine, fails))
    return 1 if fails or ran < 15 else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
