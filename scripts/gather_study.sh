#!/usr/bin/env bash
# The final gather's sample counts against error and time: one `render` per setting of
# --gather-samples / --light-samples / --near-samples [/ --reflector-samples; the default when
# left out] (and the patch gather for scale) on each
# scene, compared with a path-traced reference; a table, a CSV and a chart of relative RMSE
# against the render's CPU seconds, each point labelled with its counts.
#
#   ./scripts/gather_study.sh [DIR] [SCENES...]
#     DIR     output (default out/gather): gather.md, gather.csv, gather.png, the images, reports
#     SCENES  default: cornell-box cornell-mirror-cube cornell-glossy
# References are DIR/../accuracy/SCENE-pt4096.exr when scripts/accuracy_study.sh made them, else
# rendered into DIR at 4096 spp (about 7 minutes a scene on two cores).
# $POLYRAD names the binary (default: a Release build through scripts/build.sh); $SETTINGS
# overrides the settings ("gather/light/near[/reflector] ...", default the eleven below).
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"
out="${1:-out/gather}"
shift $(( $# > 1 ? 1 : $# )) || true
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(cornell-box cornell-mirror-cube cornell-glossy)
need_polyrad
settings="${SETTINGS:-16/64/4 36/64/4 64/64/4 100/64/4 64/16/4 64/256/4 64/64/0 64/64/16 64/64/4/0 64/64/4/256 patch}"
mkdir -p "$out"
/usr/bin/python3 - "$POLYRAD" "$root" "$out" "$settings" "${scenes[@]}" <<'PY'
import json, os, resource, subprocess, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

polyrad, root, out, settings, scenes = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4].split(), sys.argv[5:]

def cpu_seconds(args):
    """Runs a command; returns the CPU seconds (user + system) it and its threads took."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)

rows = []
for scene in scenes:
    file = f"{root}/scenes/{scene}.json"
    ref = f"{out}/../accuracy/{scene}-pt4096.exr"
    if not os.path.exists(ref):
        ref = f"{out}/{scene}-pt4096.exr"
        if not os.path.exists(ref):
            print(f"gather_study: path tracing {scene} at 4096 spp", file=sys.stderr)
            subprocess.run([polyrad, "--quiet", "render", file, "--method", "pathtrace", "--spp", "4096",
                            "-o", ref], check=True)
    for s in settings:
        tag = s.replace("/", "-")
        counts = s.split("/")
        flags = ["--gather", "patch", "--mesh", "uniform"] if s == "patch" else \
            ["--gather", "final", "--gather-samples", counts[0], "--light-samples", counts[1],
             "--near-samples", counts[2]] + (["--reflector-samples", counts[3]] if len(counts) > 3 else [])
        img, rep, cmp = (f"{out}/{scene}-{tag}.exr", f"{out}/{scene}-{tag}.json", f"{out}/{scene}-{tag}-cmp.json")
        cpu = cpu_seconds([polyrad, "--quiet", "render", file, *flags, "-o", img, "--report", rep])
        subprocess.run([polyrad, "--quiet", "compare", img, ref, "--scene", file, "--report", cmp],
                       check=True, stdout=subprocess.DEVNULL)
        r, c = json.load(open(rep)), json.load(open(cmp))["comparison"]
        worst = max(c["regions"], key=lambda g: abs(g["luminance_difference"]))
        entries = r.get("gather", {}).get("nnz", 0)
        rows.append(dict(scene=scene, setting=s, cpu=cpu, wall=r["seconds"]["total"], rmse=c["relative_rmse"],
                         l1=c["relative_l1"], worst=f"{worst['name']} {100 * worst['luminance_difference']:+.2f}%",
                         entries=entries))
        print(f"gather_study: {scene} {s}: RMSE {c['relative_rmse']:.3f}, {cpu:.1f} CPU s", file=sys.stderr)

with open(f"{out}/gather.csv", "w") as f:
    f.write("scene,setting,cpu_s,wall_s,relative_rmse,relative_l1,gather_entries\n")
    for x in rows:
        f.write(f"{x['scene']},{x['setting']},{x['cpu']:.2f},{x['wall']:.2f},{x['rmse']:.4f},{x['l1']:.4f},{x['entries']}\n")
with open(f"{out}/gather.md", "w") as f:
    f.write("| scene | gather / light / near [/ reflector] samples | CPU s | wall s | relative RMSE | relative L1 | largest region difference |\n")
    f.write("|---|---|---|---|---|---|---|\n")
    for x in rows:
        f.write(f"| {x['scene']} | {x['setting']} | {x['cpu']:.1f} | {x['wall']:.1f} | {x['rmse']:.3f} | "
                f"{x['l1']:.3f} | {x['worst']} |\n")

fig, ax = plt.subplots(figsize=(8, 5))
for scene in scenes:
    pts = [x for x in rows if x["scene"] == scene]
    line = ax.plot([x["cpu"] for x in pts], [x["rmse"] for x in pts], "o", label=scene)[0]
    for x in pts:
        ax.annotate(x["setting"], (x["cpu"], x["rmse"]), fontsize=7, xytext=(3, 3),
                    textcoords="offset points", color=line.get_color())
ax.set_xscale("log")
ax.set_yscale("log")
ax.set_xlabel("CPU seconds of the whole render (two threads)")
ax.set_ylabel("relative RMSE against 4096 spp")
ax.set_title("Final gather: gather / light / near [/ reflector] samples against error and time")
ax.grid(True, which="both", alpha=0.3)
ax.legend()
fig.tight_layout()
fig.savefig(f"{out}/gather.png", dpi=110)
print(open(f"{out}/gather.md").read())
PY
