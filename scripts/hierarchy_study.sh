#!/usr/bin/env bash
# Hierarchical against uniform meshes on one scene: elements, links, seconds per stage, peak
# memory and the image error against a path-traced reference through the same camera gather.
#
#   ./scripts/hierarchy_study.sh [DIR] [REFERENCE.exr] [SCENE]
#     DIR        output (default out/hierarchy): hierarchy.md, hierarchy.csv, the images, reports
#     REFERENCE  a path-traced reference of SCENE (default: DIR/SCENE-pt4096.exr, rendered if
#                missing, which takes about 20 minutes on two cores)
#     SCENE      default scenes/cornell-box.json (with lobes, e.g. cornell-mirror-cube, the
#                hierarchy carries them on root links)
# $POLYRAD names the binary (default: a Release build through scripts/build.sh);
# $UNIFORM_SIZES and $TOLERANCES override the runs (default "50 25 17" and "0.2 0.1 0.05 0.02");
# $GATHER the camera gather of every run (default final; patch reads the mesh at each pixel);
# $IMAGE the format each run writes (default exr; pfm needs no codec module, whose 110 MiB
# would otherwise sit in every run's peak).
# Also hierarchy.png: links, peak memory and wall time against elements for both meshes, and
# the image error against wall time.
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
out="${1:-out/hierarchy}"
scene="${3:-$root/scenes/cornell-box.json}"
name="$(basename "$scene" .json)"
ref="${2:-$out/$name-pt4096.exr}"
need_polyrad
mkdir -p "$out"
if [ ! -f "$ref" ]; then
  echo "hierarchy study: path tracing $name at 4096 spp" >&2
  "$POLYRAD" --quiet render "$scene" --method pathtrace --spp 4096 -o "$ref"
fi
gather="${GATHER:-final}"
run() {  # run TAG ARGS...: render, time it, compare with the reference
  local tag="$1"
  shift
  local img="$out/$name-$tag.${IMAGE:-exr}"
  /usr/bin/time -f "%e" -o "$out/$name-$tag.wall" "$POLYRAD" --quiet render "$scene" --tolerance 1e-6 \
    --gather "$gather" -o "$img" --report "$out/$name-$tag.json" "$@"
  "$POLYRAD" --quiet compare "$img" "$ref" --scene "$scene" --report "$out/$name-$tag-cmp.json" \
    --side-by-side "$out/$name-$tag-sbs.png" > /dev/null
  echo "$tag" >> "$out/runs.txt"
}
: > "$out/runs.txt"
for size in ${UNIFORM_SIZES:-50 25 17}; do
  run "uniform-$size" --mesh uniform --patch-size "$size"
done
for tol in ${TOLERANCES:-0.2 0.1 0.05 0.02}; do
  run "hierarchical-$tol" --mesh hierarchical --link-tolerance "$tol"
done
# The patch gather reads smooth B by default; the flat reading beside it.
[ "$gather" = patch ] && run "hierarchical-0.05-flat" --mesh hierarchical --link-tolerance 0.05 --diffuse flat
uptime > "$out/load.txt"
/usr/bin/python3 - "$out" "$name" "$gather" <<'EOF'
import json, sys
out, name = sys.argv[1], sys.argv[2]
rows = []
for tag in open(f"{out}/runs.txt").read().split():
    r = json.load(open(f"{out}/{name}-{tag}.json"))
    c = json.load(open(f"{out}/{name}-{tag}-cmp.json"))["comparison"]
    wall = float(open(f"{out}/{name}-{tag}.wall").read().split()[-1])
    s = r["seconds"]
    h = r["system"].get("hierarchy")
    if h:
        elements, links = h["leaves"], h["links"]
        build = s.get("hierarchy", 0.0)
        stages = (f"exposure {s.get('hierarchy_exposure', 0):.1f}, oracle {s.get('hierarchy_oracle', 0):.1f}, "
                  f"form factors {s.get('hierarchy_form_factors', 0):.1f}, operators {s.get('hierarchy_operators', 0):.1f}, "
                  f"pass solves {s.get('hierarchy_pass_solves', 0):.2f}")
        if "specular_transfer" in s:
            stages += f", transfer {s['specular_transfer']:.1f}"
    else:
        elements, links = r["system"]["patches"], r["system"]["form_factors"]["pairs_visible"]
        build = s.get("form_factors", 0.0) + s.get("specular_transfer", 0.0)
        stages = f"form factors {s.get('form_factors', 0.0):.1f}"
        if "specular_transfer" in s:
            stages += f", transfer {s['specular_transfer']:.1f}"
    regions = {x["name"]: x["luminance_difference"] for x in c["regions"]}
    worst = max(regions, key=lambda k: abs(regions[k]))
    rows.append(dict(tag=tag, elements=elements, links=links, slinks=r["system"]["links"],
                     build=build, stages=stages,
                     solve=s.get("solve", 0.0), gather=s.get("gather_build", 0.0), wall=wall,
                     peak=r["peak_memory_bytes"] / 2**30, rmse=c["relative_rmse"],
                     mre=c["mean_relative_error"], l1=c["relative_l1"], worst=worst,
                     worst_diff=regions[worst], regions=regions))
with open(f"{out}/hierarchy.md", "w") as f:
    f.write("| run | elements | links | specular links | build (s): stages | solve (s) | gather (s) | wall (s) "
            "| peak (GiB) | relative RMSE | mean relative error | relative L1 | largest region difference |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    for x in rows:
        f.write(f"| {x['tag']} | {x['elements']} | {x['links']} | {x['slinks']} | {x['build']:.1f}: {x['stages']} | "
                f"{x['solve']:.2f} | {x['gather']:.2f} | {x['wall']:.1f} | {x['peak']:.2f} | {x['rmse']:.3f} | "
                f"{x['mre']:.3f} | {x['l1']:.3f} | {x['worst']} {100 * x['worst_diff']:+.2f}% |\n")
    f.write("\nRegion means against the reference (luminance, percent):\n\n")
    names = list(rows[0]["regions"])
    f.write("| run | " + " | ".join(names) + " |\n|---|" + "---|" * len(names) + "\n")
    for x in rows:
        f.write(f"| {x['tag']} | " + " | ".join(f"{100 * x['regions'][n]:+.2f}" for n in names) + " |\n")
with open(f"{out}/hierarchy.csv", "w") as f:
    f.write("run,elements,links,specular_links,build_s,solve_s,gather_s,wall_s,peak_gib,relative_rmse,mean_relative_error,relative_l1\n")
    for x in rows:
        f.write(f"{x['tag']},{x['elements']},{x['links']},{x['slinks']},{x['build']:.3f},{x['solve']:.3f},{x['gather']:.3f},"
                f"{x['wall']:.2f},{x['peak']:.3f},{x['rmse']:.4f},{x['mre']:.4f},{x['l1']:.4f}\n")
print(open(f"{out}/hierarchy.md").read())

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
fig, axes = plt.subplots(1, 4, figsize=(17, 4.2))
kinds = [("uniform", "o-", "uniform (patch size)"), ("hierarchical", "s-", "hierarchical (link tolerance)")]
panels = [("links", "links (visible pairs / element links)"), ("peak", "peak memory (GiB)"),
          ("wall", "wall time of the render (s)")]
for ax, (key, label) in zip(axes, panels):
    for kind, style, legend in kinds:
        pts = sorted((x for x in rows if x["tag"].startswith(kind) and not x["tag"].endswith("flat")),
                     key=lambda x: x["elements"])
        if not pts:
            continue
        ax.plot([x["elements"] for x in pts], [x[key] for x in pts], style, label=legend)
        for x in pts:
            ax.annotate(x["tag"].split("-")[1], (x["elements"], x[key]), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
    if key == "links":  # slopes 1 and 2 through the first uniform point, for the eye
        u = [x for x in rows if x["tag"].startswith("uniform")]
        if u:
            x0, y0 = u[0]["elements"], u[0]["links"]
            xs = [x0, max(x["elements"] for x in rows)]
            ax.plot(xs, [y0 * (v / x0) for v in xs], ":", color="grey", label="slope 1")
            ax.plot(xs, [y0 * (v / x0) ** 2 for v in xs], "--", color="grey", label="slope 2")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("elements (patches or leaves)")
    ax.set_ylabel(label)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
ax = axes[3]
for kind, style, legend in kinds:
    pts = sorted((x for x in rows if x["tag"].startswith(kind) and not x["tag"].endswith("flat")),
                 key=lambda x: x["wall"])
    if pts:
        ax.plot([x["wall"] for x in pts], [x["rmse"] for x in pts], style, label=legend)
        for x in pts:
            ax.annotate(x["tag"].split("-")[1], (x["wall"], x["rmse"]), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
ax.set_xscale("log")
ax.set_xlabel("wall time of the render (s)")
ax.set_ylabel("relative RMSE against the reference")
ax.grid(True, which="both", alpha=0.3)
ax.legend(fontsize=7)
fig.suptitle(f"{name}: uniform against hierarchical meshes, {sys.argv[3]} gather")
fig.tight_layout()
fig.savefig(f"{out}/hierarchy.png", dpi=100)
EOF
