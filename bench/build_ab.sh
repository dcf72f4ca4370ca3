#!/bin/bash
# build_ab.sh - one LAMMPS input run by several builds' lmp_sphdem on NP ranks in interleaved rounds (each build in
# turn, then again), so that a busy moment of a shared machine hits every build alike; prints the best and the
# median loop time of each build, and the median of the last "Fix sph/fluid timing" transfer value.
#   bash bench/build_ab.sh NP ROUNDS INPUT BUILD [BUILD ...] [-- ENGINE ARGS]
# e.g. bash bench/build_ab.sh 2 8 examples/dambreak2d/in.dambreak2d build /tmp/build-old -- -var nres 80
# The input runs in its own folder (outputs go there); extra engine arguments follow "--".
set -e
np=$1; reps=$2; in=$(realpath "$3"); shift 3
builds=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do builds+=("$(realpath "$1")"); shift; done
[ "${1:-}" = "--" ] && shift
[ ${#builds[@]} -gt 0 ] || { sed -n '2,7p' "$0"; exit 2; }
export OMP_NUM_THREADS=1
out=$(mktemp -d)
for i in $(seq "$reps"); do
  k=0
  for b in "${builds[@]}"; do
    k=$((k + 1))
    (cd "$(dirname "$in")" && mpirun --allow-run-as-root --oversubscribe -np "$np" "$b/src_fix/lmp_sphdem" \
       -in "$(basename "$in")" -log none -echo none "$@" 2>&1) > "$out/log"
    grep "Loop time" "$out/log" | tail -1 | sed 's/Loop time of \([0-9.]*\).*/\1/' >> "$out/loop$k"
    grep "Fix sph/fluid timing" "$out/log" | tail -1 | sed 's/.*transfer \([0-9.e+-]*\).*/\1/' >> "$out/xfer$k"
  done
done
summary() { sort -g "$1" | awk '{a[NR]=$1} END{if (NR) printf "best %.4g median %.4g n %d", a[1], a[int((NR+1)/2)], NR}'; }
k=0
for b in "${builds[@]}"; do
  k=$((k + 1))
  echo "$b: loop $(summary "$out/loop$k"); transfer $(summary "$out/xfer$k")"
done
uptime
rm -rf "$out"
