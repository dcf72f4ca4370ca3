#!/usr/bin/python3
"""mpi_counts.py - the work each MPI rank does, counted in instructions (valgrind's callgrind), at 1 and N ranks.

Wall-clock scaling on a shared 2-core machine says more about the other jobs than about the code. Instructions
do not depend on the load: this script runs the scenes of bench/mpi_scaling.py (same inputs: the example, the
timed run shortened, `balance` on several ranks) under `valgrind --tool=callgrind`, one profile per rank, and
splits each rank's instructions into
    MPI    : the MPI library and its transports (libmpi, libopen-pal, libopen-rte, mca_*): sending, and spinning
             while a rank waits for another one (this part grows with any imbalance and with descheduling)
    work   : everything else (the engine, the styles, the core's passes)
and prints, per rank count, each rank's work, its share of the 1-rank work, the work efficiency
W1 / (N max_r W_r) (the parallel efficiency the code would reach on idle cores if instructions were time), and
the inclusive counts of the main passes (rate pass, wall pass, coupling, the exchanges, the ghost updates).

  /usr/bin/python3 bench/mpi_counts.py BUILD [--scenes dambreak2d_80,settling] [--ranks 1,2] [--steps N]
A benchmark: prints numbers, asserts nothing. Under callgrind a run is ~50x slower: the timed run is shortened
(--steps, default 100).
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import mpi_scaling as ms  # noqa: E402  (scenes, inputs, commands)

MPI_OBJ = re.compile(r"(libmpi|libopen-pal|libopen-rte|mca_|libpmix|libevent|libhwloc)")
PASSES = ["sphdem_compute_rates", "cpu_rates_sym", "sphdem_cpu_wall_state", "couple_prepare", "couple_finish",
          "sphdem_exchange_fluid", "sphdem_exchange_walls", "sphdem_update_ghosts", "sphdem_get_fluid"]


def profile(path):
    """(total, mpi, {pass: inclusive}) of one callgrind file"""
    ex = subprocess.run(["callgrind_annotate", "--threshold=100", path], stdout=subprocess.PIPE, text=True).stdout
    total, mpi = 0, 0
    for ln in ex.splitlines():
        m = re.match(r"^\s*([0-9,]+)\s+\(\s*[0-9.]+%\)\s+(.*)$", ln)
        if not m:
            continue
        n = int(m.group(1).replace(",", ""))
        if "PROGRAM TOTALS" in m.group(2):
            total = n
            continue
        obj = re.search(r"\[([^\]]*)\]\s*$", m.group(2))
        if obj and MPI_OBJ.search(os.path.basename(obj.group(1))):
            mpi += n
    inc = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", path], stdout=subprocess.PIPE,
                         text=True).stdout
    passes = {}
    for ln in inc.splitlines():
        m = re.match(r"^\s*([0-9,]+)\s+\(\s*[0-9.]+%\)\s+\?\?\?:(\S+)", ln)
        if m:
            name = m.group(2)
            for p in PASSES:
                if name == p or name.startswith(p + "."):
                    passes[p] = max(passes.get(p, 0), int(m.group(1).replace(",", "")))
    return total, mpi, passes


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("--scenes", default="dambreak2d_80,settling")
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--workdir", default=None)
    a = ap.parse_args()
    a.quick, a.dx3d = False, 0.008
    build = os.path.abspath(a.build)
    wd0 = a.workdir or tempfile.mkdtemp(prefix="mpi_counts_")
    commit = subprocess.run(["git", "-C", ms.ROOT, "rev-parse", "--short", "HEAD"], stdout=subprocess.PIPE,
                            text=True).stdout.strip()
    print("# mpi_counts.py, commit %s, load average %s, OMP_NUM_THREADS=1, %d timed steps, workdir %s" %
          (commit, " ".join(open("/proc/loadavg").read().split()[:3]), a.steps, wd0))
    want = a.scenes.split(",")
    for sc in [s for s in ms.scenes(a) if s["name"] in want]:
        print("\n### %s: %s" % (sc["name"], sc["what"]))
        print("| ranks | rank | instructions | MPI | work | work / 1-rank work | " + " | ".join(PASSES) + " |")
        print("|---" * (6 + len(PASSES)) + "|")
        w1 = None
        for n in [int(x) for x in a.ranks.split(",")]:
            wd = os.path.join(wd0, "%s_np%d" % (sc["name"], n))
            os.makedirs(wd, exist_ok=True)
            with open(os.path.join(wd, "in.run"), "w") as f:
                f.write(ms.with_runs(sc["text"], 5, a.steps, n, sc["dims"], sc.get("weight", "")))
            cmd = ms.scene_cmd(build, sc, n)
            exe_at = next(i for i, w in enumerate(cmd) if w.endswith(sc["exe"]))
            cg = ["valgrind", "--tool=callgrind", "--callgrind-out-file=cg.%q{OMPI_COMM_WORLD_RANK}"]
            cmd = cmd[:exe_at] + cg + cmd[exe_at:] + ["-in", "in.run", "-log", "log.run"]
            env = dict(os.environ, OMP_NUM_THREADS="1")
            if n == 1:  # no mpirun: name the one profile like rank 0's
                env["OMPI_COMM_WORLD_RANK"] = "0"
            for f in os.listdir(wd):
                if f.startswith("cg."):
                    os.remove(os.path.join(wd, f))
            p = subprocess.run(cmd, cwd=wd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            if p.returncode != 0:
                print("| %d | FAILED (rc %d): %s |" % (n, p.returncode, p.stdout[-300:].replace("\n", " ")))
                continue
            rows = [profile(os.path.join(wd, "cg.%d" % r)) for r in range(n)]
            works = [t - m for t, m, _ in rows]
            if n == 1:
                w1 = works[0]
            for r, (t, m, ps) in enumerate(rows):
                print("| %d | %d | %.3g | %.3g | %.3g | %s | %s |" % (
                    n, r, t, m, works[r], "%.2f" % (works[r] / w1) if w1 else "-",
                    " | ".join("%.3g" % ps[k] if k in ps else "-" for k in PASSES)))
            if w1 and n > 1:
                print("| %d | all | | | | work efficiency W1 / (N max W) = %.2f |" % (n, w1 / (n * max(works))) +
                      " |" * (len(PASSES) - 1))


if __name__ == "__main__":
    main()
