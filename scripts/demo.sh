#!/usr/bin/env bash
# The main job on the default scene: installs what is missing, builds Release, runs
# `polyrad demo`, and leaves its images and report under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/deps.sh
dir=$(BUILD_TYPE=Release ./scripts/build.sh | tail -n 1)
"$dir/src/polyrad" demo --out out "$@"
