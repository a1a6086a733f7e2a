#!/usr/bin/env bash
# Installs what is missing (Debian packages, as root or with sudo), then configures and builds
# specula into build/. Usage: bash tools/build.sh [extra cmake args]
set -euo pipefail
cd "$(dirname "$0")/.."

pkgs=(build-essential cmake pkg-config libembree-dev libopenexr-dev libpng-dev libexpat1-dev zlib1g-dev
      libjpeg62-turbo-dev libmicrohttpd-dev libjs-three
      ocl-icd-opencl-dev opencl-c-headers pocl-opencl-icd)
missing=()
for p in "${pkgs[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build build -j"$(nproc)"
