#!/usr/bin/env bash
# setup.sh - install what sphdem needs from Debian 12 packages (idempotent; uses sudo when not root).
set -euo pipefail
PKGS="build-essential cmake python3 python3-numpy python3-matplotlib lammps liblammps-dev liggghts libliggghts-dev openmpi-bin libopenmpi-dev"
missing=""
for p in $PKGS; do dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"; done
if [ -n "$missing" ]; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
  echo "sphdem setup: installing$missing"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
fi
