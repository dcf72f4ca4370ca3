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
# threads: the cores this process may use, capped by a cgroup CPU quota (containers, CI runners), where
# nproc reports the host's cores and surplus OpenMP threads would spin at barriers
cpus=$(nproc)
if [ -r /sys/fs/cgroup/cpu.max ]; then
  read -r quota period < /sys/fs/cgroup/cpu.max || true
  if [ "${quota:-max}" != max ] && [ "${period:-0}" -gt 0 ]; then
    q=$(( (quota + period - 1) / period ))
    [ "$q" -ge 1 ] && [ "$q" -lt "$cpus" ] && cpus=$q
  fi
fi
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-$cpus}"
echo "== running examples/dambreak2d/in.dambreak2d with lmp_sphdem ($OMP_NUM_THREADS threads)"
"$root/build/src_fix/lmp_sphdem" -in "$root/examples/dambreak2d/in.dambreak2d" -log log.lammps -screen none
grep -m1 "Fix sph/fluid:" log.lammps || true
py=/usr/bin/python3   # Debian's python3-numpy / python3-matplotlib live there
"$py" "$root/examples/dambreak2d/plot.py" front.dat -o front.png
"$py" "$root/tools/dump2vtk.py" 'dump.dambreak2d.*' -o vtk >/dev/null
"$py" "$root/tools/render_snapshot.py" 'dump.dambreak2d.*' --step last -o snapshot.png >/dev/null
echo "== done: $out/front.png (front vs Martin & Moyce), $out/snapshot.png, $out/vtk/ (open the .pvd in ParaView), $out/log.lammps"
