#!/usr/bin/env bash
# The default against references that each sample their pixels' rare paths, per pixel class fixed by
# the geometry before any test (a glass ball under a small sphere light, no sky: the floor pixels get
# part of their light through the light's tiny image in the glass, which path tracing finds about
# once in 1e5 samples and light tracing finds from the light):
#   ref    Mitsuba's ptracer on the floor pixels (every camera sample hits the floor first, Mitsuba's
#          aov integrator), Mitsuba's path on the rest (ptracer renders nothing seen through glass);
#   bdpt   specula's bdpt without specular NEE (light tracing among its strategies);
#   none   specula's path without specular NEE.
# All 32x32, one thread each (Mitsuba llvm_ad_rgb with Dr.Jit on one thread), the scene's max_depth.
# Each estimate is made of CHUNKS independent parts (Mitsuba: 16 batches of 8192 spp; specula:
# renders with their own seeds) and the parts already in REFDIR are reused, so the run can be
# stopped and continued. bench/check/cmp_mix.py prints the table.
# Usage: bash bench/check/settle_mixed.sh SCENE.xml REFDIR CHUNKS DEFAULT_SPP BDPT_SPP NONE_SPP
set -euo pipefail
cd "$(dirname "$0")/../.."
xml=$1; dir=$2; chunks=$3; dspp=$4; bspp=$5; nspp=$6
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
mkdir -p "$dir"
md=$(python3 -c "import re; m=re.search(r'name=\"max_depth\" value=\"(-?[0-9]+)\"', open('$xml').read()); print(m.group(1) if m else 8)")
mask=$dir/normal.npy
[ -f "$mask" ] || python3 bench/check/mitsuba_ref.py "$xml" "$mask" --batches 1 --spp 64 --res 32 \
  --integrator normal --threads 1 2> /dev/null
R="build/specula render $xml -D res=32 --threads 1 --variance --quiet"
[ -f "$dir/default.exr" ] || $R --spp "$dspp" --seed 11 -o "$dir/default.exr"
pa= pt= bd= no=
for ((c = 0; c < chunks; c++)); do
  for integ in path ptracer; do
    f=$dir/${integ}_$c.npy
    [ -f "$f" ] || python3 bench/check/mitsuba_ref.py "$xml" "$f" --batches 16 --first-batch $((16 * c)) \
      --spp 8192 --res 32 --max-depth "$md" --integrator $integ --threads 1 2> /dev/null
  done
  [ -f "$dir/bdpt_$c.exr" ] || $R --integrator bdpt --specular-nee none --spp "$bspp" --seed $((100 + c)) \
    -o "$dir/bdpt_$c.exr"
  [ -f "$dir/none_$c.exr" ] || $R --specular-nee none --spp "$nspp" --seed $((200 + c)) -o "$dir/none_$c.exr"
  pa+=${pa:+,}$dir/path_$c.npy; pt+=${pt:+,}$dir/ptracer_$c.npy
  bd+=${bd:+,}$dir/bdpt_$c.exr; no+=${no:+,}$dir/none_$c.exr
done
python3 bench/check/cmp_mix.py --mask "$mask" --src default="$dir/default.exr" --src pa="$pa" \
  --src pt="$pt" --src bdpt="$bd" --src none="$no" --mix ref=pt/pa --floor-only pt --blocks 4 \
  --cmp default:ref --cmp default:pa --cmp default:pt --cmp default:bdpt --cmp default:none \
  --cmp bdpt:ref --cmp none:ref --cmp none:bdpt
