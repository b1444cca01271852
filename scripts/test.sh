#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole ctest suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/deps.sh
dir=$(BUILD_TYPE=Release ./scripts/build.sh | tail -n 1)
ctest --test-dir "$dir" --output-on-failure -j "$(nproc)" --timeout 900
