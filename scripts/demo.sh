#!/usr/bin/env bash
# The main job on the default scene: installs what is missing, builds Release, runs
# `polyrad demo`, and leaves its images and report under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/deps.sh
dir=$(BUILD_TYPE=Release ./scripts/build.sh | tail -n 1)
"$dir/src/polyrad" demo --out out "$@"

# Speed against accuracy: the quick sweep on the default scene (about three minutes on 2 cores); its data in out/sweep/, the
# charts drawn from it in out/charts/.
POLYRAD="$dir/src/polyrad" CHARTS_DIR=out/charts ./scripts/sweep.sh scenes/cornell-mirror-cube.json \
  --out out/sweep --quick
