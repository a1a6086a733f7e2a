#!/usr/bin/env bash
# Regenerates the README's pictures, each scene with the default (specular NEE chosen from the scene)
# and with --specular-nee none at about equal CPU time (none gets as many more samples as the
# default costs per sample):
#   - scenes/demo.xml at its own size (256x256), the default at its 8 spp, none at 64 spp (the
#     default's cost per sample there is about 7x none's: 3.8 CPU-s at 8 spp against 4.1 at 64):
#     docs/images/demo_default.png, docs/images/demo_none.png;
#   - scenes/caustic_mirror_ring.xml (a caustic inside a mirror ring under a small sphere light) at
#     128x128, 32 against 354 spp (4.2 CPU-s at 32 spp against 5.1 at 426):
#     docs/images/ring_default.png, docs/images/ring_none.png.
# Usage: bash tools/readme_images.sh
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
spc=${SPECULA:-build/specula}
mkdir -p docs/images
# scene, name, res, default spp, none spp
pair() {
  "$spc" render "$1" --res "$3x$3" --spp "$4" --seed 1 -o "$tmp/default.exr" --quiet
  "$spc" render "$1" --res "$3x$3" --spp "$5" --seed 1 --specular-nee none -o "$tmp/none.exr" --quiet
  cp "$tmp/default.png" "docs/images/$2_default.png"
  cp "$tmp/none.png" "docs/images/$2_none.png"
  echo "wrote docs/images/$2_default.png and docs/images/$2_none.png ($3x$3, $4 and $5 spp)"
}
pair scenes/demo.xml demo 256 8 64
pair scenes/caustic_mirror_ring.xml ring 128 32 354
