#!/usr/bin/env bash
# Installs what scripts/train/train_normal_net.py needs (dev only: building and
# running scanbench needs none of it). libopenblas0-pthread takes over the
# libblas.so.3 alternative from the reference BLAS Debian's python3-torch
# otherwise runs on: about 17x faster matrix products on this 2-core machine.
set -euo pipefail
packages=(python3-torch python3-numpy python3-scipy libopenblas0-pthread)
missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
[ ${#missing[@]} -eq 0 ] && exit 0
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
$sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
