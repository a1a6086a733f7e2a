#!/usr/bin/env bash
# fuzz/run.sh: builds the libFuzzer harnesses (clang, -DSPC_FUZZ=ON, in build-fuzz/) and runs each
# for a fixed budget on its seed corpus. New inputs go to build-fuzz/fuzz/work/<name>/ (never to
# the committed fuzz/corpus/); a crash leaves build-fuzz/fuzz/crash-<name>-* and fails the run.
#
# usage: bash fuzz/run.sh [SECONDS_EACH (default 20)] [NAME...]   (names: xml obj ply serialized
#        exr png jpeg checkpoint cli explore vol curve; default all). FUZZ_JOBS=N runs N fuzzers at once (default 1).
# Installs clang and libclang-rt-14-dev (Debian) if missing; the library's own dependencies are
# tools/build.sh's (run it first on a fresh machine).
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-20}
shift || true
names=("$@")
[ ${#names[@]} -eq 0 ] && names=(xml obj ply serialized exr png jpeg checkpoint cli explore vol curve)

missing=()
for p in clang libclang-rt-14-dev; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi

CC=clang cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPC_FUZZ=ON >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_all >/dev/null

out=build-fuzz/fuzz
status=0
run_one() {
  local n=$1
  mkdir -p "$out/work/$n"
  # -timeout: one input taking longer is a finding (a hang); -rss_limit_mb: so is memory blow-up
  if ! ASAN_OPTIONS=detect_leaks=1 "$out/fuzz_$n" -max_total_time="$secs" -timeout=20 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$out/crash-$n-" "$out/work/$n" "fuzz/corpus/$n" \
      >"$out/$n.log" 2>&1; then
    echo "fuzz_$n: FAILED (see $out/$n.log and $out/crash-$n-*)" >&2
    return 1
  fi
  local execs cov
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$out/$n.log" | grep -o '[0-9]*$' || echo "?")
  cov=$(grep -o 'cov: [0-9]*' "$out/$n.log" | tail -1 | grep -o '[0-9]*' || echo "?")
  echo "fuzz_$n: ok, $execs executions in ${secs} s, coverage $cov edges"
}
jobs=${FUZZ_JOBS:-1}
pids=()
for n in "${names[@]}"; do
  run_one "$n" &
  pids+=($!)
  if [ ${#pids[@]} -ge "$jobs" ]; then
    wait "${pids[0]}" || status=1
    pids=("${pids[@]:1}")
  fi
done
for p in "${pids[@]}"; do wait "$p" || status=1; done
exit $status
