#!/usr/bin/env bash
# build.sh - configure and build sphdem into ./build (CUDA backend when nvcc is found; SPHDEM_CUDA=OFF to skip).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSPHDEM_CUDA="${SPHDEM_CUDA:-AUTO}" >build.log 2>&1 || { cat build.log; exit 1; }
cmake --build build -j"$(nproc)" >>build.log 2>&1 || { tail -50 build.log; exit 1; }
grep -E "sphdem: CUDA backend" build.log || true
