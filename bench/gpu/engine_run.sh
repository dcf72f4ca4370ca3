#!/usr/bin/env bash
# engine_run.sh LAUNCHER ARGS... - run a launcher packed by pack_engines.sh (or orterun, Open MPI's mpirun:
# engine_run.sh orterun -np 2 ./lmp_gpu.sh -in in.x, where lmp_gpu.sh runs engine_run.sh lmp_sphdem) on a machine without the
# Debian packages: the carried loader and libraries; OpenMPI components copied to their Debian
# paths only where nothing is there yet (the machine's own files are never replaced).
set -u
E=$(cd "$(dirname "$0")" && pwd)
[ -e /tmp/eng/done ] || { mkdir -p /tmp/eng && tar xJf "$E/englibs.tar.xz" -C /tmp/eng && touch /tmp/eng/done; }
(cd /tmp/eng/root && find . -type f -o -type l | while read -r f; do [ -e "/$f" ] || { mkdir -p "/$(dirname "$f")"; cp -a "$f" "/$f"; }; done)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
LP=$E:/tmp/eng/lib:/usr/local/nvidia/lib64:/usr/lib/x86_64-linux-gnu:/usr/local/cuda/lib64
exe=$1; shift
# orterun (mpirun): its ranks on this machine talk through shared memory; a launcher alone is a singleton
if [ "$exe" = orterun ]; then export OMPI_MCA_btl=${OMPI_MCA_btl:-self,vader}
else export OMPI_MCA_ess_singleton_isolated=${OMPI_MCA_ess_singleton_isolated:-1} OMPI_MCA_btl=${OMPI_MCA_btl:-self}; fi
exec /tmp/eng/lib/ld-linux-x86-64.so.2 --library-path "$LP" "$E/$exe" "$@"
