#!/usr/bin/env bash
# CI: the whole test suite built with AddressSanitizer and UndefinedBehaviorSanitizer (gcc).
#   bash .ci/sanitize.sh       # from the repository root; builds in build-asan/
# Any sanitizer report fails the test that triggered it (and so this script). Leaks are checked;
# .ci/lsan.supp silences leaks of third-party libraries only.
set -euo pipefail
cd "$(dirname "$0")/.."

build=${PIPETILE_ASAN_BUILD_DIR:-build-asan}
jobs=${PIPETILE_JOBS:-2}
root=$PWD

# The test binary runs at build time too (gtest_discover_tests lists its tests), so the options
# are exported before building.
export ASAN_OPTIONS="detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1:strict_init_order=1:abort_on_error=0"
export LSAN_OPTIONS="suppressions=$root/.ci/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

start=$SECONDS
werror=OFF; [ -z "${CI:-}" ] || werror=ON # as tools/dev.sh: warnings are errors in CI
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPIPETILE_SANITIZE=ON -DPIPETILE_BUILD_TESTS=ON \
      -DPIPETILE_WERROR=$werror >/dev/null
nice cmake --build "$build" -j"$jobs"
built=$SECONDS
# The smoke at iso 0.1 is meshed whole once here (Quality.NoNeedlesOnTheSmokeAtTheIsovalueItsReadmeGives,
# every level along y); its other whole-plume runs (along x and z, the top level's distance, the
# topology of every level) take the same code paths and 4 to 10 minutes each under the sanitizers,
# which would take CI past its time. The Release suite above runs them.
skip='^(KnownGap\.TheSmokeAtItsReadmeIsovalueHasNoNeedlesAlongXAndZ|Graph\.TheSmokesWholePlumeHasTheIsosurfaceTopology'
skip+='|Graph\.TheSmokeAtItsReadmeIsovalueIsWithinAVoxel(AlongX|AlongZ)?)$'
ctest --test-dir "$build" --output-on-failure -j"$jobs" -E "$skip"
echo "sanitize.sh: build $((built - start)) s, tests $((SECONDS - built)) s"
