#!/usr/bin/env bash
# Is a Welch failure against Mitsuba 3's path tracer the default's fault or the reference's? For one
# scene: the default at each SPP (32x32, one thread, --variance --aovs) against two independent
# Mitsuba 3 references (llvm_ad_rgb, 32x32, the scene's max_depth):
#   path    MITSUBA_BATCHES x 8192 spp; cmp_ref.py --spikes --blocks 4 groups the pixels by the
#           reference batches holding a spike (a rare path, e.g. a small light seen in a glass ball
#           from the floor, which BSDF sampling finds once in 1e5 samples or less): a reference that
#           misses it is low on the spike-free pixels only, where a biased image is off everywhere;
#   ptracer 8 x 8192 light paths per pixel; reaches those paths from the light, renders nothing
#           seen through glass or in a mirror, so it tests only the pixels whose camera rays all
#           hit the floor (normal 0,1,0) first (mask: Mitsuba's aov integrator, NAME_32_normal.npy).
# Usage: bash bench/check/settle_rare.sh SCENE.xml REFDIR MITSUBA_BATCHES SPP...
# References are cached in REFDIR as NAME_32_{path,ptracer,normal}.npy.
set -euo pipefail
cd "$(dirname "$0")/../.."
xml=$1; refdir=$2; batches=$3; shift 3
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
mkdir -p "$refdir"
name=$(basename "$xml" .xml)
md=$(python3 -c "import re; m=re.search(r'name=\"max_depth\" value=\"(-?[0-9]+)\"', open('$xml').read()); print(m.group(1) if m else 8)")
for integ in path ptracer; do
  ref=$refdir/${name}_32_$integ.npy
  b=$batches; [ $integ = ptracer ] && b=8
  [ -f "$ref" ] || python3 bench/check/mitsuba_ref.py "$xml" "$ref" --batches "$b" --spp 8192 --res 32 \
    --max-depth "$md" --integrator $integ 2> /dev/null
done
mask=$refdir/${name}_32_normal.npy
[ -f "$mask" ] || python3 bench/check/mitsuba_ref.py "$xml" "$mask" --batches 1 --spp 64 --res 32 \
  --integrator normal 2> /dev/null
for spp in "$@"; do
  out=$refdir/${name}_32_default_${spp}_aov.exr
  [ -f "$out" ] || build/specula render "$xml" -D res=32 --spp "$spp" --threads 1 --variance --aovs --quiet \
    -o "$out"
  echo "== $name, the default at $spp spp, against Mitsuba's path ($batches x 8192 spp):"
  python3 bench/check/cmp_ref.py "$refdir/${name}_32_path.npy" "$out" --spikes --blocks 4
  echo "   the floor pixels against Mitsuba's ptracer (8 x 8192):"
  python3 bench/check/cmp_ref.py "$refdir/${name}_32_ptracer.npy" "$out" --floor "$mask" --blocks 4
done
