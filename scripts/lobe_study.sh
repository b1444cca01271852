#!/usr/bin/env bash
# Coarse patches against a sharp lobe (issue 7, METHOD.md section 9). scenes/stability/sharp-lobe
# has a GGX tall block at alpha 0.05 (and a short block at 0.3); for contrast the same scene with
# the tall block at alpha 0.3 is made here. Each is rendered by radiosity at several patch sizes
# and compared with its own path-traced reference. The table says, per patch size, whether
# polyrad warned that the patches smear the tall block's lobe, and how far the image is from the
# reference: overall, and on the tall block, the floor (where its reflected light lands) and the
# short block, by the region's mean (as `polyrad compare` reports it) and by its relative L1.
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
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-out/lobe}"
spp="${2:-16384}"
shift $(( $# > 2 ? 2 : $# )) || true
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(100 70 50 35 25)
if [ -z "${POLYRAD:-}" ]; then
  "$root/scripts/deps.sh"
  POLYRAD="$root/$(cd "$root" && BUILD_TYPE=Release ./scripts/build.sh | tail -n 1)/src/polyrad"
fi
mkdir -p "$out"
light_samples="${LIGHT_SAMPLES:-4}"

# The scenes: sharp-lobe as shipped, and its contrast with the tall block rough; mesh paths made
# absolute so that both can live in DIR. Also, per scene, the object ids per pixel: every surface
# black and object n emitting n + 1, seen through pixel centres in flat shading (the rays
# `polyrad compare` labels its regions with).
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
    ids = copy.deepcopy(scene)
    ids["materials"] = {"black": {"type": "diffuse", "reflectance": [0, 0, 0]}}
    for n, o in enumerate(ids["objects"]):
        o["material"], o["emission"] = "black", [n + 1, 0, 0]
    json.dump(ids, open(f"{out}/{name}-ids.json", "w"), indent=1)
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
  "$POLYRAD" --quiet render "$out/$variant-ids.json" --classic --diffuse flat --pixel-grid 1 \
    -o "$out/$variant-ids.pfm" 2>/dev/null
  for size in "${sizes[@]}"; do
    base="$out/$variant-p$size"
    "$POLYRAD" --quiet render "$scene" --patch-size "$size" --tolerance 1e-6 -o "$base.pfm" \
      --light-samples "$light_samples" --report "$base.json" 2> "$base.stderr"
    "$POLYRAD" --quiet compare "$base.pfm" "$ref" --scene "$scene" --report "$base-cmp.json" \
      --side-by-side "$base-compare.png" >/dev/null
    /usr/bin/python3 - "$out" "$variant" "$size" "$ref" >> "$table.tmp" <<'PY'
import array, json, sys
out, variant, size, ref = sys.argv[1:]
base = f"{out}/{variant}-p{size}"

def pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        assert float(f.readline()) < 0  # little-endian
        v = array.array("f")
        v.frombytes(f.read(12 * w * h))
    return w, h, v

w, h, a = pfm(f"{base}.pfm")
_, _, b = pfm(ref)
_, _, ids = pfm(f"{out}/{variant}-ids.pfm")
label = [round(ids[3 * p]) - 1 for p in range(w * h)]
def region_l1(obj):
    # Pixels whose 3 x 3 neighbourhood sees the same object, as `polyrad compare` keeps them.
    diff = total = 0.0
    for y in range(1, h - 1):
        for x in range(1, w - 1):
            if any(label[(y + dy) * w + x + dx] != obj for dx in (-1, 0, 1) for dy in (-1, 0, 1)):
                continue
            for c in range(3):
                i = 3 * (y * w + x) + c
                diff += abs(a[i] - b[i])
                total += abs(b[i])
    return diff / total

r = json.load(open(f"{base}.json"))
c = json.load(open(f"{base}-cmp.json"))
names = [o["name"] for o in json.load(open(f"{out}/{variant}-ids.json"))["objects"]]
tall = next(x for x in r["lobe_resolution"] if x["object"] == "tall_block")
warned = any(x["object"] == "tall_block" for x in r["warnings"])
means = {g["name"]: g["luminance_difference"] for g in c["regions"]}
def region(name):
    return f"{100 * means[name]:+.1f}%, {region_l1(names.index(name)):.3f}"
alpha = tall["lobe"].split()[-1]
print(f"| alpha {alpha} | {size} | {r['patches']} | {tall['patch_angle_degrees']:.1f} vs "
      f"{tall['lobe_width_degrees']:.1f} deg, {'**warning**' if warned else 'no warning'} | "
      f"{c['relative_l1']:.3f} | {c['relative_rmse']:.3f} | {region('tall_block')} | "
      f"{region('floor')} | {region('short_block')} | {sum(r['seconds'].values()):.1f} |")
PY
  done
  notes+=("$(/usr/bin/python3 - "$variant" "$out/$variant-pt$spp.json" <<'PY'
import json, sys
variant, path = sys.argv[1:]
r = json.load(open(path))
print(f"Reference ({variant} tall block): {r['spp']} spp in {sum(r['seconds'].values()):.0f} s, "
      f"mean relative standard error {r['mean_relative_standard_error']:.3f}.")
PY
)")
done
{
  echo
  for n in "${notes[@]}"; do echo "$n"; done
  echo "Machine: $(/usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['machine'])" "$out/sharp-pt$spp.json")."
} >> "$table.tmp"
mv "$table.tmp" "$table"
cat "$table"
