#!/usr/bin/env bash
# CI: builds the libFuzzer harnesses of fuzz/ with clang and runs each for a bounded time.
#   bash .ci/fuzz.sh                          # from the repository root; builds in build-fuzz/
#   PIPETILE_FUZZ_SECONDS=300 bash .ci/fuzz.sh
# The regression inputs of fuzz/corpus_regressions/{contour,vdb,mesh}/ are replayed first; any of them
# failing again fails the script. A new crash, sanitizer report, invariant trap, timeout or
# out-of-memory in the timed run is reported with its input left in build-fuzz/artifacts/ (move it
# to fuzz/corpus_regressions/<fuzzer>/ and add a test); it fails the script with
# PIPETILE_FUZZ_STRICT=1.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=${PIPETILE_FUZZ_SECONDS:-60}
build=${PIPETILE_FUZZ_BUILD_DIR:-build-fuzz}
jobs=${PIPETILE_JOBS:-2}
root=$PWD

packages=(clang-14 libclang-rt-14-dev)
if ! dpkg -s "${packages[@]}" >/dev/null 2>&1; then
  sudo=""; [ "$(id -u)" = 0 ] || sudo=sudo
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q "${packages[@]}"
fi

start=$SECONDS
# CI (the variable CI set, as .ci/run does) builds with warnings as errors, as tools/dev.sh does.
werror=OFF; [ -z "${CI:-}" ] || werror=ON
cmake -S . -B "$build" -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DPIPETILE_FUZZ=ON -DPIPETILE_BUILD_TESTS=OFF -DPIPETILE_WERROR=$werror >/dev/null
nice cmake --build "$build" -j"$jobs" --target fuzz_contour fuzz_vdb fuzz_mesh make_vdb_seeds
echo "fuzz.sh: build $((SECONDS - start)) s"
# .vdb seeds are written by the installed OpenVDB (about 10 KB each, too big to keep in the tree).
"$build/make_vdb_seeds" "$build/seeds/vdb" >/dev/null

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0"
export LSAN_OPTIONS="suppressions=$root/.ci/lsan_fuzz.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

failed=0 # a known regression input fails again: always fatal
found=0  # the timed run found something new: reported; fatal with PIPETILE_FUZZ_STRICT=1
run() { # run FUZZER NAME SEED_DIR EXTRA_FLAGS...
  local fuzzer=$1 name=$2 seeds=$3; shift 3
  local corpus="$build/corpus/$fuzzer" artifacts="$build/artifacts/$fuzzer" log="$build/$fuzzer.log"
  mkdir -p "$corpus" "$artifacts"
  local regressions=(fuzz/corpus_regressions/"$name"/*)
  if [ -e "${regressions[0]}" ]; then
    echo "== $fuzzer: replaying ${#regressions[@]} regression inputs"
    # One process per input, so that every failing one is named.
    local input
    for input in "${regressions[@]}"; do
      if ! "$build/$fuzzer" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=30 "$@" "$input" \
           >"$log.replay" 2>&1; then
        grep -E "^(==[0-9]+==ERROR|SUMMARY|fuzz_(contour|mesh): invariant|.*runtime error)" "$log.replay" | head -n 5 || true
        echo "== $fuzzer: FAILS AGAIN on $input"
        failed=1
      fi
    done
  fi
  echo "== $fuzzer: fuzzing for $seconds s"
  local status=0
  "$build/$fuzzer" "$corpus" "$seeds" -max_total_time="$seconds" -rss_limit_mb=2048 \
      -malloc_limit_mb=2048 -timeout=30 -print_final_stats=1 -artifact_prefix="$artifacts/" "$@" \
      >"$log" 2>&1 || status=$?
  local executions
  executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  echo "== $fuzzer: ${executions:-?} executions, corpus $(ls "$corpus" | wc -l) inputs, exit $status"
  if [ "$status" != 0 ]; then
    grep -E "^(==[0-9]+==ERROR|SUMMARY|fuzz_(contour|mesh): invariant|.*runtime error)" "$log" | head -n 20 || true
    tail -n 60 "$log"
    echo "== $fuzzer: FOUND A CRASH; inputs in $artifacts/:"
    ls -l "$artifacts"
    found=1
  fi
}

run fuzz_contour contour fuzz/seeds/contour -max_len=1100
run fuzz_vdb vdb "$build/seeds/vdb" -max_len=24576
run fuzz_mesh mesh fuzz/seeds/mesh -max_len=16384
echo "fuzz.sh: total $((SECONDS - start)) s"
if [ "$found" = 1 ]; then
  echo "fuzz.sh: NEW FINDINGS above: move each input to fuzz/corpus_regressions/<fuzzer>/ and add a test."
  echo "         (not fatal for this run, since a random discovery is no regression of the change under test;"
  echo "          set PIPETILE_FUZZ_STRICT=1 to make it so)"
  [ "${PIPETILE_FUZZ_STRICT:-0}" = 1 ] && failed=1
fi
exit $failed
