#!/usr/bin/python3
"""dem_statistics.py - long runs of the DEM statistics scenes: the /gpu pair styles against the stock run-to-run spread.

The scenes, runs and statistics of tests/engine/test_dem_statistics.py (stock S0, stock displaced by 1e-15 d with
four seeds S1..S4, the /gpu style G, a control C with friction 0.3), run longer and larger than ctest does. Prints,
per scene, each statistic averaged over the second half of the run: S0, the spread max |Si - S0|, |G - S0|,
|C - S0|, the bound 2 x spread + floor and the ratio |G - S0| / spread; then the load average.

  python3 bench/dem_statistics.py [--build build] [--engines lammps,liggghts] [--scale 3] [--out bench/out]

--scale multiplies the steps of the short runs (the grains stay as in ctest, the pours' sizes x 2).
A benchmark of accuracy: it prints numbers and exits 0 whatever they are.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests", "engine"))
import benchlib  # noqa: E402
import test_dem_statistics as T  # noqa: E402

EXE = {"lammps": "lmp_sphdem", "liggghts": "liggghts_sphdem"}


def main():
    ap = benchlib.parser(__doc__)
    ap.add_argument("--engines", default="lammps,liggghts")
    ap.add_argument("--scale", type=int, default=3)
    a = ap.parse_args()
    print("load average before: %.2f %.2f %.2f" % os.getloadavg())
    for engine in a.engines.split(","):
        exe = os.path.abspath(os.path.join(a.build, "src_fix", EXE[engine]))
        table = {}
        for name, (size, n1, n2, every) in T.SHORT[engine].items():
            if name == "pour":
                size = 2 * size
            table[name] = (size, n1, a.scale * (n1 + n2) - n1, a.scale * every)
        for name, params in table.items():
            got = T.scene_runs(exe, engine, name, params, os.path.join(a.out, "dem_statistics"), timeout=3600)
            if got is None:
                continue
            good, control, shift = T.compare(engine, name, *got)
            res = got[0]
            worst = max((abs(res["G"][k] - res["S0"][k]) / max(abs(res[r][k] - res["S0"][k]) for r in T.PERTURBED))
                        for k in res["S0"] if max(abs(res[r][k] - res["S0"][k]) for r in T.PERTURBED) > 0) \
                if any(max(abs(res[r][k] - res["S0"][k]) for r in T.PERTURBED) > 0 for k in res["S0"]) else 0.0
            print("%s %s (%s steps): /gpu within 2 x spread: %s; control outside: %s; worst |G - S0| / spread %.2f; "
                  "S1 vs S0 decorrelated to %.3g d" % (engine, name, params[1] + params[2], good, control, worst, shift))
    print("load average after: %.2f %.2f %.2f" % os.getloadavg())
    return 0


if __name__ == "__main__":
    sys.exit(main())
