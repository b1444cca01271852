#!/usr/bin/env bash
# The final gather in a room of four mirror walls, each facing the other three: the lamps drawn at
# their images through the chains of walls whose beams are not empty, as many as
# --mirror-chains N allows (whole lengths at a time), against the exact image
# (scenes/stability/mirrored-room.json, whose floor's light is the sum over the lattice of the
# lamp's images: scripts/mirrored_room_exact.py).
#
#   ./scripts/mirrored_room_study.sh [DIR]
#     DIR  output (default out/mirrored-room): per budget N, chains-N.pfm and its report;
#          exact.pfm; mirrored-room.md, the table
# $POLYRAD names the binary (default: a Release build through scripts/build.sh); $BUDGETS the
# budgets (default "0 64 128 256 512 1024"; 0: one mirror, as --mirror-image-depth 1).
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
out="${1:-out/mirrored-room}"
scene="$root/scenes/stability/mirrored-room.json"
exact="$root/scripts/mirrored_room_exact.py"
need_polyrad
mkdir -p "$out"
[ -f "$out/exact.pfm" ] || /usr/bin/python3 "$exact" exact "$out/exact.pfm" "$out/mask.json"
table="$out/mirrored-room.md"
{
  echo "| \`--mirror-chains\` | wall (s) | gather rays | against the exact image |"
  echo "|---|---|---|---|"
} > "$table"
for budget in ${BUDGETS:-0 64 128 256 512 1024}; do
  base="$out/chains-$budget"
  /usr/bin/time -f "%e" -o "$base.wall" "$POLYRAD" --quiet render "$scene" \
    --mirror-chains "$budget" -o "$base.pfm" --report "$base.json"
  rays=$(report_value "$base.json" gather rays)
  echo "| $budget | $(tail -n 1 "$base.wall") | $rays | $(/usr/bin/python3 "$exact" compare \
    "$base.pfm" "$out/exact.pfm" "$out/mask.json") |" >> "$table"
done
cat "$table"
