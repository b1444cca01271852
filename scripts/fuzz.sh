#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang in build/fuzz and runs each for a bounded
# time: FUZZ_SECONDS per target (default 60). FUZZ_TARGETS picks some ("scene_parser_fuzzer").
# The .prt loader's seeds follow the current file format, so they are not kept in git: they are
# written before each run by `polyrad precompute` (POLYRAD_CLI, default build/release/src/polyrad,
# built there when missing) into build/fuzz/seeds/prt.
# Exits 1 on a finding (a crash, a sanitizer report, a leak, a timeout or running out of memory)
# after copying its input to fuzz/regressions/<corpus>/, where tests/fuzz_regression_test.cpp
# replays it in every test run. See docs/testing.md.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/deps.sh

seconds="${FUZZ_SECONDS:-60}"
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 1 ]; then
  echo "fuzz.sh: FUZZ_SECONDS must be a positive integer, not '$seconds'" >&2
  exit 2
fi
dir="build/fuzz"
# target:corpus, the corpus naming fuzz/<corpus>.dict, fuzz/regressions/<corpus> and the seeds:
# fuzz/corpus/<corpus> and build/fuzz/seeds/<corpus>, whichever exist.
all_targets=(scene_parser_fuzzer:scene obj_reader_fuzzer:obj prt_loader_fuzzer:prt)
wanted="${FUZZ_TARGETS:-}"

cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++-14 \
  -DPOLYRAD_FUZZ=ON -DPOLYRAD_BUILD_TESTS=OFF -DPOLYRAD_BUILD_BENCH=OFF >/dev/null
targets=()
for entry in "${all_targets[@]}"; do
  name="${entry%%:*}"
  if [ -z "$wanted" ] || [[ " $wanted " == *" $name "* ]]; then targets+=("$entry"); fi
done
if [ ${#targets[@]} -eq 0 ]; then
  echo "fuzz.sh: no target matches FUZZ_TARGETS='$wanted'" >&2
  exit 2
fi
cmake --build "$dir" -j "$(nproc)" --target "${targets[@]%%:*}" >&2

# Seeds for the .prt loader: small operators of fuzz/prt_seed_scene.json in every combination of
# rows, precision and basis (and one sparse solution, by --drop, and one that keeps the mesh's
# direct light, by --indirect mesh), written by this polyrad.
if [[ " ${targets[*]} " == *":prt "* ]]; then
  cli="${POLYRAD_CLI:-build/release/src/polyrad}"
  if [ ! -x "$cli" ]; then
    echo "fuzz.sh: building $cli for the .prt seeds" >&2
    cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release >/dev/null
    cmake --build build/release -j "$(nproc)" --target polyrad_cli >&2
  fi
  seeds="$dir/seeds/prt"
  rm -rf "$seeds"
  mkdir -p "$seeds"
  seed() {  # seed NAME FLAGS...: quiet unless the precompute fails
    local said
    if ! said=$("$cli" precompute fuzz/prt_seed_scene.json -o "$seeds/$1.prt" --order 3 \
                 "${@:2}" 2>&1); then
      echo "$said" >&2
      echo "fuzz.sh: polyrad precompute failed to write the .prt seed $1" >&2
      exit 2
    fi
  }
  for output in view solution; do
    for precision in float half; do
      for basis in patch object; do
        seed "$output-$precision-$basis" \
          --output "$output" --precision "$precision" --basis "$basis"
      done
    done
  done
  seed solution-float-patch-drop --output solution --drop 0.3
  seed solution-float-object-mesh --output solution --basis object --indirect mesh
  echo "fuzz.sh: $(ls "$seeds" | wc -l) .prt seeds in $seeds" >&2
fi

status=0
passed=0
failed=0
for entry in "${targets[@]}"; do
  name="${entry%%:*}"
  corpus="${entry##*:}"
  work="$dir/corpus/$name"          # what the fuzzer learns; kept between local runs, not in git
  artifacts="$dir/artifacts/$name"
  log="$dir/logs/$name.log"
  mkdir -p "$work" "$artifacts" "$(dirname "$log")"
  rm -f "$artifacts"/crash-* "$artifacts"/leak-* "$artifacts"/timeout-* "$artifacts"/oom-*
  seed_dirs=()
  for d in "fuzz/corpus/$corpus" "$dir/seeds/$corpus"; do
    if [ -d "$d" ]; then seed_dirs+=("$d"); fi
  done
  echo "fuzz.sh: $name for ${seconds} s (log: $log)" >&2
  rc=0
  # -timeout: one input taking longer than 10 s is a finding; -rss_limit_mb likewise for memory.
  "$dir/fuzz/$name" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -dict="fuzz/$corpus.dict" -artifact_prefix="$artifacts/" -print_final_stats=1 \
    "$work" "${seed_dirs[@]}" >"$log" 2>&1 || rc=$?
  grep -E '^(Done|stat::number_of_executed_units)' "$log" | sed "s/^/fuzz.sh: $name: /" >&2 || true
  if [ "$rc" -eq 0 ]; then
    passed=$((passed + 1))
  else
    status=1
    failed=$((failed + 1))
    echo "fuzz.sh: FINDING in $name (exit $rc); the end of its log:" >&2
    tail -n 60 "$log" >&2
    mkdir -p "fuzz/regressions/$corpus"
    for f in "$artifacts"/crash-* "$artifacts"/leak-* "$artifacts"/timeout-* "$artifacts"/oom-*; do
      [ -e "$f" ] || continue
      cp "$f" "fuzz/regressions/$corpus/"
      echo "fuzz.sh: saved fuzz/regressions/$corpus/$(basename "$f"); replay it with" >&2
      echo "  $dir/fuzz/$name fuzz/regressions/$corpus/$(basename "$f")" >&2
      echo "fuzz.sh: its bytes (base64): $(base64 -w0 "$f" | head -c 4000)" >&2
    done
  fi
done
echo "fuzz: $passed passed, $failed failed"
exit "$status"
