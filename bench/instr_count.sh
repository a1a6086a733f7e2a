#!/bin/bash
# Instructions executed by a specula binary on the shared scenes (valgrind's cachegrind, no cache
# simulation): one-thread plain path tracing, cornell box 256x256 and veach-mis 320x180 at SPP
# samples. A deterministic figure next to paired CPU time, which scatters by 5-15% a round on a
# shared machine: it shows whether a change does less work, not whether it runs faster (cache
# misses, branch mispredictions and code size are not in it). Valgrind runs the batch kernels'
# AVX2 variants (it has no AVX-512). `cg_annotate OUT/cg_TAG_SCENE.out` splits the count by
# function and source line.
#
# usage: bench/instr_count.sh BIN TAG [SPP (4)]
# env:   SCENES (/work/shared/scenes), OUT (directory for the cachegrind files and EXRs, /tmp/instr_count)
B=$1; T=$2; SPP=${3:-4}
S=${SCENES:-/work/shared/scenes}
OUT=${OUT:-/tmp/instr_count}
mkdir -p "$OUT"
for sc in cornell:cornell-box:256x256 veach:veach-mis:320x180; do
  IFS=: read -r tag dir res <<< "$sc"
  n=$(valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file="$OUT/cg_${T}_$tag.out" "$B" render \
      "$S/$dir/scene.xml" --threads 1 --integrator path --spp "$SPP" --res "$res" --quiet \
      -o "$OUT/${T}_$tag.exr" 2>&1 | sed -n 's/.*I *refs: *//p')
  echo "$T $tag instructions $n"
done
