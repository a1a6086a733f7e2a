#!/bin/sh
# bench/conic_validate.sh: the larger, by-hand versions of the conic solver's image tests,
# whose small versions run in CI (tests/test_conic.c, tests/test_volpath.c):
#   - conic_bunny.xml (glass bunny-like mesh caustic): path + specular NEE conic against ipt;
#   - newton_pool.xml (a water surface mesh): path + conic against ipt;
#   - medium_glass.xml (a glass mesh filled with a scattering medium, lit through its surface):
#     volpath + conic connection against volpath without it (brute force: phase sampling only);
# each a per-pixel z-test (specula diff: alpha 0.01, Sidak-corrected over the pixels) on the pass
# fraction; then, on the medium scene, relMSE at equal CPU time of volpath with the conic, angular
# and newton connections and without any, against the brute-force reference.
#
#   sh bench/conic_validate.sh [BUILD_DIR] [OUT_DIR]
#
# Sizes by environment: RES (32), REF_SPP (65536: ipt and brute-force volpath), SPP (1024: path or
# volpath with the conic), EQ_SPP (1024: brute force in the equal-time set; the connections get
# EQ_SPP / 16). CPU seconds (user + sys of the render process) are measured with /usr/bin/time.
set -eu
BUILD=${1:-build}
OUT=${2:-/tmp/conic_validate}
RES=${RES:-32}
REF_SPP=${REF_SPP:-65536}
SPP=${SPP:-1024}
EQ_SPP=${EQ_SPP:-1024}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
SPECULA="$ROOT/$BUILD/specula"
mkdir -p "$OUT"

# render NAME SCENE SEED ARGS...: writes $OUT/NAME.exr (with variance) and $OUT/NAME.cpu
render() {
    name=$1 scene=$2 seed=$3
    shift 3
    /usr/bin/time -f "%U %S" -o "$OUT/$name.time" "$SPECULA" render "$ROOT/scenes/$scene" --res "${RES}x$RES" \
        --threads 2 --seed "$seed" --variance --quiet -o "$OUT/$name.exr" "$@"
    awk '{printf "%.1f\n", $1 + $2}' "$OUT/$name.time" > "$OUT/$name.cpu"
}

# ztest NAME REF: the pass fraction, pixels and relMSE of NAME against REF
ztest() {
    "$SPECULA" diff "$OUT/$1.exr" "$OUT/$2.exr" --json > "$OUT/$1.diff.json"
    python3 - "$OUT/$1.diff.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
z = d.get("ztest") or {}
print("z-test pass %.4f of %d pixels, relMSE %.4g, mean R %.5f vs %.5f" % (z.get("pass_fraction", -1),
      z.get("pixels", 0), d["rel_mse"], d["mean_a"][0], d["mean_b"][0]))
PY
}

echo "date $(date -u +%Y-%m-%dT%H:%MZ), load average $(cut -d' ' -f1-3 /proc/loadavg), res $RES"
for s in "bunny conic_bunny.xml" "pool newton_pool.xml"; do
    set -- $s
    render "$1_ipt" "$2" 1 --integrator ipt --specular-nee none --spp "$REF_SPP"
    render "$1_conic" "$2" 2 --integrator path --specular-nee conic --spp "$SPP"
    echo "$1: ipt $REF_SPP spp $(cat "$OUT/$1_ipt.cpu") CPU-s, path + conic $SPP spp $(cat "$OUT/$1_conic.cpu") CPU-s:" \
        "$(ztest "$1_conic" "$1_ipt")"
done
render medium_ref medium_glass.xml 1 --integrator volpath --specular-nee none --spp "$REF_SPP"
render medium_conic medium_glass.xml 2 --integrator volpath --specular-nee conic --spp "$SPP"
echo "medium: volpath $REF_SPP spp $(cat "$OUT/medium_ref.cpu") CPU-s, volpath + conic $SPP spp" \
    "$(cat "$OUT/medium_conic.cpu") CPU-s: $(ztest medium_conic medium_ref)"
# equal time: relMSE against the brute-force reference, and CPU seconds
for solver in none conic angular newton; do
    spp=$EQ_SPP
    [ "$solver" = none ] || spp=$((EQ_SPP / 16))
    render "eq_$solver" medium_glass.xml 3 --integrator volpath --specular-nee "$solver" --spp "$spp"
    echo "equal-time $solver: $spp spp, $(cat "$OUT/eq_$solver.cpu") CPU-s, $(ztest "eq_$solver" medium_ref)"
done
