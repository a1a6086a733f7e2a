#!/bin/bash
# One seed of scenes/demo.xml at 16x16, one thread, --variance: demo_ceiling_one.sh NAME SEED SPP [render options]
# (run in the folder that holds the specula binary; the seed is 1000 + SEED; CPU time appended to times.txt)
n=$1; s=$2; spp=$3; shift 3
scene=${SCENE:-$(cd "$(dirname "$0")/../.." && pwd)/scenes/demo.xml}
cd "${DIR:-/tmp/welch15}"
/usr/bin/time -f "$n $s $spp cpu %U %S" -a -o times.txt ./specula render "$scene" --res 16x16 --spp $spp --threads 1 --quiet --seed $((1000+s)) --variance "$@" -o r_${n}_$s.exr > log_${n}_$s.txt 2>&1
