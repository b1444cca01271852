#!/usr/bin/env bash
# Radiosity against a path-traced reference of the same scene, camera and materials, at several
# patch sizes. For each scene: a high-sample reference (cached), then radiosity at each patch
# size read three ways (the patch gather in smooth and in flat shading, and the final gather),
# compared region by region; a markdown table and side-by-side pictures under DIR, named
# SCENE-pSIZE-{patch-smooth,patch-flat,final}.
#
#   ./scripts/accuracy_study.sh [DIR] [SPP] [SCENES...]
#     DIR     output (default out/accuracy)      SPP  reference samples per pixel (default 4096)
#     SCENES  default: cornell-box cornell-mirror-cube cornell-glossy
# $POLYRAD names the binary (default: a Release build through scripts/build.sh); $TOLERANCES the
# link tolerances of the hierarchical runs (final gather, each patch size as the roots; default
# "0.1 0.05 0.02"; empty: none), named SCENE-pSIZE-hTOL; $READS replaces the whole list of runs
# (e.g. READS="final h0.05").
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
out="${1:-out/accuracy}"
spp="${2:-4096}"
shift $(( $# > 2 ? 2 : $# )) || true
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(cornell-box cornell-mirror-cube cornell-glossy)
need_polyrad
mkdir -p "$out"
table="$out/accuracy.md"
{
  echo "| scene | patch size | elements | gather | relative RMSE | mean relative error | relative L1 | largest region difference | time (s) |"
  echo "|---|---|---|---|---|---|---|---|---|"
} > "$table.tmp"
for scene in "${scenes[@]}"; do
  file="$root/scenes/$scene.json"
  ref="$out/$scene-pt$spp.exr"
  if [ ! -f "$ref" ]; then
    echo "accuracy: path tracing $scene at $spp spp" >&2
    "$POLYRAD" --quiet render "$file" --method pathtrace --spp "$spp" -o "$ref" --report "$out/$scene-pt$spp.json"
  fi
  for size in 100 50 25; do
    reads=(patch-smooth patch-flat final)
    for tol in ${TOLERANCES-0.1 0.05 0.02}; do reads+=("h$tol"); done
    if [ -n "${READS:-}" ]; then read -r -a reads <<< "$READS"; fi
    for read in "${reads[@]}"; do
      case "$read" in
        patch-*) flags=(--gather patch --mesh uniform --diffuse "${read#patch-}") ;;
        final) flags=(--gather final) ;;
        h*) flags=(--gather final --mesh hierarchical --link-tolerance "${read#h}") ;;
      esac
      img="$out/$scene-p$size-$read.exr"
      "$POLYRAD" --quiet render "$file" --patch-size "$size" "${flags[@]}" --tolerance 1e-6 \
        -o "$img" --report "$out/$scene-p$size-$read.json"
      "$POLYRAD" --quiet compare "$img" "$ref" --scene "$file" --report "$out/$scene-p$size-$read-cmp.json" \
        --side-by-side "$out/$scene-p$size-$read-compare.png" >/dev/null
      /usr/bin/python3 - "$out" "$scene" "$size" "$read" >> "$table.tmp" <<'PY'
import json, sys
out, scene, size, shading = sys.argv[1:]
r = json.load(open(f"{out}/{scene}-p{size}-{shading}.json"))
c = json.load(open(f"{out}/{scene}-p{size}-{shading}-cmp.json"))["comparison"]
worst = max(c["regions"], key=lambda g: abs(g["luminance_difference"]))
total = r["seconds"]["total"]
h = r["system"].get("hierarchy")
print(f"| {scene} | {size} | {h['leaves'] if h else r['system']['patches']} | {shading} | {c['relative_rmse']:.3f} | "
      f"{c['mean_relative_error']:.3f} | {c['relative_l1']:.3f} | "
      f"{worst['name']} {100 * worst['luminance_difference']:+.1f}% | {total:.1f} |")
PY
    done
  done
done
mv "$table.tmp" "$table"
cat "$table"
