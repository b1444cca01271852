#!/usr/bin/env bash
# The memory estimate against the measured peak (README, "Memory"): each run's report gives
# system.estimated_memory_bytes, the estimate the run was let through with, and
# peak_memory_bytes, the process's peak resident set up to the report (the image written
# included).
#
#   ./scripts/memory_study.sh [DIR] [ROWS]
#     DIR   output (default out/memory): memory.md (the table), memory.csv, each run's report
#     ROWS  "quick" (the Cornell scenes, about 5 minutes on two cores) or "all" (default; the
#           room's renders and precomputes too, about 15 minutes more)
# $POLYRAD names the binary (default: a Release build through scripts/build.sh).
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
out="${1:-out/memory}"
rows="${2:-all}"
need_polyrad
mkdir -p "$out"
scenes="$root/scenes"

# at SCENE SIDE: a copy of SCENE seen at SIDE x SIDE pixels, its meshes found where they were.
at() {
  local copy="$out/$(basename "$1" .json)-$2.json"
  /usr/bin/python3 - "$1" "$2" "$copy" <<'EOF'
import json, os, sys
path, side, copy = sys.argv[1], int(sys.argv[2]), sys.argv[3]
scene = json.load(open(path))
scene["camera"]["width"] = scene["camera"]["height"] = side
for o in scene["objects"]:
    if isinstance(o.get("mesh"), str):
        o["mesh"] = os.path.join(os.path.dirname(os.path.abspath(path)), o["mesh"])
json.dump(scene, open(copy, "w"), indent=1)
EOF
  echo "$copy"
}

: > "$out/runs.tsv"
n=0
run() {  # [EXT=pfm] run LABEL COMMAND ARGS...: one run, its report kept as DIR/N.json
  local label="$1"
  shift
  n=$((n + 1))
  local output="$out/$n.${EXT:-exr}"
  [ "$1" = precompute ] && output="$out/$n.prt"
  echo "memory study: $label" >&2
  "$POLYRAD" --quiet "$@" -o "$output" --report "$out/$n.json" > /dev/null
  rm -f "$output"
  printf '%s\t%s\n' "$n" "$label" >> "$out/runs.tsv"
}

box="$scenes/cornell-box.json" mirror="$scenes/cornell-mirror-cube.json"
run "render cornell-box, uniform, patch gather" render "$box" --mesh uniform --gather patch
run "render cornell-box, uniform, patch size 25, patch gather" render "$box" --patch-size 25 --mesh uniform --gather patch
run "render cornell-box, uniform, patch size 17, patch gather" render "$box" --patch-size 17 --mesh uniform --gather patch
run "render cornell-mirror-cube (final gather)" render "$mirror"
run "render cornell-mirror-cube, uniform, patch size 35, patch gather" render "$mirror" --patch-size 35 --mesh uniform --gather patch
run "render cornell-mirror-cube, uniform, patch size 25, patch gather" render "$mirror" --patch-size 25 --mesh uniform --gather patch
run "render cornell-mirror-cube, uniform, patch size 17, patch gather" render "$mirror" --patch-size 17 --mesh uniform --gather patch
run "render cornell-glossy, patch size 35" render "$scenes/cornell-glossy.json" --patch-size 35
run "render cornell-box, hierarchical, tau 0.05" render "$box" --mesh hierarchical --link-tolerance 0.05
run "render cornell-mirror-cube, hierarchical, tau 0.05" render "$mirror" --mesh hierarchical --link-tolerance 0.05
run "render cornell-mirror-cube, hierarchical (the final gather's tau, 0.07)" render "$mirror" --mesh hierarchical
run "render cornell-box, hierarchical, tau 0.02" render "$box" --mesh hierarchical --link-tolerance 0.02
# To .pfm (no codec): the hierarchy's share is most of the peak.
EXT=pfm run "render cornell-box, hierarchical, no refinement pass (.pfm)" render "$box" \
  --mesh hierarchical --refine-passes 0
EXT=pfm run "render cornell-box, hierarchical (.pfm)" render "$box" --mesh hierarchical
EXT=pfm run "render cornell-mirror-cube, hierarchical, mesh mode, one pass (.pfm)" render \
  "$mirror" --mesh hierarchical --indirect mesh --refine-passes 1
big="$(at "$box" 1024)"
run "render cornell-box at 1024 x 1024, uniform, patch gather" render "$big" --mesh uniform --gather patch
run "render cornell-box at 1024 x 1024, final gather" render "$big"
run "precompute cornell-box at 512 x 512 (view rows)" precompute "$(at "$box" 512)"
run "precompute cornell-box at 1024 x 1024" precompute "$big"
run "precompute cornell-mirror-cube" precompute "$mirror"
if [ "$rows" = all ]; then
  room="$scenes/room.json"
  run "render room (uniform, final gather)" render "$room"
  run "render room, patch size 200" render "$room" --patch-size 200
  run "render room, hierarchical (the final gather's tau, 0.07)" render "$room" --mesh hierarchical
  run "render room, hierarchical, tau 0.05" render "$room" --mesh hierarchical --link-tolerance 0.05
  run "render room, hierarchical, tau 0.02" render "$room" --mesh hierarchical --link-tolerance 0.02
  run "precompute room" precompute "$room"
  run "precompute room, hierarchical (tau 0.07)" precompute "$room" --mesh hierarchical
fi
uptime > "$out/load.txt"

/usr/bin/python3 - "$out" <<'EOF'
import json, sys
out = sys.argv[1]
mib = 2.0**20
lines = ["| run | estimate (MiB) | peak (MiB) | ratio |", "|---|---|---|---|"]
csv = ["run,estimate_bytes,peak_bytes,ratio,system_bytes,camera_bytes"]
for row in open(f"{out}/runs.tsv"):
    n, label = row.rstrip("\n").split("\t")
    r = json.load(open(f"{out}/{n}.json"))
    est, peak = r["system"]["estimated_memory_bytes"], r["peak_memory_bytes"]
    lines.append(f"| {label} | {est / mib:,.0f} | {peak / mib:,.0f} | {est / peak:.2f} |")
    part = r["system"]["estimated_memory"]
    csv.append(f"\"{label}\",{est:.0f},{peak:.0f},{est / peak:.4f},"
               f"{part['system_bytes']:.0f},{part['camera_bytes']:.0f}")
machine = r["machine"]
lines.append("")
lines.append(f"{machine}; load before the last run: {open(f'{out}/load.txt').read().strip()}")
open(f"{out}/memory.md", "w").write("\n".join(lines) + "\n")
open(f"{out}/memory.csv", "w").write("\n".join(csv) + "\n")
print("\n".join(lines))
EOF
