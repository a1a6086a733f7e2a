#!/usr/bin/env bash
# Packs build/specula and build/test_opencl with every shared library they load (glibc and its
# loader included) into .devkit/ (lib.tar.xz, about 19 MB), so that they run unchanged on a machine
# with another distribution: the GPU check machine (bench/gpu/check.sh, bench/gpu/probe.py) has
# an NVIDIA driver but none of specula's libraries. Run from the repository root after
# tools/build.sh; .devkit/ should be ignored (.git/info/exclude).
set -euo pipefail
cd "$(dirname "$0")/../.."
rm -rf .devkit && mkdir -p .devkit/lib
for f in $(ldd build/specula build/test_opencl | awk '/=>/ {print $3}' | sort -u) /lib64/ld-linux-x86-64.so.2; do
  cp -L "$f" .devkit/lib/
done
cp build/specula build/test_opencl .devkit/
(cd .devkit && tar cJf lib.tar.xz lib && rm -rf lib)
cp bench/gpu/check.sh bench/gpu/probe.py .devkit/
du -sh .devkit
