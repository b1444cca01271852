#!/usr/bin/env bash
# Copies the pictures the README shows from out/ into docs/images/, composing a few strips.
# Everything comes from the project's own runs, never from hand-edited numbers:
#   out/*.png                  ./scripts/demo.sh          (demo images, relit images)
#   out/charts/*.png           ./scripts/demo.sh          (sweep charts), and
#                              polyrad convergence + scripts/convergence_chart.py (convergence.png)
#   out/accuracy/*             ./scripts/accuracy_study.sh (radiosity | path traced | error)
#   out/gather/gather.png      ./scripts/gather_study.sh  (final gather samples: error against time)
#   out/lobe/*                 ./scripts/lobe_study.sh    (coarse mesh under a sharp lobe)
#   out/lobe-nolight/*         LIGHT_SAMPLES=0 ./scripts/lobe_study.sh out/lobe-nolight
# A missing source is skipped with a note, so the script can refresh part of the pictures.
set -euo pipefail
cd "$(dirname "$0")/.."
polyrad="${POLYRAD:-build/release/src/polyrad}"
dst=docs/images
mkdir -p "$dst"

copy() {  # copy SRC DST-NAME
  if [ -f "$1" ]; then cp "$1" "$dst/$2"; echo "readme_images: $dst/$2"; else echo "readme_images: skipped $2 ($1 missing)" >&2; fi
}

copy out/compare.png mirror-cube-compare.png
copy out/gather/gather.png gather-samples.png
copy out/hierarchy-mirror/hierarchy.png hierarchy-mirror.png  # ./scripts/hierarchy_study.sh on the mirror cube
for c in error_vs_time error_vs_order cost_vs_patches convergence; do copy "out/charts/$c.png" "$c.png"; done

# Strips: images side by side (--row) or one above the other (--column), 6 px white gaps.
strip() {
  /usr/bin/python3 - "$@" <<'EOF'
import sys
import matplotlib.image as mpimg
import numpy as np
mode, out, files = sys.argv[1], sys.argv[2], sys.argv[3:]
ims = [mpimg.imread(f)[..., :3] for f in files]
axis = 1 if mode == "--row" else 0
shape = list(ims[0].shape)
shape[axis] = 6
gap = np.ones(shape, dtype=ims[0].dtype)
parts = []
for im in ims:
    parts += [im, gap]
mpimg.imsave(out, np.concatenate(parts[:-1], axis=axis))
print("readme_images:", out)
EOF
}

relit=(out/radiosity.png out/relit-as-scene.png out/relit-double.png out/relit-blue.png)
if [ -f "${relit[3]}" ]; then strip --row "$dst/relit.png" "${relit[@]}"; fi

# Both gathers beside the path tracer, top to bottom: the patch gather at the default patch
# size 50, the final gather at 50, and the final gather at 100 (240 patches).
for scene in cornell-box cornell-mirror-cube cornell-glossy; do
  files=()
  for run in p50-patch-smooth p50-final p100-final; do files+=("out/accuracy/$scene-$run-compare.png"); done
  if [ -f "${files[0]}" ] && [ -f "${files[1]}" ] && [ -f "${files[2]}" ]; then
    strip --column "$dst/accuracy-$scene.png" "${files[@]}"
  else
    echo "readme_images: skipped accuracy-$scene.png (run scripts/accuracy_study.sh)" >&2
  fi
done

# Coarse mesh under a sharp lobe: scenes/stability/sharp-lobe at patch sizes 100 (warned) and 25.
lobe=(out/lobe/sharp-p100-compare.png out/lobe/sharp-p25-compare.png)
if [ -f "${lobe[0]}" ] && [ -f "${lobe[1]}" ]; then
  strip --column "$dst/sharp-lobe.png" "${lobe[@]}"
else
  echo "readme_images: skipped sharp-lobe.png (run scripts/lobe_study.sh)" >&2
fi

# The camera gather without and with points on the lights: sharp-lobe at patch size 25.
lights=(out/lobe-nolight/sharp-p25-compare.png out/lobe/sharp-p25-compare.png)
if [ -f "${lights[0]}" ] && [ -f "${lights[1]}" ]; then
  strip --column "$dst/light-samples.png" "${lights[@]}"
else
  echo "readme_images: skipped light-samples.png (run LIGHT_SAMPLES=0 scripts/lobe_study.sh out/lobe-nolight)" >&2
fi

# Where the mirror cube adds light: each mirror-cube image against the same box with a diffuse
# short block, radiosity (patch size 25) and path traced (4096 spp); red where the mirror adds.
rad_m=out/accuracy/cornell-mirror-cube-p25-patch-smooth.exr rad_d=out/accuracy/cornell-box-p25-patch-smooth.exr
pt_m=out/accuracy/cornell-mirror-cube-pt4096.exr pt_d=out/accuracy/cornell-box-pt4096.exr
if [ -f "$rad_m" ] && [ -f "$rad_d" ] && [ -f "$pt_m" ] && [ -f "$pt_d" ]; then
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  "$polyrad" --quiet compare "$rad_m" "$rad_d" --heatmap "$tmp/rad.png" --error-scale 1 >/dev/null
  "$polyrad" --quiet compare "$pt_m" "$pt_d" --heatmap "$tmp/pt.png" --error-scale 1 >/dev/null
  strip --row "$dst/caustics.png" "$tmp/rad.png" "$tmp/pt.png"
else
  echo "readme_images: skipped caustics.png (run scripts/accuracy_study.sh)" >&2
fi
