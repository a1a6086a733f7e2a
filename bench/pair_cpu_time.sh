#!/bin/bash
# Paired CPU time of two specula binaries on the shared scenes: one-thread plain path tracing, the
# two binaries alternating in each round, CPU time (user + system, /usr/bin/time -f %U+%S) per
# render; then whether the last round's EXRs are byte for byte equal (cmp). On a machine shared
# with other jobs CPU time of one-thread children is the measure that pairs (bench/RESULTS.md).
#
# usage: bench/pair_cpu_time.sh A B [ROUNDS]
# env:   CSPP (cornell box spp, 16), VSPP (veach-mis spp, 16), SCENES (/work/shared/scenes),
#        OUT (directory for the EXRs, a new temporary one)
A=$1; B=$2; R=${3:-3}
S=${SCENES:-/work/shared/scenes}
OUT=${OUT:-$(mktemp -d)}
for r in $(seq "$R"); do
  for bin in A B; do
    exe=${!bin}
    c=$( { /usr/bin/time -f %U+%S "$exe" render "$S/cornell-box/scene.xml" --threads 1 --integrator path \
          --spp "${CSPP:-16}" --res 256x256 --quiet -o "$OUT/cb_$bin.exr" >/dev/null; } 2>&1 | tail -1)
    v=$( { /usr/bin/time -f %U+%S "$exe" render "$S/veach-mis/scene.xml" --threads 1 --integrator path \
          --spp "${VSPP:-16}" --res 320x180 --quiet -o "$OUT/vm_$bin.exr" >/dev/null; } 2>&1 | tail -1)
    echo "round $r $bin cornell $(echo "$c" | bc) veach $(echo "$v" | bc)"
  done
done
cmp "$OUT/cb_A.exr" "$OUT/cb_B.exr" && echo "cornell EXR identical"
cmp "$OUT/vm_A.exr" "$OUT/vm_B.exr" && echo "veach EXR identical"
uptime
