#!/usr/bin/env bash
# gpu_check.sh - (bench/gpu/) GPU verification on a machine with an NVIDIA GPU: every unit/verification test
# on the CUDA backend, the CPU-vs-CUDA twin tests under compute-sanitizer memcheck and racecheck (and the fluid's
# two-rank exchange test under memcheck), the 3D
# dam-break, CFD and DEM benchmarks, and (with the packed engines) the coupled drum benchmark.
#   usage: bench/gpu/gpu_check.sh BIN_DIR OUT_DIR [bench sizes...]
# BIN_DIR holds the test binaries and bench_dambreak (built with -DSPHDEM_CUDA=ON): either a build's tests/ folder
# (BUILD/tests, with its CTestTestfile.cmake) or the copy that pack_engines.sh makes (.gpubin/). OUT_DIR gets one
# log per step (OUT_DIR/logs.tgz). Each step has its own time limit; a failing step does not stop the others.
# The part "tests" is `ctest -L gpu -LE twin` in a build's tests/ folder (the gpu_<name> registrations of
# tests/CMakeLists.txt: every unit and verification test on the CUDA backend; the twins have their own part);
# in a .gpubin/ copy it runs each unit_*/verify_* binary with SPHDEM_TEST_DEVICE=gpu. SPHDEM_REQUIRE_GPU=1 is set:
# a test that finds no usable GPU fails here instead of skipping.
# Environment:
#   GPU_CHECK_PARTS     which parts, in this order (default: "twins tests mpi bench cfd dem drum"); the twins come
#                       first because they are what a short GPU run must not miss; mpi runs the engines' rank
#                       tests on the GPU with the packed launchers and mpirun (orterun)
#   GPU_CHECK_DEADLINE  seconds after the start past which no new step starts (default 540, for a machine that
#                       stops a command at 600 s); the steps left out are listed as "skipped (deadline)"
#   GPU_CHECK_ENGINES   the packed engines (default: .englibs next to BIN_DIR) for the drum part
set -u
BIN=${1:?bin dir}; OUT=${2:?out dir}; shift 2
SIZES=${*:-1e5 1e6}
PARTS=${GPU_CHECK_PARTS:-twins tests mpi bench cfd dem drum}
DEADLINE=${GPU_CHECK_DEADLINE:-540}
ENG=${GPU_CHECK_ENGINES:-$(dirname "$BIN")/.englibs}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
export PATH=$PATH:/usr/local/cuda/bin
[ -d "$BIN/reference" ] && export SPHDEM_REFERENCE_DIR=${SPHDEM_REFERENCE_DIR:-$BIN/reference}
export SPHDEM_REQUIRE_GPU=1
mkdir -p "$OUT"; LOGS=$OUT; OUT=$OUT/logs; mkdir -p "$OUT"
T0=$(date +%s)
step() { # name limit command...
  local name=$1 lim=$2; shift 2
  local left=$((DEADLINE - ($(date +%s) - T0)))
  if [ "$left" -le 0 ]; then printf "%-28s skipped (deadline)\n" "$name"; return; fi
  [ "$lim" -gt "$left" ] && lim=$left
  local t0=$(date +%s.%N)
  timeout "$lim" "$@" >"$OUT/$name.log" 2>&1; local rc=$?
  printf "%-28s rc=%-3s %6.1fs  %s\n" "$name" "$rc" "$(awk -v a="$(date +%s.%N)" -v b="$t0" "BEGIN{print a-b}")" "$(tail -1 "$OUT/$name.log")"
}
has() { case " $PARTS " in *" $1 "*) return 0;; esac; return 1; }
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
for part in $PARTS; do
  case $part in
  twins)
    for t in "$BIN"/twin_*; do
      n=$(basename "$t")
      (cd "$OUT" && step "$n" 300 "$t")
      (cd "$OUT" && step "memcheck_$n" 150 compute-sanitizer --tool memcheck --leak-check full "$t")
      (cd "$OUT" && step "racecheck_$n" 150 compute-sanitizer --tool racecheck "$t")
    done
    # two ranks as threads on one GPU: the device gathers of the boundary rows and scatters into the ghost slots
    [ -x "$BIN/unit_fluid_comm" ] && (cd "$OUT" && step memcheck_unit_fluid_comm 150 env SPHDEM_TEST_DEVICE=gpu \
      compute-sanitizer --tool memcheck --leak-check full "$BIN/unit_fluid_comm") ;;
  tests)
    if [ -f "$BIN/CTestTestfile.cmake" ]; then
      step ctest_gpu "$DEADLINE" ctest --test-dir "$BIN" -L gpu -LE twin --output-on-failure --timeout 300 \
        -j "${GPU_CHECK_JOBS:-4}"
      grep -E "tests passed|Failed|\*\*\*" "$OUT/ctest_gpu.log" 2>/dev/null
    else
      for t in "$BIN"/unit_* "$BIN"/verify_*; do
        (cd "$OUT" && step "$(basename "$t")" 300 env SPHDEM_TEST_DEVICE=gpu "$t")
      done
    fi ;;
  bench)
    for n in $SIZES; do
      step "bench3d_gpu_$n" 300 "$BIN/bench_dambreak" --dim 3 --device gpu --n "$n" --steps 200 --warmup 20
      grep BENCH "$OUT/bench3d_gpu_$n.log"
      # the float pair terms (fix sph/fluid precision mixed / single) beside double
      for prec in mixed single; do
        step "bench3d_gpu_${prec}_$n" 300 "$BIN/bench_dambreak" --dim 3 --device gpu --n "$n" --steps 200 --warmup 20 \
          --precision $prec
        grep BENCH "$OUT/bench3d_gpu_${prec}_$n.log"
      done
      # multiphase: two phases without (mp 1) and with (mp 2) the delta-plus terms
      for mp in 1 2; do
        step "bench3d_gpu_mp${mp}_$n" 300 "$BIN/bench_dambreak" --dim 3 --device gpu --n "$n" --steps 100 --warmup 10 --mp $mp
        grep BENCH "$OUT/bench3d_gpu_mp${mp}_$n.log"
      done
    done ;;
  cfd) # CFD-DEM gas grid + DEM, GPU and CPU side by side
    [ -x "$BIN/cfd_bench" ] && for n in 100000 1000000; do
      step "cfd_gpu_$n" 300 "$BIN/cfd_bench" --n "$n" --device gpu --steps 50 --warmup 10
      step "cfd_cpu_$n" 300 "$BIN/cfd_bench" --n "$n" --device cpu --steps 10 --warmup 5 --threads 16
    done ;;
  dem) # the DEM contacts alone
    [ -x "$BIN/bench_dem" ] && for n in 10000 100000 1000000; do
      for algo in pair particle; do
        step "dem_gpu_${algo}_$n" 300 "$BIN/bench_dem" --n "$n" --device gpu --algo "$algo" --steps 200 --warmup 20
      done
      step "dem_cpu_$n" 300 "$BIN/bench_dem" --n "$n" --device cpu --threads 1 --steps 20 --warmup 5
    done ;;
  drum) # coupled drum at 100-400 mm: fluid and coupling on the GPU, the DEM pair style on the GPU too
    if [ -x "$ENG/run.sh" ] && command -v python3 >/dev/null; then
      printf '#!/bin/sh\nexec "%s" lmp_sphdem "$@"\n' "$ENG/run.sh" > "$OUT/lmp_gpu.sh"; chmod +x "$OUT/lmp_gpu.sh"
      step drum_gpu 400 python3 "$ROOT/bench/drum_bench.py" --exe "$OUT/lmp_gpu.sh" --steps 200 \
        --var lmppair gran/hertz/history/gpu --out "$LOGS/drum_gpu"
      step drum_gpu_cpupair 400 python3 "$ROOT/bench/drum_bench.py" --exe "$OUT/lmp_gpu.sh" --steps 200 \
        --out "$LOGS/drum_gpu_cpupair"
    else
      echo "drum: no packed engines at $ENG (bash bench/gpu/pack_engines.sh) or no python3: skipped"
    fi ;;
  mpi) # several ranks sharing the GPU: the engine rank tests through the packed launchers and mpirun (every style's
       # device is auto, so each rank takes the GPU); each compares 2 and 4 ranks with 1, as in ctest
    if [ -x "$ENG/run.sh" ] && [ -x "$ENG/orterun" ] && command -v python3 >/dev/null; then
      W=$(mktemp -d /tmp/gpu_mpi.XXXX)
      printf '#!/bin/sh\nexec "%s" lmp_sphdem "$@"\n' "$ENG/run.sh" > "$W/lmp_gpu.sh"
      printf '#!/bin/sh\nexec "%s" liggghts_sphdem "$@"\n' "$ENG/run.sh" > "$W/liggghts_gpu.sh"
      printf '#!/bin/sh\nexec "%s" orterun "$@"\n' "$ENG/run.sh" > "$W/mpirun_gpu.sh"
      chmod +x "$W"/*.sh
      T=$ROOT/tests/engine
      (cd "$W" && step mpi_fluid_tworuns 120 python3 "$T/test_fluid_mpi.py" tworuns "$W/lmp_gpu.sh" lammps "$W/mpirun_gpu.sh")
      for t in ranks couple dambreak3d; do
        (cd "$W" && step "mpi_fluid_$t" 300 python3 "$T/test_fluid_mpi.py" "$t" "$W/lmp_gpu.sh" lammps "$W/mpirun_gpu.sh" \
          "$ROOT/examples")
      done
      (cd "$W" && step mpi_cfd_bed 300 python3 "$T/test_cfd_engine.py" mpi_bed "$W/lmp_gpu.sh" lammps "$W/mpirun_gpu.sh")
      (cd "$W" && step mpi_dem_lammps 300 python3 "$T/test_dem_mpi.py" lammps "$W/mpirun_gpu.sh" "$W/lmp_gpu.sh")
      (cd "$W" && step mpi_dem_liggghts 300 python3 "$T/test_dem_mpi.py" liggghts "$W/mpirun_gpu.sh" "$W/liggghts_gpu.sh")
      # which device each run took, and the ranks' GPU mapping
      grep -rhoE "(Fix sph/fluid|Fix cfd/grid): [A-Z]+ backend|Pair [^:]+: sphdem DEM core on the [A-Z]+|rank 0 -> .*" \
        "$W" 2>/dev/null |
        sort | uniq -c | head -20 > "$OUT/mpi_devices.log"
      cat "$OUT/mpi_devices.log"
      rm -rf "$W"
    else
      echo "mpi: no packed engines with orterun at $ENG (bash bench/gpu/pack_engines.sh) or no python3: skipped"
    fi ;;
  *) echo "unknown part '$part' (parts: twins tests mpi bench cfd dem drum)" ;;
  esac
done
ls "$OUT"/twin_*.log >/dev/null 2>&1 && tail -n 4 "$OUT"/twin_*.log
(cd "$LOGS" && tar czf logs.tgz logs && rm -rf logs)
