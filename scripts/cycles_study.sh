#!/usr/bin/env bash
# Blender Cycles beside polyrad on the same scene (docs/cycles-study.md). Cycles renders a
# polyrad scene through scripts/cycles_render.py (run inside Blender); polyrad's path tracer
# and `polyrad compare` judge the result.
#
#   ./scripts/cycles_study.sh render SCENE OUT.exr SPP [THREADS [ARGS...]]
#       one Cycles render (ARGS go to cycles_render.py); prints the whole process's wall time,
#       Blender's start included
#   ./scripts/cycles_study.sh validate [DIR] [SPP]
#       cornell-box, cornell-glossy (Phong as Beckmann) and cornell-glossy-ggx (made in DIR: its
#       Phong block GGX too): Cycles and polyrad's path tracer at SPP (default 1024), compared;
#       polyrad at a second seed gives the noise floor. Table in DIR/validate.md
#   ./scripts/cycles_study.sh room [DIR] [SPP] [REF_SPP]
#       the room: Cycles at SPP (default 512) on 2 threads, timed, against a Cycles reference
#       at REF_SPP (default 4096; rendered once and kept in DIR). Table in DIR/room.md
#
# DIR defaults to out/cycles. Renders already in DIR are reused (delete them to render again).
# $POLYRAD names polyrad's binary (default: a Release build through scripts/build.sh),
# $BLENDER Blender's (default: blender, installed with apt-get when missing), $NICE a niceness
# for the long renders (default 10). Timings are only as good as the machine is quiet.
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
mode="${1:-}"
shift || true
NICE="${NICE:-10}"
BLENDER="${BLENDER:-blender}"

usage() { sed -n '6,15p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }

need_blender() {
  if ! command -v "$BLENDER" >/dev/null; then
    echo "cycles study: installing blender" >&2
    sudo_cmd=()
    if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
    DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y --no-install-recommends \
      blender >&2
  fi
}

# cycles SCENE OUT SPP THREADS [ARGS...]: renders (ARGS go to cycles_render.py), leaves
# OUT.log, prints the whole process's seconds.
cycles() {
  local scene="$1" out="$2" spp="$3" threads="$4"
  shift 4
  local t0 t1
  t0=$(date +%s.%N)
  nice -n "$NICE" "$BLENDER" -b --factory-startup -noaudio -t "$threads" --python-exit-code 1 \
    -P "$root/scripts/cycles_render.py" -- "$scene" -o "$out" --spp "$spp" \
    --threads "$threads" "$@" > "$out.log" 2>&1 || { tail -n 20 "$out.log" >&2; exit 1; }
  t1=$(date +%s.%N)
  python3 -c "print(f'{$t1 - $t0:.2f}')" | tee "$out.seconds"
}

# polyrad_pt SCENE OUT SPP SEED: path traced by polyrad (kept when present).
polyrad_pt() {
  local scene="$1" out="$2" spp="$3" seed="$4"
  if [ ! -f "$out" ]; then
    echo "cycles study: polyrad path tracing $(basename "$scene") at $spp spp, seed $seed" >&2
    nice -n "$NICE" "$POLYRAD" --quiet render "$scene" --method pathtrace --spp "$spp" \
      --seed "$seed" -o "$out" --report "${out%.exr}.json" >&2
  fi
}

compare() {  # compare A B SCENE REPORT
  "$POLYRAD" --quiet compare "$1" "$2" --scene "$3" --report "$4" \
    --side-by-side "${4%.json}.png" > "${4%.json}.txt"
}

load() { cut -d' ' -f1 /proc/loadavg; }

case "$mode" in
render)
  [ $# -ge 3 ] || usage
  need_blender
  s=$(cycles "$1" "$2" "$3" "${4:-0}" "${@:5}")
  grep '^cycles:' "$2.log"
  echo "whole process: $s s (load average $(load))"
  ;;

validate)
  need_blender
  need_polyrad
  out="${1:-out/cycles}"
  spp="${2:-1024}"
  mkdir -p "$out"
  # cornell-glossy with its Phong block GGX as well (the tall block's material): the GGX
  # mapping on its own, without the Phong approximation's light.
  python3 - "$root/scenes/cornell-glossy.json" "$out/cornell-glossy-ggx.json" <<'PY'
import json, os, sys
src, dst = sys.argv[1:]
s = json.load(open(src))
for o in s["objects"]:
    if "mesh" in o:
        o["mesh"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(src)), o["mesh"]))
    if o["name"] == "short_block":
        o["material"] = "gloss"
json.dump(s, open(dst, "w"), indent=1)
PY
  for name in cornell-box cornell-glossy cornell-glossy-ggx; do
    scene="$root/scenes/$name.json"
    [ -f "$scene" ] || scene="$out/$name.json"
    polyrad_pt "$scene" "$out/$name-polyrad-pt$spp.exr" "$spp" 1
    polyrad_pt "$scene" "$out/$name-polyrad-pt$spp-seed2.exr" "$spp" 2
    if [ ! -f "$out/$name-cycles$spp.exr" ]; then
      echo "cycles study: Cycles on $name at $spp spp" >&2
      cycles "$scene" "$out/$name-cycles$spp.exr" "$spp" 0 --phong beckmann > /dev/null
      load > "$out/$name-cycles$spp.exr.load"
    fi
    compare "$out/$name-cycles$spp.exr" "$out/$name-polyrad-pt$spp.exr" "$scene" \
      "$out/$name-cycles-vs-polyrad.json"
    compare "$out/$name-polyrad-pt$spp-seed2.exr" "$out/$name-polyrad-pt$spp.exr" "$scene" \
      "$out/$name-seed2-vs-seed1.json"
  done
  python3 - "$out" "$spp" > "$out/validate.md" <<'PY'
import json, re, sys
out, spp = sys.argv[1:]
print(f"Cycles against polyrad's path tracer, both at {spp} spp; the noise floor is polyrad at "
      "seed 2 against seed 1. Region columns: mean luminance, A / B - 1. cornell-glossy's "
      "short block is Phong, which Cycles approximates (Beckmann); cornell-glossy-ggx has it "
      "GGX as well.\n")
for name in ("cornell-box", "cornell-glossy", "cornell-glossy-ggx"):
    cy = json.load(open(f"{out}/{name}-cycles-vs-polyrad.json"))
    fl = json.load(open(f"{out}/{name}-seed2-vs-seed1.json"))
    pt = json.load(open(f"{out}/{name}-polyrad-pt{spp}.json"))
    log = open(f"{out}/{name}-cycles{spp}.exr.log").read()
    m = re.search(r"render ([0-9.]+) s", log)
    whole = open(f"{out}/{name}-cycles{spp}.exr.seconds").read().strip()
    print(f"**{name}** (Cycles: render {m.group(1)} s, whole process {whole} s; polyrad path "
          f"tracer {sum(pt['seconds'].values()):.0f} s)\n")
    print("| | relative RMSE | relative L1 | worst region |" +
          "".join(f" {r['name']} |" for r in cy["regions"]))
    print("|---" * (4 + len(cy["regions"])) + "|")
    for label, c in (("Cycles vs polyrad", cy), ("polyrad seed 2 vs seed 1", fl)):
        print(f"| {label} | {c['relative_rmse']:.4f} | {c['relative_l1']:.4f} | "
              f"{100 * c['worst_region_difference']:.2f}% |" +
              "".join(f" {100 * r['luminance_difference']:+.2f}% |" for r in c["regions"]))
    print()
PY
  cat "$out/validate.md"
  ;;

room)
  need_blender
  need_polyrad
  out="${1:-out/cycles}"
  spp="${2:-512}"
  ref_spp="${3:-4096}"
  scene="$root/scenes/room.json"
  mkdir -p "$out"
  # The timed render first, so that the long reference does not share the machine with it.
  echo "cycles study: Cycles on the room at $spp spp, 2 threads" >&2
  load > "$out/room-cycles$spp.exr.load"
  cycles "$scene" "$out/room-cycles$spp.exr" "$spp" 2 > /dev/null
  ref="$out/room-cycles$ref_spp.exr"
  if [ ! -f "$ref" ]; then
    echo "cycles study: Cycles reference of the room at $ref_spp spp (long)" >&2
    load > "$ref.load"
    cycles "$scene" "$ref" "$ref_spp" 0 > /dev/null
  fi
  # polyrad's first image with its defaults, the whole process timed on the same 2 threads and
  # niceness, then the precompute and one relight: how many relights the precompute pays for.
  echo "cycles study: polyrad on the room, defaults, 2 threads" >&2
  load > "$out/room-polyrad.exr.load"
  t0=$(date +%s.%N)
  OMP_NUM_THREADS=2 nice -n "$NICE" "$POLYRAD" --quiet render "$scene" -o "$out/room-polyrad.exr" \
    --report "$out/room-polyrad.json"
  t1=$(date +%s.%N)
  python3 -c "print(f'{$t1 - $t0:.2f}')" > "$out/room-polyrad.exr.seconds"
  t0=$(date +%s.%N)
  OMP_NUM_THREADS=2 nice -n "$NICE" "$POLYRAD" --quiet precompute "$scene" -o "$out/room.prt" \
    --report "$out/room-precompute.json"
  t1=$(date +%s.%N)
  python3 -c "print(f'{$t1 - $t0:.2f}')" > "$out/room.prt.seconds"
  OMP_NUM_THREADS=2 "$POLYRAD" --quiet relight "$out/room.prt" -o "$out/room-relit.exr" \
    --report "$out/room-relight.json"
  compare "$out/room-polyrad.exr" "$ref" "$scene" "$out/room-polyrad-vs-ref.json"
  compare "$out/room-cycles$spp.exr" "$ref" "$scene" "$out/room-cycles$spp-vs-ref.json"
  python3 - "$out" "$spp" "$ref_spp" > "$out/room.md" <<'PY'
import json, math, re, sys
out, spp, ref_spp = sys.argv[1:]
def timing(path):
    log = open(path + ".log").read()
    m = re.search(r"scene ([0-9.]+) s, render ([0-9.]+) s", log)
    whole = float(open(path + ".seconds").read())
    return f"scene {m.group(1)} s, render {m.group(2)} s, whole process {whole:.1f} s"
c = json.load(open(f"{out}/room-cycles{spp}-vs-ref.json"))["comparison"]
print(f"- Cycles at {spp} spp, 2 threads: {timing(f'{out}/room-cycles{spp}.exr')} "
      f"(load average before: {open(f'{out}/room-cycles{spp}.exr.load').read().strip()})")
print(f"- reference, Cycles at {ref_spp} spp: {timing(f'{out}/room-cycles{ref_spp}.exr')}")
print(f"- {spp} spp against the reference: relative RMSE {c['relative_rmse']:.4f}, relative L1 "
      f"{c['relative_l1']:.4f}, worst region {100 * c['worst_region_difference']:.2f}%")
p = json.load(open(f"{out}/room-polyrad-vs-ref.json"))["comparison"]
r = json.load(open(f"{out}/room-polyrad.json"))
whole = float(open(f"{out}/room-polyrad.exr.seconds").read())
print(f"- polyrad, defaults ({r['system']['mesh']} mesh, {r['gather']['options']['kind']} gather, "
      f"{r['system']['patches']} patches), 2 threads: whole process {whole:.1f} s, peak "
      f"{r['peak_memory_bytes'] / 2**30:.2f} GiB (load average before: "
      f"{open(f'{out}/room-polyrad.exr.load').read().strip()})")
print(f"- polyrad against the reference: relative RMSE {p['relative_rmse']:.4f}, relative L1 "
      f"{p['relative_l1']:.4f}, worst region {100 * p['worst_region_difference']:.2f}%")
pre = float(open(f"{out}/room.prt.seconds").read())
rel = json.load(open(f"{out}/room-relight.json"))["relight"]
product = rel["product_seconds_median"]
pays = math.ceil(pre / max(whole - product, 1e-9))
print(f"- precompute (view rows, final gather): whole process {pre:.1f} s; a relight's product "
      f"{1e3 * product:.2f} ms against {whole:.1f} s for a new render: the precompute pays for "
      f"itself after {pays} change(s) of lights")
PY
  cat "$out/room.md"
  ;;

*) usage ;;
esac
