#!/usr/bin/env bash
# The final gather between two facing mirrors: the lamps drawn at their images through chains of
# up to N mirrors (--mirror-image-depth N), against the exact image of the black corridor
# (scenes/stability/facing-mirrors-black.json, whose floor's light is exactly the sum over the
# lamp's images: scripts/facing_mirrors_exact.py) and polyrad's path tracer judged the same way.
#
#   ./scripts/facing_mirrors_study.sh [DIR]
#     DIR  output (default out/facing-mirrors): per depth N, depth-N.pfm and its report;
#          exact.pfm and its lamp mask; facing-mirrors.md, the table
# $POLYRAD names the binary (default: a Release build through scripts/build.sh); $DEPTHS the
# depths (default "1 2 4 8 16 32"); $SPP the path tracer's samples per pixel (default 16384, with
# --max-depth 4096 since the mirrors keep 0.99 of the light: about 25 s on two cores; 0: none).
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
out="${1:-out/facing-mirrors}"
scene="$root/scenes/stability/facing-mirrors-black.json"
spp="${SPP:-16384}"
exact="$root/scripts/facing_mirrors_exact.py"
need_polyrad
mkdir -p "$out"
[ -f "$out/exact.pfm" ] || /usr/bin/python3 "$exact" exact "$out/exact.pfm" "$out/lamp-mask.json"
table="$out/facing-mirrors.md"
{
  echo "| run | wall (s) | against the exact image, over the pixels without a lamp |"
  echo "|---|---|---|"
} > "$table"
row() {  # row LABEL IMAGE WALL-FILE
  echo "| $1 | $(tail -n 1 "$3") | $(/usr/bin/python3 "$exact" compare "$2" "$out/exact.pfm" \
    "$out/lamp-mask.json") |" >> "$table"
}
for depth in ${DEPTHS:-1 2 4 8 16 32}; do
  base="$out/depth-$depth"
  /usr/bin/time -f "%e" -o "$base.wall" "$POLYRAD" --quiet render "$scene" \
    --mirror-image-depth "$depth" -o "$base.pfm" --report "$base.json"
  row "final gather, \`--mirror-image-depth $depth\`" "$base.pfm" "$base.wall"
done
if [ "$spp" -gt 0 ]; then
  /usr/bin/time -f "%e" -o "$out/pt$spp.wall" "$POLYRAD" --quiet render "$scene" \
    --method pathtrace --spp "$spp" --max-depth 4096 -o "$out/pt$spp.pfm"
  row "path tracer, $spp spp" "$out/pt$spp.pfm" "$out/pt$spp.wall"
fi
cat "$table"
