#!/usr/bin/env bash
# demo.sh - quick start, first command: set up, build and run the 2D dam break (Martin & Moyce) through
# lmp_sphdem (GPU when one is usable, else the CPU), then plot the surge front against the experiment,
# write VTK files for ParaView and render a snapshot. Everything lands in demo-output/.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
bash scripts/setup.sh
bash scripts/build.sh
out="$root/demo-output"
rm -rf "$out"
mkdir -p "$out"
cd "$out"
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-$(nproc)}"
echo "== running examples/dambreak2d/in.dambreak2d with lmp_sphdem ($OMP_NUM_THREADS threads)"
"$root/build/src_fix/lmp_sphdem" -in "$root/examples/dambreak2d/in.dambreak2d" -log log.lammps -screen none
grep -m1 "Fix sph/fluid:" log.lammps || true
py=/usr/bin/python3   # Debian's python3-numpy / python3-matplotlib live there
"$py" "$root/examples/dambreak2d/plot.py" front.dat -o front.png
"$py" "$root/tools/dump2vtk.py" 'dump.dambreak2d.*' -o vtk >/dev/null
"$py" "$root/tools/render_snapshot.py" 'dump.dambreak2d.*' --step last -o snapshot.png >/dev/null
echo "== done: $out/front.png (front vs Martin & Moyce), $out/snapshot.png, $out/vtk/ (open the .pvd in ParaView), $out/log.lammps"
