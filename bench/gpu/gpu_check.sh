#!/usr/bin/env bash
# gpu_check.sh - (bench/gpu/) GPU verification of the C core on a machine with an NVIDIA GPU (no engines needed):
# every unit/verification test on the CUDA backend, the CPU-vs-CUDA twin test, compute-sanitizer
# memcheck and racecheck on the twin test, and the 3D dam-break benchmark on the GPU.
#   usage: scripts/gpu_check.sh BIN_DIR OUT_DIR [bench sizes...]
# BIN_DIR holds the test binaries and bench_dambreak (built with -DSPHDEM_CUDA=ON), OUT_DIR gets
# one log per step. Each step has its own time limit; a failing step does not stop the others.
set -u
BIN=${1:?bin dir}; OUT=${2:?out dir}; shift 2
SIZES=${*:-1e5 1e6}
export PATH=$PATH:/usr/local/cuda/bin
export SPHDEM_REFERENCE_DIR=${SPHDEM_REFERENCE_DIR:-$BIN/reference}
mkdir -p "$OUT"; LOGS=$OUT; OUT=$OUT/logs; mkdir -p "$OUT"
step() { # name limit command...
  local name=$1 lim=$2; shift 2
  local t0=$(date +%s.%N)
  timeout "$lim" "$@" >"$OUT/$name.log" 2>&1; local rc=$?
  printf "%-28s rc=%-3s %6.1fs  %s\n" "$name" "$rc" "$(awk -v a="$(date +%s.%N)" -v b="$t0" "BEGIN{print a-b}")" "$(tail -1 "$OUT/$name.log")"
}
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
export SPHDEM_TEST_DEVICE=gpu
for t in "$BIN"/unit_* "$BIN"/verify_*; do
  (cd "$OUT" && step "$(basename "$t")" 300 "$t")
done
unset SPHDEM_TEST_DEVICE
for t in "$BIN"/twin_*; do
  n=$(basename "$t")
  (cd "$OUT" && step "$n" 300 "$t")
  (cd "$OUT" && step "memcheck_$n" 150 compute-sanitizer --tool memcheck --leak-check full "$t")
  (cd "$OUT" && step "racecheck_$n" 150 compute-sanitizer --tool racecheck "$t")
done
for n in $SIZES; do
  step "bench3d_gpu_$n" 300 "$BIN/bench_dambreak" --dim 3 --device gpu --n "$n" --steps 200 --warmup 20
  grep BENCH "$OUT/bench3d_gpu_$n.log"
  # multiphase (issue 4): two phases without (mp 1) and with (mp 2) the delta-plus terms
  for mp in 1 2; do
    step "bench3d_gpu_mp${mp}_$n" 300 "$BIN/bench_dambreak" --dim 3 --device gpu --n "$n" --steps 100 --warmup 10 --mp $mp
    grep BENCH "$OUT/bench3d_gpu_mp${mp}_$n.log"
  done
done
# CFD-DEM gas grid + DEM (issue 6) and the DEM contacts alone (issue 5), GPU and CPU side by side
if [ -x "$BIN/cfd_bench" ]; then
  for n in 100000 1000000; do
    step "cfd_gpu_$n" 300 "$BIN/cfd_bench" --n "$n" --device gpu --steps 50 --warmup 10
    step "cfd_cpu_$n" 300 "$BIN/cfd_bench" --n "$n" --device cpu --steps 10 --warmup 5 --threads 16
  done
fi
if [ -x "$BIN/bench_dem" ]; then
  for n in 10000 100000 1000000; do
    for algo in pair particle; do
      step "dem_gpu_${algo}_$n" 300 "$BIN/bench_dem" --n "$n" --device gpu --algo "$algo" --steps 200 --warmup 20
    done
    step "dem_cpu_$n" 300 "$BIN/bench_dem" --n "$n" --device cpu --threads 1 --steps 20 --warmup 5
  done
fi
tail -n 4 "$OUT"/twin_*.log
(cd "$LOGS" && tar czf logs.tgz logs && rm -rf logs)
