#!/usr/bin/env bash
# The opencl device against the CPU device: samples per second (wall clock) and per CPU second
# (user + system of the whole process, PoCL's threads included), for path and bdpt on the SDF
# scenes. Usage: bash bench/bench_opencl.sh [RES] [SPP_PATH] [SPP_BDPT] (default 64 64 32).
# Needs build/specula built with OpenCL and an OpenCL device (PoCL runs the kernels on the CPU).
set -euo pipefail
cd "$(dirname "$0")/.."
res=${1:-64}
spp_path=${2:-64}
spp_bdpt=${3:-32}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf "%-26s %-5s %-7s %5s %9s %8s %12s %14s\n" scene integ device spp wall_s cpu_s samples/s samples/cpu_s
for scene in scenes/caustic_sdf_torus.xml scenes/sdf_shapes_csg.xml; do
  for integ in path bdpt; do
    spp=$spp_path
    [ "$integ" = bdpt ] && spp=$spp_bdpt
    for dev in cpu opencl; do
      /usr/bin/time -f "%U %S" -o "$tmp/time" build/specula render "$scene" --device "$dev" --integrator "$integ" \
        --max-depth 8 --res "${res}x${res}" --spp "$spp" --quiet -o "$tmp/out.exr" --stats "$tmp/stats.json"
      wall=$(python3 -c "import json; print(json.load(open('$tmp/stats.json'))['wall_seconds'])")
      cpu=$(awk '{print $1 + $2}' "$tmp/time")
      n=$((res * res * spp))
      printf "%-26s %-5s %-7s %5d %9.2f %8.2f %12.0f %14.0f\n" "$(basename "$scene")" "$integ" "$dev" "$spp" "$wall" \
        "$cpu" "$(echo "$n / $wall" | bc -l)" "$(echo "$n / $cpu" | bc -l)"
    done
  done
done
