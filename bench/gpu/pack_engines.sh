#!/usr/bin/env bash
# pack_engines.sh - bundle the Debian-built launchers with every shared library they load (glibc's
# loader included) and the OpenMPI components, into .englibs/ (git-ignored), so that they run on a
# GPU machine that has a driver but none of the Debian packages. Run after scripts/build.sh; carry
# .englibs to the GPU machine and start the launchers with bench/gpu/engine_run.sh.
# Also copies the core's test binaries and bench_dambreak into .gpubin/ for bench/gpu/gpu_check.sh.
set -euo pipefail
cd "$(dirname "$0")/../.."
B=build/src_fix
E=.englibs
rm -rf $E .gpubin && mkdir -p $E/stage/lib $E/stage/root/usr/lib/x86_64-linux-gnu $E/stage/root/usr/share $E/stage/root/etc
grep -qx '/.englibs/' .git/info/exclude 2>/dev/null || echo /.englibs/ >> .git/info/exclude
grep -qx '/.gpubin/' .git/info/exclude 2>/dev/null || echo /.gpubin/ >> .git/info/exclude
libs() { ldd "$@" 2>/dev/null | awk '$3 ~ /^\// {print $3}'; }
{ libs $B/lmp_sphdem $B/liggghts_sphdem /usr/bin/orterun
  libs /usr/lib/x86_64-linux-gnu/openmpi/lib/openmpi3/*.so /usr/lib/x86_64-linux-gnu/pmix2/lib/pmix/*.so
} | grep -v "$B" | sort -u | while read -r f; do cp -L "$f" $E/stage/lib/; done
cp -L /lib64/ld-linux-x86-64.so.2 $E/stage/lib/
cp -a /usr/lib/x86_64-linux-gnu/openmpi /usr/lib/x86_64-linux-gnu/pmix2 $E/stage/root/usr/lib/x86_64-linux-gnu/
cp -a /usr/share/openmpi $E/stage/root/usr/share/ && cp -a /etc/openmpi $E/stage/root/etc/
(cd $E/stage && tar cJf ../englibs.tar.xz lib root) && rm -rf $E/stage
cp $B/lmp_sphdem $B/liggghts_sphdem $B/libsphdem_lammps.so $B/libsphdem_liggghts.so /usr/bin/orterun $E/
cp bench/gpu/engine_run.sh $E/run.sh
mkdir -p .gpubin/reference && cp data/reference/* .gpubin/reference/
cp build/tests/unit_* build/tests/verify_* build/tests/twin_* build/bench/bench_dambreak .gpubin/
for b in bench_dem cfd_bench; do [ -x build/bench/$b ] && cp build/bench/$b .gpubin/; done
du -sh $E .gpubin
