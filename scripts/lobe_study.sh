#!/usr/bin/env bash
# Coarse patches against a sharp lobe (papers/glossy-radiosity.md). scenes/stability/sharp-lobe
# has a GGX tall block at alpha 0.05 (and a short block at 0.3); for contrast the same scene with
# the tall block at alpha 0.3 is made here. Each is rendered by radiosity at several patch sizes
# and compared with its own path-traced reference. The table says, per patch size, whether
# polyrad warned that the patches smear the tall block's lobe, and how far the image is from the
# reference: overall, and on the tall block, the floor (where its reflected light lands) and the
# short block, by the region's mean and by its relative L1 (both as `polyrad compare` reports them).
# The transfer conserves flux, so a smeared lobe moves light within a region more than it
# changes the region's mean: the L1 columns are the ones that can show it.
#
#   ./scripts/lobe_study.sh [DIR] [SPP] [SIZES...]
#     DIR    output (default out/lobe)    SPP  reference samples per pixel (default 16384)
#     SIZES  patch sizes, default 100 70 50 35 25
# $POLYRAD names the binary (default: a Release build through scripts/build.sh); $LIGHT_SAMPLES
# sets the gather's --light-samples (default: polyrad's, 4; 0 shows the gather without them,
# e.g. LIGHT_SAMPLES=0 ./scripts/lobe_study.sh out/lobe-nolight, which readme_images.sh uses
# beside out/lobe for the before-and-after picture). References are
# cached in DIR (delete them to render again); 128 x 128 at 16384 spp takes 2 to 4 minutes each
# on two cores, the radiosity at patch size 25 about 20 seconds.
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
out="${1:-out/lobe}"
spp="${2:-16384}"
shift $(( $# > 2 ? 2 : $# )) || true
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(100 70 50 35 25)
need_polyrad
mkdir -p "$out"
light_samples="${LIGHT_SAMPLES:-4}"

# The scenes: sharp-lobe as shipped, and its contrast with the tall block rough; mesh paths made
# absolute so that both can live in DIR.
/usr/bin/python3 - "$root/scenes/stability/sharp-lobe.json" "$out" <<'PY'
import copy, json, os, sys
src, out = sys.argv[1:]
s = json.load(open(src))
for o in s["objects"]:
    if "mesh" in o:
        o["mesh"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(src)), o["mesh"]))
rough = copy.deepcopy(s)
next(o for o in rough["objects"] if o["name"] == "tall_block")["material"] = "rough"
for name, scene in (("sharp", s), ("rough", rough)):
    json.dump(scene, open(f"{out}/{name}.json", "w"), indent=1)
PY

table="$out/lobe.md"
{
  echo "Scene \`scenes/stability/sharp-lobe.json\` (128 x 128; tall block GGX alpha 0.05, short" \
       "block 0.3) and the same with the tall block at alpha 0.3: radiosity (\`--method" \
       "iterative\`, smooth shading, 16 gather lobe samples, tolerance 1e-6) against a" \
       "path-traced reference at $spp spp; the gather takes $light_samples points on the lights per glossy hit."
  echo "Angles: the tall block's lobe width (the cone that holds half its energy) against the" \
       "flux-weighted median angle of the patches it exchanges specular light with; polyrad" \
       "warns when the patches are the wider. Region columns: mean luminance, radiosity /" \
       "reference - 1, then the region's relative L1 (sum |A - B| / sum |B| over its pixels" \
       "and channels)."
  echo
  echo "| tall block | patch size | patches | tall block: patches vs lobe | relative L1 | relative RMSE | tall block: mean, L1 | floor: mean, L1 | short block (alpha 0.3): mean, L1 | radiosity time (s) |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
} > "$table.tmp"
notes=()
for variant in sharp rough; do
  scene="$out/$variant.json"
  ref="$out/$variant-pt$spp.pfm"
  if [ ! -f "$ref" ]; then
    echo "lobe study: path tracing the $variant reference at $spp spp" >&2
    "$POLYRAD" --quiet render "$scene" --method pathtrace --spp "$spp" -o "$ref" \
      --report "$out/$variant-pt$spp.json"
  fi
  for size in "${sizes[@]}"; do
    base="$out/$variant-p$size"
    "$POLYRAD" --quiet render "$scene" --gather patch --mesh uniform --patch-size "$size" \
      --tolerance 1e-6 -o "$base.pfm" \
      --light-samples "$light_samples" --report "$base.json" 2> "$base.stderr"
    "$POLYRAD" --quiet compare "$base.pfm" "$ref" --scene "$scene" --report "$base-cmp.json" \
      --side-by-side "$base-compare.png" >/dev/null
    /usr/bin/python3 - "$out" "$variant" "$size" >> "$table.tmp" <<'PY'
import json, sys
out, variant, size = sys.argv[1:]
base = f"{out}/{variant}-p{size}"
r = json.load(open(f"{base}.json"))
c = json.load(open(f"{base}-cmp.json"))["comparison"]
tall = next(x for x in r["system"]["lobe_resolution"] if x["object"] == "tall_block")
warned = any(x.get("object") == "tall_block" for x in r["warnings"])
regions = {g["name"]: g for g in c["regions"]}
def region(name):
    g = regions[name]
    return f"{100 * g['luminance_difference']:+.1f}%, {g['relative_l1']:.3f}"
alpha = tall["lobe"].split()[-1]
print(f"| alpha {alpha} | {size} | {r['system']['patches']} | {tall['patch_angle_degrees']:.1f} vs "
      f"{tall['lobe_width_degrees']:.1f} deg, {'**warning**' if warned else 'no warning'} | "
      f"{c['relative_l1']:.3f} | {c['relative_rmse']:.3f} | {region('tall_block')} | "
      f"{region('floor')} | {region('short_block')} | {r['seconds']['total']:.1f} |")
PY
  done
  notes+=("$(/usr/bin/python3 - "$variant" "$out/$variant-pt$spp.json" <<'PY'
import json, sys
variant, path = sys.argv[1:]
r = json.load(open(path))
pt = r["pathtrace"]
print(f"Reference ({variant} tall block): {pt['spp']} spp in {r['seconds']['total']:.0f} s, "
      f"mean relative standard error {pt['mean_relative_standard_error']:.3f}.")
PY
)")
done
{
  echo
  for n in "${notes[@]}"; do echo "$n"; done
  echo "Machine: $(report_value "$out/sharp-pt$spp.json" machine)."
} >> "$table.tmp"
mv "$table.tmp" "$table"
cat "$table"
