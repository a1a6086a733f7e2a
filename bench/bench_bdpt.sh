#!/bin/sh
# bench/bench_bdpt.sh: BDPT against path at equal time (issue 4), and BDPT's per-strategy images.
#
# For each scene: a reference rendered by bdpt for REF_SECONDS (seed 1), then path and bdpt for
# SECONDS each (seeds 2, 3), and `specula diff` of each against the reference (relMSE). Then the
# caustic scene's strategies (s, t) of lengths 1..4, unweighted and MIS-weighted, as small PNGs in
# bench/bdpt_strategies/.
#
# usage: bench/bench_bdpt.sh [BUILD_DIR [SECONDS [REF_SECONDS [RES]]]]   (run from the source root)
# defaults: build 30 600 128. EXRs and JSON go to $OUT (default /tmp/specula_bench_bdpt).
set -eu
BUILD=${1:-build}
T=${2:-30}
REF=${3:-600}
RES=${4:-128}
OUT=${OUT:-/tmp/specula_bench_bdpt}
SPC="$BUILD/specula"
SCENES=${SCENES:-"indirect_shade indirect_door caustic_sphere"}
mkdir -p "$OUT" bench/bdpt_strategies

json_num() { # json_num FILE KEY: the number after "KEY": in FILE
    sed -n "s/.*\"$2\": *\([-0-9.e+]*\).*/\1/p" "$1" | head -n 1
}

echo "date: $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "| scene | integrator | seconds | spp | relMSE | relMSE path / bdpt |"
echo "|---|---|---|---|---|---|"
for sc in $SCENES; do
    "$SPC" render "scenes/$sc.xml" -D res="$RES" --integrator bdpt --time "$REF" --seed 1 --quiet \
        -o "$OUT/${sc}_ref.exr" --stats "$OUT/${sc}_ref.json"
    for it in path bdpt; do
        seed=2
        [ "$it" = bdpt ] && seed=3
        "$SPC" render "scenes/$sc.xml" -D res="$RES" --integrator "$it" --time "$T" --seed "$seed" --quiet \
            -o "$OUT/${sc}_$it.exr" --stats "$OUT/${sc}_$it.json"
        "$SPC" diff "$OUT/${sc}_$it.exr" "$OUT/${sc}_ref.exr" --json >"$OUT/${sc}_$it.diff.json"
    done
    rp=$(json_num "$OUT/${sc}_path.diff.json" rel_mse)
    rb=$(json_num "$OUT/${sc}_bdpt.diff.json" rel_mse)
    ratio=$(awk -v a="$rp" -v b="$rb" 'BEGIN { printf "%.1f", a / b }')
    echo "| $sc | path | $(json_num "$OUT/${sc}_path.json" wall_seconds | cut -c1-5) |" \
        "$(json_num "$OUT/${sc}_path.json" spp) | $rp | |"
    echo "| $sc | bdpt | $(json_num "$OUT/${sc}_bdpt.json" wall_seconds | cut -c1-5) |" \
        "$(json_num "$OUT/${sc}_bdpt.json" spp) | $rb | $ratio |"
    echo "| $sc | reference (bdpt) | $(json_num "$OUT/${sc}_ref.json" wall_seconds | cut -c1-5) |" \
        "$(json_num "$OUT/${sc}_ref.json" spp) | | |"
done

# per-strategy images of the caustic: lengths k = s + t - 1 <= 4, at 64x64
SRES=${SRES:-64}
SSPP=${SSPP:-256}
for k in 1 2 3 4; do
    s=0
    while [ "$s" -le "$k" ]; do
        t=$((k + 1 - s))
        for w in unweighted weighted; do
            flag=""
            [ "$w" = weighted ] && flag="--strategy-weighted"
            "$SPC" render scenes/caustic_sphere.xml -D res="$SRES" --max-depth 4 --spp "$SSPP" --seed 4 --quiet \
                --strategy "$s,$t" $flag -o "$OUT/strategy_s${s}_t${t}_$w.exr"
            cp "$OUT/strategy_s${s}_t${t}_$w.png" "bench/bdpt_strategies/s${s}_t${t}_$w.png"
        done
        s=$((s + 1))
    done
done
"$SPC" render scenes/caustic_sphere.xml -D res="$SRES" --max-depth 4 --spp "$SSPP" --seed 4 --quiet \
    -o "$OUT/strategy_all.exr"
cp "$OUT/strategy_all.png" bench/bdpt_strategies/all_max_depth_4.png
echo "per-strategy images: bench/bdpt_strategies/"
