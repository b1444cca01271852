#!/usr/bin/env bash
# Builds Release and runs the Google Benchmark programs (docs/benchmarks.md): each writes its
# JSON to out/bench/<name>.json and its console table to out/bench/<name>.txt (and stdout);
# then scripts/bench_summary.py turns the JSON into out/bench/summary.md, with PASS/FAIL against
# the targets of the form factors, the transport, the series, the relighting server and the
# hierarchical mesh (form_factor_bench writes form_factors.json and .txt). The targets are reported, never
# enforced: the exit status is that of the build and the runs.
#
#   ./scripts/bench.sh                                  # everything (about 20 minutes)
#   ./scripts/bench.sh --benchmark_filter='sweep|product'   # extra arguments go to each program
#
# Environment: BENCH_OUT=DIR writes there instead of out/bench; BENCH_BUILD_DIR=DIR configures
# and builds the benchmarks there instead of build/release (scripts/build.sh); OMP_NUM_THREADS
# as usual (recorded in the JSON). Figures from a loaded machine are noisy: the ratios are taken
# against reference kernels timed in the same loop, which keeps them usable, not exact.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/deps.sh
if [ -n "${BENCH_BUILD_DIR:-}" ]; then
  dir="$BENCH_BUILD_DIR"
  cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DPOLYRAD_BUILD_BENCH=ON >/dev/null
  cmake --build "$dir" -j "$(nproc)" --target transport_bench series_bench form_factor_bench serve_bench \
    hierarchy_bench >&2
else
  dir=$(BUILD_TYPE=Release ./scripts/build.sh | tail -n 1)
fi
out="${BENCH_OUT:-out/bench}"
mkdir -p "$out"
# program:output name
for run in transport:transport series:series form_factor:form_factors serve:serve \
  hierarchy:hierarchy; do
  program="${run%%:*}" name="${run#*:}"
  echo "polyrad: running ${program}_bench" >&2
  "$dir/bench/${program}_bench" --benchmark_out="$out/$name.json" --benchmark_out_format=json \
    "$@" | tee "$out/$name.txt"
done
/usr/bin/python3 scripts/bench_summary.py "$out"
echo "polyrad: wrote $out/summary.md" >&2
