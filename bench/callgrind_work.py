#!/usr/bin/env python3
"""callgrind_work.py - instructions of callgrind output files outside the MPI and runtime libraries.

On several ranks the instructions counted inside the MPI library are mostly a rank polling while it waits for
another, which depends on timing; what is left is each rank's own work, comparable between codes. For each file:
total, MPI/runtime (libmpi, libopen-pal, Open MPI components, PMIx, libevent, hwloc, the dynamic loader), work.

    mpirun -np 2 valgrind --tool=callgrind --callgrind-out-file=cg.%q{OMPI_COMM_WORLD_RANK} lmp -in in.x
    python3 bench/callgrind_work.py cg.0 cg.1
"""
import re
import subprocess
import sys

RUNTIME = re.compile(r"libmpi|libopen-pal|libopen-rte|openmpi3|pmix|libevent|libhwloc|ld-linux")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for f in sys.argv[1:]:
        out = subprocess.run(["callgrind_annotate", "--threshold=100", f], capture_output=True, text=True, check=True).stdout
        tot = mpi = 0
        for line in out.split("\n"):
            m = re.match(r"\s*([\d,]+) \(\s*[\d.]+%\)\s+(.*)$", line)
            if not m or "PROGRAM TOTALS" in line:
                continue
            n = int(m.group(1).replace(",", ""))
            tot += n
            if RUNTIME.search(m.group(2)):
                mpi += n
        print(f"{f}: total {tot / 1e6:.1f} M  MPI/runtime {mpi / 1e6:.1f} M  work {(tot - mpi) / 1e6:.1f} M")


if __name__ == "__main__":
    main()
