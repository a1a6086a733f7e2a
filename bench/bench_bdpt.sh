#!/bin/sh
# bench/bench_bdpt.sh: BDPT against path at equal time, and BDPT's per-strategy images.
#
# For each scene: a reference rendered by bdpt for REF_SECONDS (seed 1), then path and bdpt for
# SECONDS each (seeds 2, 3), and `specula diff` of each against the reference (relMSE). Then the
# caustic scene's strategies (s, t) of lengths 1..4, unweighted and MIS-weighted, from one render
# with --strategy-images, as small PNGs in bench/bdpt_strategies/, and each weighted strategy's
# share of the caustic (build/bdpt_strategy_share: 7x7 pixels around the image's brightest pixel).
#
# The machine may be shared: besides wall-clock equal time, each render's CPU time (user + system,
# from /usr/bin/time) is recorded, and relMSE x CPU seconds (constant for an unbiased estimator
# whose error falls as 1 / samples) gives the ratio at equal CPU time, which does not depend on how
# the cores were shared during the two runs.
#
# usage: bench/bench_bdpt.sh [BUILD_DIR [SECONDS [REF_SECONDS [RES]]]]   (run from the source root)
# defaults: build 30 600 128. EXRs and JSON go to $OUT (default /tmp/specula_bench_bdpt); with
# REUSE_REF=1 an existing reference there is kept; with STRATEGIES=0 the strategy images are skipped.
set -eu
BUILD=${1:-build}
T=${2:-30}
REF=${3:-600}
RES=${4:-128}
OUT=${OUT:-/tmp/specula_bench_bdpt}
SPC="$BUILD/specula"
SCENES=${SCENES-"indirect_shade indirect_lamp_glass indirect_door caustic_sphere"} # SCENES= : strategy images only
mkdir -p "$OUT" bench/bdpt_strategies

json_num() { # json_num FILE KEY: the number after "KEY": in FILE
    sed -n "s/.*\"$2\": *\([-0-9.e+]*\).*/\1/p" "$1" | head -n 1
}

echo "date: $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "| scene | integrator | wall s | CPU s | spp | relMSE | path / bdpt at equal wall time | at equal CPU time |"
echo "|---|---|---|---|---|---|---|---|"
for sc in $SCENES; do
    if [ "${REUSE_REF:-0}" != 1 ] || [ ! -f "$OUT/${sc}_ref.exr" ]; then
        "$SPC" render "scenes/$sc.xml" -D res="$RES" --integrator bdpt --time "$REF" --seed 1 --quiet \
            -o "$OUT/${sc}_ref.exr" --stats "$OUT/${sc}_ref.json"
    fi
    for it in path bdpt; do
        seed=2
        [ "$it" = bdpt ] && seed=3
        /usr/bin/time -f "%U %S" -o "$OUT/${sc}_$it.cpu" "$SPC" render "scenes/$sc.xml" -D res="$RES" \
            --integrator "$it" --time "$T" --seed "$seed" --quiet -o "$OUT/${sc}_$it.exr" --stats "$OUT/${sc}_$it.json"
        "$SPC" diff "$OUT/${sc}_$it.exr" "$OUT/${sc}_ref.exr" --json >"$OUT/${sc}_$it.diff.json"
    done
    rp=$(json_num "$OUT/${sc}_path.diff.json" rel_mse)
    rb=$(json_num "$OUT/${sc}_bdpt.diff.json" rel_mse)
    cpu_p=$(awk '{ printf "%.1f", $1 + $2 }' "$OUT/${sc}_path.cpu")
    cpu_b=$(awk '{ printf "%.1f", $1 + $2 }' "$OUT/${sc}_bdpt.cpu")
    ratio=$(awk -v a="$rp" -v b="$rb" 'BEGIN { printf "%.1f", a / b }')
    ratio_cpu=$(awk -v a="$rp" -v b="$rb" -v ca="$cpu_p" -v cb="$cpu_b" 'BEGIN { printf "%.1f", a * ca / (b * cb) }')
    echo "| $sc | path | $(json_num "$OUT/${sc}_path.json" wall_seconds | cut -c1-5) | $cpu_p |" \
        "$(json_num "$OUT/${sc}_path.json" spp) | $(printf %.4g "$rp") | | |"
    echo "| $sc | bdpt | $(json_num "$OUT/${sc}_bdpt.json" wall_seconds | cut -c1-5) | $cpu_b |" \
        "$(json_num "$OUT/${sc}_bdpt.json" spp) | $(printf %.4g "$rb") | $ratio | $ratio_cpu |"
    echo "| $sc | reference (bdpt) | $(json_num "$OUT/${sc}_ref.json" wall_seconds | cut -c1-5) | |" \
        "$(json_num "$OUT/${sc}_ref.json" spp) | | | |"
done
[ "${STRATEGIES:-1}" = 0 ] && exit 0

# per-strategy images of the caustic: lengths k = s + t - 1 <= 4, at 64x64, all from one render
SRES=${SRES:-64}
SSPP=${SSPP:-256}
/usr/bin/time -f "%U %S" -o "$OUT/strategies.cpu" "$SPC" render scenes/caustic_sphere.xml -D res="$SRES" \
    --max-depth 4 --spp "$SSPP" --seed 4 --quiet -o "$OUT/strategy_all.exr" --strategy-images "$OUT/strategies"
echo "strategy images: $(awk '{ printf "%.1f", $1 + $2 }' "$OUT/strategies.cpu") CPU s for the image and 28 films"
cp "$OUT"/strategies/s*_t*_*weighted.png bench/bdpt_strategies/
cp "$OUT/strategy_all.png" bench/bdpt_strategies/all_max_depth_4.png
"$BUILD/bdpt_strategy_share" "$OUT/strategy_all.exr" "$OUT/strategies"
echo "per-strategy images: bench/bdpt_strategies/"
