#!/usr/bin/env bash
# Regenerates the README's pictures: the demo scene rendered with the default (specular NEE chosen
# from the scene) and with --specular-nee none, at equal CPU time: none gets SPP_RATIO times the
# samples (the default's measured cost per sample on this scene, CPU seconds of single-threaded
# renders: 1.82 s against 0.11 s for 64x64 at 16 spp). Writes docs/images/demo_default.png and
# docs/images/demo_none.png. Usage: bash tools/readme_images.sh [RES] [SPP] [SPP_RATIO]
set -euo pipefail
cd "$(dirname "$0")/.."
res=${1:-128}
spp=${2:-16}
ratio=${3:-16}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
build/specula render scenes/demo.xml --res "${res}x${res}" --spp "$spp" --seed 1 -o "$tmp/default.exr" --quiet
build/specula render scenes/demo.xml --res "${res}x${res}" --spp $((spp * ratio)) --seed 1 --specular-nee none \
  -o "$tmp/none.exr" --quiet
mkdir -p docs/images
cp "$tmp/default.png" docs/images/demo_default.png
cp "$tmp/none.png" docs/images/demo_none.png
echo "wrote docs/images/demo_default.png and docs/images/demo_none.png (${res}x${res}, $spp and $((spp * ratio)) spp)"
