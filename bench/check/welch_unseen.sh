#!/usr/bin/env bash
# The default (no --specular-nee flag) against Mitsuba 3 on scenes no one tuned it for: the check
# scenes of this folder and fresh random caustic scenes (/work/shared/tools/random_caustic_scene.py).
# Usage: bash bench/check/welch_unseen.sh REFDIR SPP MITSUBA_BATCHES SCENE_OR_SEED...
# A number is a random scene's seed (written to REFDIR/caustic_SEED.xml); anything else an XML path.
# Mitsuba's references (llvm_ad_rgb, MITSUBA_BATCHES x 8192 spp, 32x32, the scene's max_depth, path or
# volpath as the scene's integrator) are cached in REFDIR as NAME_32_mitsuba.npy; specula renders
# 32x32 at SPP spp, one thread, --variance; bench/check/cmp_ref.py prints the per-pixel Welch test
# (Sidak, alpha 0.01) and 4x4 blocks.
set -euo pipefail
cd "$(dirname "$0")/../.."
refdir=$1; spp=$2; batches=$3; shift 3
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
mkdir -p "$refdir"
for s in "$@"; do
  if [[ $s =~ ^[0-9]+$ ]]; then
    python3 /work/shared/tools/random_caustic_scene.py "$s" "$refdir" > /dev/null
    xml=$refdir/caustic_$s.xml
  else
    xml=$s
  fi
  name=$(basename "$xml" .xml)
  md=$(python3 -c "import re,sys; m=re.search(r'name=\"max_depth\" value=\"(-?[0-9]+)\"', open('$xml').read()); print(m.group(1) if m else 8)")
  integ=path; grep -q '"volpath"' "$xml" && integ=volpath
  ref=$refdir/${name}_32_mitsuba.npy
  [ -f "$ref" ] || python3 bench/check/mitsuba_ref.py "$xml" "$ref" --batches "$batches" --spp 8192 --res 32 \
    --max-depth "$md" --integrator $integ 2> /dev/null || { echo "$name: Mitsuba 3 cannot render it"; continue; }
  out=$refdir/${name}_32_default_${spp}.exr
  [ -f "$out" ] || build/specula render "$xml" -D res=32 --spp "$spp" --threads 1 --variance --quiet -o "$out" \
    --stats "$refdir/${name}_default.json"
  plan=$(python3 -c "import json; print(json.load(open('$refdir/${name}_default.json')).get('specular_nee'))")
  echo "== $name (max_depth $md): $plan"
  python3 bench/check/cmp_ref.py "$ref" "$out" --blocks 4
done
