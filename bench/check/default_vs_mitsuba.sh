#!/usr/bin/env bash
# The default renderer (no flag: specular NEE as the plan picks it) against Mitsuba 3 on the
# project's caustic scenes, per-pixel Welch test (bench/check/cmp.py: pixels passing at alpha 0.01
# Sidak-corrected, mean z, image means).
# Usage: bash bench/check/default_vs_mitsuba.sh REFDIR [RES] [SPP] [MITSUBA_SPP] [SCENE...]
# REFDIR caches Mitsuba's references (llvm_ad_rgb, 16 passes); specula renders RES x RES at SPP
# with --variance, one thread. Extra specula flags: $SPECULA_FLAGS.
set -euo pipefail
cd "$(dirname "$0")/../.."
refdir=$1; res=${2:-32}; spp=${3:-2048}; mspp=${4:-131072}; shift $(( $# < 4 ? $# : 4 ))
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(caustic_glass_sphere caustic_mirror_ring caustic_pool caustic_glass_cube \
  caustic_sphere dielectrics newton_pool newton_slabs demo)
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
mkdir -p "$refdir"
for s in "${scenes[@]}"; do
  xml=scenes/$s.xml; [ -f "$xml" ] || xml=$s
  name=$(basename "$xml" .xml)
  ref=$refdir/${name}_${res}_mitsuba.exr
  if [ ! -f "$ref" ]; then
    python3 tests/validation/mitsuba_ref.py "$xml" "$ref" --res ${res}x${res} --spp "$mspp" --passes 16 \
      --variant llvm_ad_rgb > /dev/null || { printf "%-24s Mitsuba 3 cannot render it\n" "$name"; continue; }
  fi
  out=$refdir/${name}_${res}_specula.exr
  build/specula render "$xml" --res ${res}x${res} --spp "$spp" --threads 1 --variance --quiet \
    ${SPECULA_FLAGS:-} -o "$out" --stats "$refdir/${name}.json"
  plan=$(python3 -c "import json; print(json.load(open('$refdir/${name}.json')).get('specular_nee'))")
  printf "%-24s %-20s " "$name" "$plan"
  python3 bench/check/cmp.py "$out" "$ref"
done
