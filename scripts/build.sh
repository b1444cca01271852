#!/usr/bin/env bash
# Configures and builds polyrad in build/<type> (default Release). Extra arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
type="${BUILD_TYPE:-Release}"
dir="build/${type,,}"
cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE="$type" "$@" >/dev/null
cmake --build "$dir" -j "$(nproc)" >&2
echo "$dir"
