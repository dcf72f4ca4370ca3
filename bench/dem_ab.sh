#!/bin/bash
# dem_ab.sh - the loop time of the stock granular style and of one or more builds' /gpu style, on NP ranks,
# in interleaved rounds (stock, then each build in turn), so that a busy moment of a shared machine hits every code
# alike; prints the best and the median of each. The inputs are those dem_bench.py --workdir writes (in.bench of a
# stock and of a /gpu run of the same scene; LIGGGHTS where the folder's name begins with liggghts_).
#   bash bench/dem_ab.sh NP ROUNDS STOCK_INPUT GPU_INPUT BUILD [BUILD ...]
# e.g. bash bench/dem_ab.sh 2 12 wd/lammps_pour_0_1/in.bench wd/lammps_pour_0_3/in.bench build /tmp/build-old
set -e
np=$1; reps=$2; sin=$(realpath "$3"); gin=$(realpath "$4"); shift 4
[ -n "$1" ] || { sed -n '2,7p' "$0"; exit 2; }
builds=()
for b in "$@"; do builds+=("$(realpath "$b")"); done
set -- "${builds[@]}"
export OMP_NUM_THREADS=1
case "$(basename "$(dirname "$sin")")" in
  liggghts_*) stock_exe=${LIGGGHTS_EXE:-liggghts}; ours_exe=liggghts_sphdem ;;
  *) stock_exe=${LAMMPS_EXE:-lmp}; ours_exe=lmp_sphdem ;;
esac
out=$(mktemp -d)
run() { mpirun --allow-run-as-root --oversubscribe -np "$np" "$@" -log none -echo none 2>&1 | grep "Loop time" |
        sed 's/Loop time of \([0-9.]*\).*/\1/'; }
for i in $(seq "$reps"); do
  (cd "$(dirname "$sin")" && run "$stock_exe" -in "$(basename "$sin")") >> "$out/stock"
  k=0
  for b in "$@"; do
    k=$((k + 1))
    (cd "$(dirname "$gin")" && run "$b/src_fix/$ours_exe" -in "$(basename "$gin")") >> "$out/build$k"
  done
done
summary() { sort -g "$1" | awk '{a[NR]=$1} END{printf "best %.3f median %.3f n %d\n", a[1], a[int((NR+1)/2)], NR}'; }
echo "stock: $(summary "$out/stock")"
k=0
for b in "$@"; do k=$((k + 1)); echo "$b: $(summary "$out/build$k")"; done
uptime
rm -rf "$out"
