#!/usr/bin/env python3
"""test_mpi_runs.py - several `run` commands in one script on two MPI ranks, for each style.

A script usually runs more than once (settle, then the real run; or a run per stage). Every collective call a
style makes at set-up (reductions of warnings, checks, counts) must be made by every rank at every set-up, or
the ranks wait for each other for ever. Each scene below runs `run 10` three times (the second with `pre no`)
at 2 ranks with the subdomain cut through the particles, and passes when the process exits 0 within the time
limit, every one of the three runs printed its `Loop time`, and no ERROR line appeared.

  EXE ENGINE MPIRUN   scenes: fix sph/fluid with walls (the tiny dam break), fix sph/fluid + fix sph/couple
                      (six grains in it), fix cfd/grid (a column of nine grains)
Python 3 only; exits 0 on pass, 1 on failure.
"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import engine_test as et  # noqa: E402
import test_cfd_engine as cfd  # noqa: E402

TIMEOUT = 90  # s; each scene takes 1-3 s on an idle core


def three_runs(script):
    """the script's final `run N` becomes three runs of 10 steps"""
    body = re.sub(r"(?m)^run \d+.*$", "", script)
    return body + "run 10\nrun 10 pre no\nrun 10\n"


def processors(script, grid):
    return re.sub(r"(?m)^(create_box.*)$", "processors %s\n\\1" % grid, script, count=1)


def scenes(engine):
    grains = [(0.0015, 0.0015, 0.001 * (k + 1)) for k in range(9)]
    return [
        ("fluid with walls", processors(et.scene(engine), "2 1 1")),
        ("fluid and coupled grains", processors(et.couple_scene(engine), "2 1 1")),
        ("gas grid", processors(cfd.column(engine, grains, steps=10), "1 1 2")),
    ]


def main():
    exe, engine, mpirun = sys.argv[1], sys.argv[2], sys.argv[3]
    base = os.path.abspath("mpi_runs_" + engine)
    bad = 0
    for k, (name, script) in enumerate(scenes(engine)):
        wd = os.path.join(base, "s%d" % k)
        rc, out = et.run([mpirun, "-np", "2", "--oversubscribe", "--allow-run-as-root", exe], wd,
                         three_runs(script), timeout=TIMEOUT)
        loops = len(re.findall(r"(?m)^Loop time of .* on 2 procs", out))
        ok = rc == 0 and loops == 3 and "ERROR" not in out
        print("%s %s: exit %d, %d of 3 runs finished%s" % ("ok  " if ok else "FAIL", name, rc, loops,
                                                         "" if ok else "\n" + out[-2000:]))
        bad += not ok
    print("PASS" if not bad else "FAIL: %d scene(s)" % bad)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
