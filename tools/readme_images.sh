#!/usr/bin/env bash
# Regenerates the README's pictures: scenes/caustic_mirror_ring.xml (a caustic inside a mirror ring
# under a small sphere light) rendered with the default (specular NEE chosen from the scene) and
# with --specular-nee none, at about equal CPU time: none gets SPP_RATIO times the samples (the
# default's cost per sample there, from bench/bench_default.py's calibration: 139 against 1488 spp
# per CPU-second at 24x24). Writes docs/images/ring_default.png and docs/images/ring_none.png.
# Usage: bash tools/readme_images.sh [RES] [SPP] [SPP_RATIO]
set -euo pipefail
cd "$(dirname "$0")/.."
res=${1:-128}
spp=${2:-32}
ratio=${3:-11}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
scene=scenes/caustic_mirror_ring.xml
"${SPECULA:-build/specula}" render "$scene" --res "${res}x${res}" --spp "$spp" --seed 1 -o "$tmp/default.exr" --quiet
"${SPECULA:-build/specula}" render "$scene" --res "${res}x${res}" --spp $((spp * ratio)) --seed 1 --specular-nee none \
  -o "$tmp/none.exr" --quiet
mkdir -p docs/images
cp "$tmp/default.png" docs/images/ring_default.png
cp "$tmp/none.png" docs/images/ring_none.png
echo "wrote docs/images/ring_default.png and docs/images/ring_none.png (${res}x${res}, $spp and $((spp * ratio)) spp)"
