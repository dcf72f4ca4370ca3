#!/usr/bin/env bash
# compare_builds.sh - every example, shortened, through the launchers of two builds: thermo output at full
# precision every 10 steps, compared line by line. For changes that must keep the numbers (restructures).
#   usage: scripts/compare_builds.sh BUILD_A BUILD_B [example:steps ...]
# BUILD_A/B are build folders with src_fix/lmp_sphdem and src_fix/liggghts_sphdem. Prints per example and
# launcher "identical", or the first differing thermo line and the largest relative difference.
set -u
A=${1:?build A}; B=${2:?build B}; shift 2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
LIST=${*:-dambreak2d:300 hydrostatic:300 dambreak3d:20 settling:40 dambreak_particles:20 drum:20 bubbling_bed:100
       spout_bed:20 static_tank:300 poiseuille2phase:300 debris_flow:50 dem_drop:2000}
W=$(mktemp -d)
rc=0
for item in $LIST; do
  ex=${item%%:*}; n=${item##*:}
  for eng in lmp_sphdem liggghts_sphdem; do
    inp=$ROOT/examples/$ex/in.$ex
    [ $eng = liggghts_sphdem ] && [ -f "$inp.liggghts" ] && inp=$inp.liggghts
    [ -f "$inp" ] || { echo "$ex: no input $inp"; continue; }
    for side in A B; do
      b=$A; [ $side = B ] && b=$B
      d=$W/$ex.$eng.$side; mkdir -p "$d"
      sed -E "s/^run[[:space:]]+\S+.*/thermo_modify format float %.16g\nthermo 10\nrun $n/" "$inp" > "$d/in.x"
      sed -i -E '/^dump|^dump_modify/d' "$d/in.x"
      (cd "$d" && OMP_NUM_THREADS=1 timeout 900 "$b/src_fix/$eng" -in in.x -log log.x -screen none > /dev/null 2>&1)
      awk '/^ *Step/{on=1; print; next} /^Loop time/{on=0} on && $1 ~ /^[0-9]+$/' "$d/log.x" > "$d/thermo.x"
    done
    a=$W/$ex.$eng.A/thermo.x; bb=$W/$ex.$eng.B/thermo.x
    if [ ! -s "$a" ] || [ ! -s "$bb" ]; then echo "$ex $eng: no thermo output (A $(wc -l < "$a"), B $(wc -l < "$bb") lines)"; rc=1; continue; fi
    if cmp -s "$a" "$bb"; then echo "$ex $eng: identical ($(wc -l < "$a") thermo lines)"; continue; fi
    # the speed column of fix sph/fluid (f_ID[4], particle-steps per wall-clock second) is not compared
    # (LIGGGHTS writes its header without the f_), nor the engine's own timing columns
    speed=$(awk '$1 == "fix" && $4 == "sph/fluid" {printf "f_%s[4] %s[4] ", $2, $2}' "$inp")
    speed="$speed CPU Cpu T/CPU S/CPU CPULeft"
    python3 - "$a" "$bb" "$ex $eng" "$speed" <<'PY' || rc=1
import sys
la = [l.split() for l in open(sys.argv[1])]; lb = [l.split() for l in open(sys.argv[2])]
skip = set(sys.argv[4].split())
worst, first, col, head = 0.0, None, "", []
for i, (x, y) in enumerate(zip(la, lb)):
    if x and x[0] == "Step":
        head = x
        continue
    for k, (u, v) in enumerate(zip(x, y)):
        name = head[k] if k < len(head) else str(k)
        if name in skip: continue
        try: fu, fv = float(u), float(v)
        except ValueError: continue
        d = abs(fu - fv) / max(abs(fu), abs(fv), 1e-300)
        if d > 0 and first is None: first = i
        if d > worst: worst, col = d, name
if first is None and len(la) == len(lb):
    print("%s: identical (%d thermo lines; not compared: %s)" % (sys.argv[3], len(la), " ".join(sorted(skip)) or "-"))
    sys.exit(0)
print("%s: differs from thermo line %s on, largest relative difference %.3e in %s (%d vs %d lines)" %
      (sys.argv[3], first, worst, col, len(la), len(lb)))
sys.exit(1)
PY
  done
done
rm -rf "$W"
exit $rc
