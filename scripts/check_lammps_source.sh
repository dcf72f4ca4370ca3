#!/usr/bin/env bash
# check_lammps_source.sh - sphdem against a LAMMPS source tree: builds LAMMPS (shared library, GRANULAR, RIGID +
# PLUGIN, MPI), builds sphdem against it, loads sphdemplugin.so with `plugin load` and LAMMPS_PLUGIN_PATH
# in that LAMMPS' own lmp, checks that all six styles register and run the examples (shortened) with the
# same thermo as lmp_sphdem, that input errors end with exit status 1 and the ERROR line, and runs the
# LAMMPS engine tests with the launcher linked to that LAMMPS.
#
#   scripts/check_lammps_source.sh LAMMPS_SRC
#
# LAMMPS_SRC holds cmake/ and src/ (a git checkout or an unpacked release). GRANULAR and PLUGIN are what
# sphdem needs; RIGID only for the engine test of fix rigid with the /gpu pair styles. Environment:
#   LAMMPS_BUILD   LAMMPS build folder (default LAMMPS_SRC/build; kept: a second run with the same packages
#                  only relinks)
#   SPHDEM_BUILD   sphdem build folder (default build-lammps-src in this repository)
#   SPHDEM_CUDA    AUTO|ON|OFF (default AUTO)      JOBS  parallel build jobs (default: nproc)
#   CTEST_ARGS     which engine tests (default "-L engine -R lammps"; "none" skips them)
#   LAMMPS_COMMIT  the commit to print when LAMMPS_SRC is not a git checkout
#   LAMMPS_PACKAGES  more LAMMPS packages to build (default RIGID; GRANULAR and PLUGIN are always built
#                  "" builds those two only: then the test engine_dem_rigid_lammps fails)
# Exit status: 0 when every check passed; the summary at the end lists each check.
set -uo pipefail
if [ $# -lt 1 ] || [ ! -f "$1/cmake/CMakeLists.txt" ] || [ ! -f "$1/src/version.h" ]; then
  echo "usage: $0 LAMMPS_SRC   (a LAMMPS source tree with cmake/CMakeLists.txt and src/version.h)" >&2
  exit 2
fi
REPO=$(cd "$(dirname "$0")/.." && pwd)
SRC=$(cd "$1" && pwd)
LBUILD=${LAMMPS_BUILD:-$SRC/build}
SBUILD=${SPHDEM_BUILD:-$REPO/build-lammps-src}
JOBS=${JOBS:-$(nproc)}
CTEST_ARGS=${CTEST_ARGS:--L engine -R lammps}
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
FAILS=0
SUMMARY=""
check() { # check NAME STATUS [detail]
  if [ "$2" = 0 ]; then SUMMARY+="PASS  $1${3:+ ($3)}"$'\n'; else SUMMARY+="FAIL  $1${3:+ ($3)}"$'\n'; FAILS=$((FAILS + 1)); fi
  echo "== ${1}: $([ "$2" = 0 ] && echo pass || echo FAIL)${3:+ ($3)}"
}
finish() {
  echo; echo "== summary: LAMMPS ${VERSION:-?} from $SRC${COMMIT:+ (commit $COMMIT)}"; printf '%s' "$SUMMARY"
  echo "== $FAILS check(s) failed"; exit $((FAILS > 0))
}

VERSION=$(sed -n 's/^#define LAMMPS_VERSION "\(.*\)"/\1/p' "$SRC/src/version.h")
UPDATE=$(sed -n 's/^#define LAMMPS_UPDATE "\(.*\)"/\1/p' "$SRC/src/version.h")
[ -n "$UPDATE" ] && VERSION="$VERSION - $UPDATE"
COMMIT=${LAMMPS_COMMIT:-$(git -C "$SRC" rev-parse --short=12 HEAD 2>/dev/null || true)}
echo "== LAMMPS $VERSION in $SRC, build in $LBUILD; sphdem build in $SBUILD"

# 1. LAMMPS: shared library, the packages sphdem needs, MPI; no downloads
mkdir -p "$LBUILD"
PACKAGES=$(echo "GRANULAR PLUGIN ${LAMMPS_PACKAGES-RIGID}" | tr ' ' '\n' | awk 'NF && !seen[$0]++' | tr '\n' ' ')
LCMAKE=(cmake -S "$SRC/cmake" -B "$LBUILD" -DCMAKE_BUILD_TYPE=Release -DBUILD_SHARED_LIBS=on)
for p in $PACKAGES; do LCMAKE+=(-DPKG_$p=on); done
LCMAKE+=(-DBUILD_MPI=on -DBUILD_OMP=on -DLAMMPS_SIZES=smallbig -DDOWNLOAD_POTENTIALS=off -DWITH_JPEG=off -DWITH_PNG=off
         -DWITH_FFMPEG=off)
echo "== ${LCMAKE[*]}"
if "${LCMAKE[@]}" >"$LBUILD/sphdem-cmake.log" 2>&1 && cmake --build "$LBUILD" -j"$JOBS" >"$LBUILD/sphdem-build.log" 2>&1 \
   && [ -f "$LBUILD/liblammps.so" ] && [ -x "$LBUILD/lmp" ]; then
  check "LAMMPS build (shared, packages $PACKAGES)" 0 "$LBUILD/liblammps.so"
else
  tail -n 30 "$LBUILD/sphdem-build.log" "$LBUILD/sphdem-cmake.log" 2>/dev/null
  check "LAMMPS build (shared, packages $PACKAGES)" 1; finish
fi
LMP=$LBUILD/lmp
PKGS=$("$LMP" -h | sed -n '/^Installed packages:/,/^List of individual/p')
MISSING=0
for p in $PACKAGES; do echo "$PKGS" | grep -qw "$p" || MISSING=1; done
check "lmp -h lists $PACKAGES" $MISSING

# 2. sphdem against it
SCMAKE=(cmake -S "$REPO" -B "$SBUILD" -DCMAKE_BUILD_TYPE=Release -DSPHDEM_CUDA="${SPHDEM_CUDA:-AUTO}"
        -DSPHDEM_LAMMPS_INCLUDE_DIR="$SRC/src" -DSPHDEM_LAMMPS_LIBRARY="$LBUILD/liblammps.so")
echo "== ${SCMAKE[*]}"
mkdir -p "$SBUILD"
if "${SCMAKE[@]}" >"$SBUILD/sphdem-cmake.log" 2>&1 && cmake --build "$SBUILD" -j"$JOBS" >"$SBUILD/sphdem-build.log" 2>&1; then
  grep "sphdem:" "$SBUILD/sphdem-cmake.log"
  check "sphdem build" 0
else
  tail -n 40 "$SBUILD/sphdem-cmake.log" "$SBUILD/sphdem-build.log"; check "sphdem build" 1; finish
fi
B=$SBUILD/src_fix
grep -q "building sphdemplugin.so for LAMMPS $VERSION " "$SBUILD/sphdem-cmake.log" &&
  grep -q "building lmp_sphdem and libsphdem_lammps.so against LAMMPS $VERSION " "$SBUILD/sphdem-cmake.log"
check "CMake says launcher and plugin are built for LAMMPS $VERSION" $?
LINKED=$(ldd "$B/lmp_sphdem" | awk '/liblammps/ {print $3}')
[ "$(readlink -f "$LINKED")" = "$(readlink -f "$LBUILD/liblammps.so")" ]
check "lmp_sphdem links this tree's liblammps" $? "$LINKED"

# 3. plugin load in this LAMMPS' own lmp
W=$SBUILD/check_lammps_source
rm -rf "$W" && mkdir -p "$W"
cat >"$W/in.load" <<EOF
plugin load $B/sphdemplugin.so
plugin list
plugin unload fix sph/fluid
plugin list
EOF
(cd "$W" && "$LMP" -in in.load -log none) >"$W/load.out" 2>&1
RC=$?
STYLES=("fix style plugin sph/fluid" "fix style plugin sph/couple" "fix style plugin cfd/grid"
        "compute style plugin sph/probe" "pair style plugin gran/hooke/history/gpu" "pair style plugin gran/hertz/history/gpu")
MISSING=0
for s in "${STYLES[@]}"; do grep -q "$s" "$W/load.out" || { echo "missing: $s"; MISSING=1; }; done
check "plugin load: all six styles registered" $((RC != 0 || MISSING)) "$(grep -c 'style plugin' "$W/load.out") list lines"
! grep -q "compiled for LAMMPS version" "$W/load.out"
check "plugin built for the LAMMPS that loads it (no version warning)" $?
AFTER=$(sed -n '/Unloading fix style sph\/fluid/,$p' "$W/load.out")
echo "$AFTER" | grep -q "sph/couple" && ! echo "$AFTER" | grep -q "fix style plugin sph/fluid"
check "plugin unload fix sph/fluid" $?
mkdir -p "$W/ppath" && cp "$B/sphdemplugin.so" "$W/ppath/"
echo "plugin list" >"$W/in.path"
(cd "$W" && LAMMPS_PLUGIN_PATH="$W/ppath" "$LMP" -in in.path -log none) >"$W/path.out" 2>&1
[ $? = 0 ] && [ "$(grep -c 'style plugin' "$W/path.out")" -ge 6 ]
check "LAMMPS_PLUGIN_PATH loads the plugin" $?

# 4. the examples (shortened) through lmp + plugin load and through lmp_sphdem: the same thermo
# thermo rows without f_water[4] (fix sph/fluid's particle-steps/s, a timing)
thermo_rows() {
  awk '/^ *Step /{on=1; skip=0; for (i = 1; i <= NF; i++) if ($i == "f_water[4]") skip = i; next}
       /^Loop time/{on=0}
       on && $1 ~ /^[0-9]+$/ {if (skip) $skip = ""; print}' "$1"
}
run_pair() { # run_pair NAME INPUT VAR...
  local name=$1 inp=$2; shift 2
  local vars=() v
  for v in "$@"; do vars+=(-var ${v%%=*} "${v#*=}"); done
  mkdir -p "$W/$name/plugin" "$W/$name/launcher"
  { echo "plugin load $B/sphdemplugin.so"; cat "$inp"; } >"$W/$name/in.plugin"
  (cd "$W/$name/plugin" && "$LMP" -in ../in.plugin "${vars[@]}" -log none) >"$W/$name/plugin.out" 2>&1
  local r1=$?
  (cd "$W/$name/launcher" && "$B/lmp_sphdem" -in "$inp" "${vars[@]}" -log none) >"$W/$name/launcher.out" 2>&1
  local r2=$?
  local n
  n=$(thermo_rows "$W/$name/plugin.out" | wc -l)
  if [ $r1 = 0 ] && [ $r2 = 0 ] && [ "$n" -ge 2 ] &&
     diff <(thermo_rows "$W/$name/plugin.out") <(thermo_rows "$W/$name/launcher.out") >/dev/null; then
    check "$name via plugin load == lmp_sphdem" 0 "$n thermo rows identical"
  else
    tail -n 5 "$W/$name/plugin.out" "$W/$name/launcher.out"
    check "$name via plugin load == lmp_sphdem" 1 "rc $r1/$r2, $n rows"
  fi
}
E=$REPO/examples
run_pair hydrostatic "$E/hydrostatic/in.hydrostatic" tend=0.05
run_pair settling "$E/settling/in.settling" tend=0.01
run_pair dem_drop_hertz "$E/dem_drop/in.dem_drop" steps=3000 style=gran/hertz/history/gpu
run_pair dem_drop_hooke "$E/dem_drop/in.dem_drop" steps=3000 style=gran/hooke/history/gpu
run_pair bubbling_bed "$E/bubbling_bed/in.bubbling_bed" tend=0.01

# 5. an input error ends with exit status 1 and the ERROR line (lmp_sphdem, and lmp + plugin)
printf 'units si\nregion b block 0 1 0 1 0 1\ncreate_box 1 b\nfix w all sph/fluid rho0 1000 bogus 1\n' >"$W/in.bad"
for how in launcher plugin; do
  if [ $how = launcher ]; then cmd=("$B/lmp_sphdem" -in in.bad); else
    { echo "plugin load $B/sphdemplugin.so"; cat "$W/in.bad"; } >"$W/in.bad_plugin"; cmd=("$LMP" -in in.bad_plugin); fi
  (cd "$W" && "${cmd[@]}" -log none) >"$W/bad_$how.out" 2>&1
  RC=$?
  [ $RC = 1 ] && grep -q "^ERROR" "$W/bad_$how.out"
  check "bad keyword through $how: exit 1 with the ERROR line" $? "rc $RC: $(grep -m1 '^ERROR' "$W/bad_$how.out" | cut -c1-90)"
done

# 6. the engine tests with the launcher linked to this LAMMPS
if [ "$CTEST_ARGS" != none ]; then
  # shellcheck disable=SC2086
  (cd "$SBUILD" && ctest $CTEST_ARGS --output-on-failure) >"$W/ctest.out" 2>&1
  RC=$?
  grep -E "tests passed|tests failed|^\s+[0-9]+ - " "$W/ctest.out"
  check "ctest $CTEST_ARGS" $RC "$(grep -m1 'tests passed' "$W/ctest.out")"
fi
finish
