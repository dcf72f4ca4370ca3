#!/usr/bin/python3
"""dem_scenes_speed.py - loop time of the /gpu DEM pair styles against the stock styles on the statistics scenes.

The scenes of tests/engine/test_dem_statistics.py at their ctest sizes, the kinds of the LIGGGHTS tutorials and
LAMMPS granular examples: LAMMPS pour (fix pour), funnel (wall/gran/region cone, discharging), pack (a settling
lattice), shake (a wiggling floor); LIGGGHTS pour (insert/pack), mesh (STL floor, check/timestep/gran), hopper
(STL cone, discharging), shake (fix move/mesh). Each scene runs as the stock style (S0 of the test) and the /gpu
style (G), without the dumps, on one rank and one thread, alternately for --rounds rounds (so that a busy moment
of a shared machine hits both alike). Prints per scene the grains at the end, the best summed loop time of each
and their ratio /gpu / stock; then the load average.

  python3 bench/dem_scenes_speed.py [--build build] [--engines lammps,liggghts] [--rounds 4] [--out bench/out]

A benchmark: it prints numbers and exits 0 whatever they are (1 when a run fails).
"""
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests", "engine"))
import benchlib  # noqa: E402
import test_dem_statistics as T  # noqa: E402

STOCK = {"lammps": os.environ.get("LAMMPS_EXE", "lmp"), "liggghts": os.environ.get("LIGGGHTS_EXE", "liggghts")}
OURS = {"lammps": "lmp_sphdem", "liggghts": "liggghts_sphdem"}


def loop_time(cmd, wd):
    """(summed loop time of the runs, grains at the end) of one input, or None when it fails"""
    p = subprocess.run(cmd, cwd=wd, capture_output=True, text=True, timeout=3600)
    loops = [float(x) for x in re.findall(r"Loop time of ([0-9.eE+-]+)", p.stdout)]
    atoms = re.findall(r"with (\d+) atoms", p.stdout)
    if p.returncode != 0 or not loops:
        sys.stdout.write("run failed in %s (rc %d):\n%s\n" % (wd, p.returncode, (p.stdout + p.stderr)[-1500:]))
        return None
    return sum(loops), int(atoms[-1])


def main():
    ap = benchlib.parser(__doc__)
    ap.add_argument("--engines", default="lammps,liggghts")
    ap.add_argument("--rounds", type=int, default=4)
    a = ap.parse_args()
    env_threads = os.environ.get("OMP_NUM_THREADS")
    os.environ["OMP_NUM_THREADS"] = "1"
    print("dem_scenes_speed: build %s, %d rounds, OMP_NUM_THREADS=1 (was %s), load average before %.2f %.2f %.2f"
          % (a.build, a.rounds, env_threads, *os.getloadavg()))
    print("| engine | scene | grains (end) | stock loop s | /gpu loop s | /gpu / stock |")
    print("|---|---|---|---|---|---|")
    failed = False
    for engine in a.engines.split(","):
        ours = os.path.abspath(os.path.join(a.build, "src_fix", OURS[engine]))
        for name, (size, n1, n2, every) in T.SHORT[engine].items():
            best, grains = {}, 0
            for _ in range(a.rounds):
                for run in ("S0", "G"):
                    wd = os.path.join(a.out, "dem_scenes_speed", "%s_%s_%s" % (engine, name, run))
                    os.makedirs(wd, exist_ok=True)
                    for fn, txt in T.SCENES[engine][name].get("files", {}).items():
                        with open(os.path.join(wd, fn), "w") as f:
                            f.write(txt)
                    text = T.script(engine, name, run, size, n1, n2, every)
                    with open(os.path.join(wd, "in.speed"), "w") as f:
                        f.write("\n".join(l for l in text.split("\n") if not l.startswith("dump")))
                    exe = STOCK[engine] if run == "S0" else ours
                    r = loop_time([exe, "-in", "in.speed", "-log", "none", "-echo", "none"], wd)
                    if r is None:
                        failed = True
                        continue
                    best[run] = min(best.get(run, float("inf")), r[0])
                    grains = r[1]
            if "S0" in best and "G" in best:
                print("| %s | %s | %d | %.3f | %.3f | %.2f |" % (engine, name, grains, best["S0"], best["G"],
                                                                 best["G"] / best["S0"]), flush=True)
    print("load average after: %.2f %.2f %.2f" % os.getloadavg())
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
