#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole ctest suite; then the same suite under
# AddressSanitizer + UndefinedBehaviorSanitizer (build/asan), then each fuzz target for
# FUZZ_SECONDS (default 30 here). SANITIZE=0 skips the last two (local use; CI runs all).
# See docs/testing.md.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/deps.sh
dir=$(BUILD_TYPE=Release ./scripts/build.sh | tail -n 1)
ctest --test-dir "$dir" --output-on-failure -j "$(nproc)" --timeout 900

if [ "${SANITIZE:-1}" = "0" ]; then exit 0; fi

# RelWithDebInfo keeps the sanitizers' stack traces readable at a moderate slowdown. Clang, not
# GCC: it builds the instrumented suite in about half the time, its instrumented code runs
# about as fast, and the code is then compiled by both compilers on every run (docs/testing.md).
asan=build/asan
# A build/asan configured with another compiler cannot be switched in place: start it afresh.
cache="$asan/CMakeCache.txt"
if [ -f "$cache" ] && ! grep -q '^CMAKE_CXX_COMPILER:.*clang++-14$' "$cache"; then rm -rf "$asan"; fi
cmake -S . -B "$asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 \
  -DPOLYRAD_SANITIZE=ON -DPOLYRAD_BUILD_BENCH=OFF >/dev/null
cmake --build "$asan" -j "$(nproc)" >&2
# Leaks count as failures (no suppressions needed so far: OpenMP, Embree and OpenImageIO run
# clean). Any report stops the test program, so ctest sees a failure.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:check_initialization_order=1:halt_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
log="$asan/ctest-sanitizers.log"
# LeakSanitizer's own tracer (the thread that stops the others for the check at exit) crashes
# now and then on this VM, after a test has passed: "Tracer caught signal 11", then "LeakSanitizer
# has encountered a fatal error" and exit 1 (docs/testing.md). Whether every failure in a log is
# that crash, with no report of a sanitizer's.
only_tracer_crashes() {
  local failed tracer
  failed=$(grep -c '(Failed)' "$1" || true)
  tracer=$(grep -c 'LeakSanitizer has encountered a fatal error' "$1" || true)
  [ "$failed" -gt 0 ] && [ "$failed" = "$tracer" ] && grep -q 'Tracer caught signal' "$1" &&
    ! grep -Eq 'ERROR: (Address|Leak)Sanitizer|runtime error:|detected memory leaks' "$1"
}
# When that crash is every failure, the failed tests run again, up to twice (it once struck the
# same test on its first two runs); any real report, any other failure, or a third crash fails
# the run.
if ! ctest --test-dir "$asan" --output-on-failure -j "$(nproc)" --timeout 1800 2>&1 | tee "$log"; then
  for attempt in 1 2 3; do
    if [ "$attempt" = 3 ] || ! only_tracer_crashes "$log"; then exit 8; fi
    echo "test.sh: LeakSanitizer's tracer crashed after the tests ran; running them again" >&2
    log="$asan/ctest-sanitizers-rerun$attempt.log"
    if ctest --test-dir "$asan" --rerun-failed --output-on-failure --timeout 1800 2>&1 |
      tee "$log"; then
      break
    fi
  done
fi

FUZZ_SECONDS="${FUZZ_SECONDS:-30}" ./scripts/fuzz.sh
