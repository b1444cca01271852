#!/usr/bin/env python3
"""The charts of a polyrad sweep: speed against accuracy, drawn from DIR/sweep.csv.

    /usr/bin/python3 scripts/charts.py DIR [--out OUTDIR]

Reads DIR/sweep.csv and DIR/machine.txt (written by `polyrad sweep SCENE --out DIR`) and writes
three PNG files into OUTDIR (default DIR):
  error_vs_time.png     error against time per image, log-log, one series per method, with the
                        Pareto front and where the precomputed product is on it;
  error_vs_order.png    error against the order K, the a-priori bound a^(K+1)/(1-a) beside it;
  cost_vs_patches.png   precompute time, operator bytes and time per image against patch count.
Every number comes from the CSV; nothing is typed in by hand. Exit code 2 when the CSV lacks a
column these charts read (the list is COLUMNS below, which tests/sweep_test.cpp checks too).
"""
import argparse
import csv
import math
import os
import sys
import textwrap

try:
    import matplotlib
    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt
except ImportError as e:  # a listed dependency: scripts/deps.sh installs python3-matplotlib
    sys.exit(f"charts.py: matplotlib is missing ({e}); install python3-matplotlib (scripts/deps.sh)")

# The columns the charts read.
COLUMNS = [
    "method", "patch_size_scene_units", "patches", "order_K", "drop_fraction", "precision",
    "sweeps", "spp", "image_seconds", "precompute_seconds", "system_build_seconds",
    "gather_build_seconds", "operator_bytes", "a_max", "apriori_bound_rel",
    "aposteriori_estimate_rel", "solution_error_flux_rel", "error_vs_converged_rel_l1",
    "error_vs_reference_rel_l1",
]
TEXT_COLUMNS = {"method", "precision", "mesh"}  # "mesh" and "link_tolerance" may be absent

# One colour and marker per method, used in every chart.
STYLE = {
    "series": dict(color="tab:blue", marker="o", label="relight product (precomputed series)"),
    "jacobi": dict(color="tab:orange", marker="s", label="Jacobi, n sweeps"),
    "gauss-seidel": dict(color="tab:green", marker="^", label="Gauss-Seidel, n sweeps"),
    "pathtrace": dict(color="tab:red", marker="D", label="path tracer, n spp"),
    "converged": dict(color="black", marker="*", label="Gauss-Seidel to residual 1e-9"),
}


def read_rows(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            print(f"charts.py: {path} lacks the columns {', '.join(missing)}", file=sys.stderr)
            sys.exit(2)
        rows = []
        for raw in reader:
            row = {}
            for k, v in raw.items():
                if k in TEXT_COLUMNS:
                    row[k] = v
                else:
                    row[k] = float(v) if v not in ("", None) else math.nan
            rows.append(row)
    if not rows:
        print(f"charts.py: {path} has no rows", file=sys.stderr)
        sys.exit(2)
    return rows


def read_machine(path):
    info = {}
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                key, _, value = line.partition(":")
                if value:
                    info[key.strip()] = value.strip()
    return info


def caption(fig, info):
    parts = [
        f"scene {info.get('scene', '?')} ({info.get('camera', '?')} pixels)",
        f"{info.get('machine', 'unknown machine')}, {info.get('threads', '?')} threads",
        f"load average {info.get('load_average', '?')}",
        f"reference: {info.get('reference', '?')}",
        f"timings: median of {info.get('timing_repeats', '?')} repeats",
        f"{info.get('date', '')}",
    ]
    text = "\n".join(textwrap.wrap("; ".join(parts), 170))
    fig.text(0.5, 0.005, text, ha="center", va="bottom", fontsize=7.5, color="0.3")


def discretisation(r):
    """The mesh a row belongs to, as a sort key: uniform meshes from coarse to fine, then the
    hierarchical ones by root patch size and link tolerance (older sweeps have no mesh column)."""
    tol = r.get("link_tolerance", math.nan)
    hierarchical = r.get("mesh", "uniform") == "hierarchical"
    return (1 if hierarchical else 0, -r["patch_size_scene_units"], -(tol if finite(tol) else 0.0))


def discretisation_title(sel):
    r = sel[0]
    patches = int(r["patches"])
    if r.get("mesh", "uniform") == "hierarchical":
        return (f"hierarchical, tau {r['link_tolerance']:g}, roots of size "
                f"{r['patch_size_scene_units']:g} ({patches} leaves)")
    return f"patch size {r['patch_size_scene_units']:g} ({patches} patches)"


def finite(x):
    return isinstance(x, float) and math.isfinite(x)


def fmt_seconds(t):
    if t < 1e-3:
        return f"{t * 1e6:.0f} µs"
    if t < 1:
        return f"{t * 1e3:.3g} ms"
    return f"{t:.3g} s"


def knob_label(r):
    m = r["method"]
    if m == "series":
        return f"product K={r['order_K']:.0f}"
    if m in ("jacobi", "gauss-seidel"):
        return f"{m} {r['sweeps']:.0f} sweeps"
    if m == "pathtrace":
        return f"path tracer {r['spp']:.0f} spp"
    return "Gauss-Seidel to 1e-9"


def baseline_variant(rows):
    """The (drop, precision) of the plainest product in the sweep: smallest drop, float if any."""
    series = [r for r in rows if r["method"] == "series"]
    if not series:
        return None
    drop = min(r["drop_fraction"] for r in series)
    precisions = {r["precision"] for r in series}
    return drop, ("float" if "float" in precisions else sorted(precisions)[0])


def variants(rows):
    seen = []
    for r in rows:
        if r["method"] == "series" and (r["drop_fraction"], r["precision"]) not in seen:
            seen.append((r["drop_fraction"], r["precision"]))
    return sorted(seen, key=lambda v: (v[1] != "float", v[0]))


def pareto_front(points):
    """Points (time, error, row) not beaten by any faster point, in order of time."""
    front = []
    for p in sorted(points, key=lambda p: (p[0], p[1])):
        if not front or p[1] < front[-1][1]:
            front.append(p)
    return front


# ---- chart (a): error against time -------------------------------------------------------------

def error_levels(lo, hi, n=4):
    """Up to n round error levels in [lo, hi], largest first: the practical decades 10% to 0.01%
    (and 1e-6) over a wide range, finer steps over a narrow one (the error against the
    path-traced reference spans less than a decade: the discretisation error is its floor)."""
    if hi > 100 * lo:
        cands = [x for x in (1e-6, 1e-4, 1e-3, 1e-2, 1e-1) if lo <= x <= hi]
        n = len(cands)
    else:
        steps = (1.0, 1.5, 2.0, 3.0, 5.0, 7.0)
        cands = sorted(m * 10.0 ** k for k in range(-16, 3) for m in steps if lo <= m * 10.0 ** k <= hi)
    if len(cands) > n:
        cands = [cands[round(i * (len(cands) - 1) / (n - 1))] for i in range(n)]
    return sorted(set(cands), reverse=True)


def speedup_table(points):
    """Where the product wins and by how much: at round error levels, the fastest product point
    and the fastest other point with at most that error, their ratio, and after how many relights
    the precompute has paid for itself. Returns text lines."""
    product = [p for p in points if p[2]["method"] == "series"]
    other = [p for p in points if p[2]["method"] != "series"]
    if not product:
        return ["no relight product in this panel"]
    lo = min(p[1] for p in points)
    hi = max(p[1] for p in pareto_front(points) if p[2]["method"] == "series") \
        if any(p[2]["method"] == "series" for p in pareto_front(points)) else max(p[1] for p in product)
    lines = ["time to reach an error of at most:"]
    for level in error_levels(lo, hi):
        fp = min((p for p in product if p[1] <= level), key=lambda p: p[0], default=None)
        fo = min((p for p in other if p[1] <= level), key=lambda p: p[0], default=None)
        head = f"{level:<7.2g} "
        if fp and fo:
            tp, _, rp = fp
            to, _, ro = fo
            line = (f"{head}product {fmt_seconds(tp)} ({knob_label(rp)}) vs "
                    f"{fmt_seconds(to)} ({knob_label(ro)}): {to / tp:.3g}x")
            if to > tp and finite(rp["precompute_seconds"]):
                line += f", precompute repaid after {math.ceil(rp['precompute_seconds'] / (to - tp))} relights"
        elif fp:
            tp, _, rp = fp
            line = f"{head}product {fmt_seconds(tp)} ({knob_label(rp)}); no other method in the sweep gets there"
        elif fo:
            to, _, ro = fo
            line = f"{head}only {knob_label(ro)}, {fmt_seconds(to)}; no product in the sweep gets there"
        else:
            continue
        lines.append(line)
    return lines


def error_time_panel(ax, rows, error_key, title, with_converged):
    points = []
    base = baseline_variant(rows)
    for drop, precision in variants(rows):
        sel = sorted((r for r in rows if r["method"] == "series" and r["drop_fraction"] == drop
                      and r["precision"] == precision), key=lambda r: r["order_K"])
        sel = [r for r in sel if finite(r[error_key]) and r[error_key] > 0]
        if not sel:
            continue
        plain = (drop, precision) == base
        style = dict(STYLE["series"])
        label = f"relight product, drop {drop:g}, {precision}"
        ax.plot([r["image_seconds"] for r in sel], [r[error_key] for r in sel],
                color=style["color"], marker=style["marker"], label=label,
                alpha=1.0 if plain else 0.45, lw=1.6 if plain else 0.9, ms=5 if plain else 3.5,
                mfc=style["color"] if precision == "float" else "white",
                ls="-" if drop == base[0] else "--")
        if plain:
            for r in sel:
                ax.annotate(f"K={r['order_K']:.0f}", (r["image_seconds"], r[error_key]),
                            textcoords="offset points", xytext=(4, 3), fontsize=6.5,
                            color=style["color"])
        points += [(r["image_seconds"], r[error_key], r) for r in sel]
    for method, knob, fmt in (("jacobi", "sweeps", "n={:.0f}"), ("gauss-seidel", "sweeps", "n={:.0f}"),
                              ("pathtrace", "spp", "{:.0f} spp")):
        sel = sorted((r for r in rows if r["method"] == method), key=lambda r: r[knob])
        sel = [r for r in sel if finite(r[error_key]) and r[error_key] > 0]
        if not sel:
            continue
        style = STYLE[method]
        ax.plot([r["image_seconds"] for r in sel], [r[error_key] for r in sel], color=style["color"],
                marker=style["marker"], label=style["label"], ms=4.5, lw=1.2)
        for r in sel:
            ax.annotate(fmt.format(r[knob]), (r["image_seconds"], r[error_key]),
                        textcoords="offset points", xytext=(4, -8), fontsize=6.5, color=style["color"])
        points += [(r["image_seconds"], r[error_key], r) for r in sel]
    if with_converged:
        for r in rows:
            if r["method"] == "converged" and finite(r[error_key]) and r[error_key] > 0:
                ax.plot([r["image_seconds"]], [r[error_key]], ls="none", ms=11, **STYLE["converged"])
                ax.axhline(r[error_key], color="0.5", lw=0.8, ls=":")
                ax.annotate("discretisation error (converged solution)", (0.0, r[error_key]),
                            xycoords=("axes fraction", "data"), xytext=(4, 3),
                            textcoords="offset points", fontsize=6.5, color="0.4")
                points.append((r["image_seconds"], r[error_key], r))
    points = [p for p in points if finite(p[0]) and p[0] > 0]
    if not points:
        ax.set_title(title + "\n(no points)")
        return
    ax.set_xscale("log")
    ax.set_yscale("log")
    front = pareto_front(points)
    x_max = max(p[0] for p in points) * 3
    ts = [p[0] for p in front] + [x_max]
    es = [p[1] for p in front] + [front[-1][1]]
    ax.step(ts, es, where="post", color="black", lw=1.3, alpha=0.8, label="Pareto front", zorder=5)
    shaded = False
    for i, (t, e, r) in enumerate(front):
        if r["method"] == "series":
            ax.axvspan(t, ts[i + 1], color="tab:blue", alpha=0.09, lw=0,
                       label=None if shaded else "time budgets where the product is best")
            shaded = True
    # The table goes under the panel, where it hides no point.
    ax.text(0.0, -0.13, "\n".join(speedup_table(points)), transform=ax.transAxes, va="top",
            ha="left", family="monospace", fontsize=6.6,
            bbox=dict(boxstyle="round", fc="white", ec="tab:blue", alpha=0.95))
    ax.set_xlim(min(p[0] for p in points) / 3, x_max)
    ax.set_title(title, fontsize=9.5)
    ax.set_xlabel("time per image after a change of lights (s, log)")
    ax.grid(True, which="major", alpha=0.3)
    ax.grid(True, which="minor", alpha=0.1)


def chart_error_vs_time(rows, info, out):
    sizes = sorted({discretisation(r) for r in rows})
    height = 7.0 * len(sizes) + 1.6  # panels, then 1.2 in of title and legend, 0.4 of caption
    fig, axes = plt.subplots(len(sizes), 2, figsize=(15, height), squeeze=False)
    ylabel = "relative L1 error of the image, sum|a-b| / sum|b| (log)"
    reference = info.get("reference", "").split(",")[1:2]
    for i, size in enumerate(sizes):
        sel = [r for r in rows if discretisation(r) == size]
        title = discretisation_title(sel)
        error_time_panel(axes[i][0], sel, "error_vs_converged_rel_l1",
                         f"{title}: against the converged solution of the same mesh",
                         with_converged=False)
        error_time_panel(axes[i][1], sel, "error_vs_reference_rel_l1",
                         f"{title}: against the path-traced "
                         f"reference ({''.join(reference).strip() or 'high spp'})", with_converged=True)
        for ax in axes[i]:
            ax.set_ylabel(ylabel)
    handles, labels = [], []
    for ax in axes.flat:
        for h, l in zip(*ax.get_legend_handles_labels()):
            if l not in labels:
                handles.append(h)
                labels.append(l)
    fig.suptitle("Speed against accuracy: the error of an image against the time it takes once the "
                 "operator is precomputed (precompute cost: cost_vs_patches.png)",
                 y=1.0 - 0.12 / height, va="top", fontsize=11.5)
    fig.legend(handles, labels, loc="upper center", ncol=4, fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, 1.0 - 0.42 / height))
    caption(fig, info)
    fig.tight_layout(rect=(0, 0.45 / height, 1, 1.0 - 1.2 / height))
    fig.savefig(out, dpi=110)
    plt.close(fig)


# ---- chart (b): error against order K ----------------------------------------------------------

def chart_error_vs_order(rows, info, out):
    sizes = sorted({discretisation(r) for r in rows if r["method"] == "series"})
    fig, axes = plt.subplots(1, max(1, len(sizes)), figsize=(6.5 * max(1, len(sizes)), 5.6), squeeze=False)
    base = baseline_variant(rows)
    for ax, size in zip(axes[0], sizes):
        sel = [r for r in rows if r["method"] == "series" and discretisation(r) == size]
        plain = sorted((r for r in sel if (r["drop_fraction"], r["precision"]) == base),
                       key=lambda r: r["order_K"])
        ks = [r["order_K"] for r in plain]
        a_max = plain[0]["a_max"] if plain else math.nan

        def line(key, **kw):
            pts = [(r["order_K"], r[key]) for r in plain if finite(r[key]) and r[key] > 0]
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], **kw)

        line("apriori_bound_rel", color="black", ls="--", lw=1.5,
             label=f"a-priori bound a^(K+1)/(1-a), a = a_max = {a_max:g}")
        line("aposteriori_estimate_rel", color="0.45", ls=":", lw=1.5,
             label="a-posteriori estimate (from the term norms)")
        line("solution_error_flux_rel", color="tab:purple", marker="o", lw=1.6,
             label="measured: solution error, flux 1-norm / ||e||")
        line("error_vs_converged_rel_l1", color="tab:blue", marker="s", lw=1.6,
             label=f"measured: image, relative L1 (drop {base[0]:g}, {base[1]})")
        for drop, precision in variants(sel):
            if (drop, precision) == base:
                continue
            v = sorted((r for r in sel if (r["drop_fraction"], r["precision"]) == (drop, precision)),
                       key=lambda r: r["order_K"])
            pts = [(r["order_K"], r["error_vs_converged_rel_l1"]) for r in v
                   if finite(r["error_vs_converged_rel_l1"]) and r["error_vs_converged_rel_l1"] > 0]
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], color="tab:blue", alpha=0.4, lw=0.9,
                        ls="--" if drop != base[0] else "-", marker=".",
                        label=f"measured: image, drop {drop:g}, {precision}")
        # How loose the bound is: a_max is the largest albedo, while the error decays at the
        # spectral radius of T, which the term norms measure.
        both = [r for r in plain if finite(r["apriori_bound_rel"]) and finite(r["solution_error_flux_rel"])
                and r["solution_error_flux_rel"] > 0]
        if len(both) >= 2:
            r0, r1 = both[-2], both[-1]
            q = (r1["solution_error_flux_rel"] / r0["solution_error_flux_rel"]) ** (1.0 / (r1["order_K"] - r0["order_K"]))
            ax.annotate(f"bound / measured = {r1['apriori_bound_rel'] / r1['solution_error_flux_rel']:.2g} at K={r1['order_K']:.0f}\n"
                        f"measured decay {q:.2f} per order, bound's {a_max:g}",
                        (r1["order_K"], r1["apriori_bound_rel"]), textcoords="offset points",
                        xytext=(-5, 10), ha="right", fontsize=7.5,
                        bbox=dict(boxstyle="round", fc="white", ec="0.7", alpha=0.9))
        ax.axhline(1.0, color="0.8", lw=0.8)
        ax.set_yscale("log")
        ax.set_xlabel("order K of the series (terms T^0 .. T^K)")
        ax.set_ylabel("relative error (log)")
        ax.set_title(discretisation_title(sel) if sel else "", fontsize=10)
        if ks:
            ax.set_xticks(ks)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    fig.suptitle("Error against the order K of the precomputed series: the a-priori bound beside the "
                 "measured error (both relative to the converged solution)", fontsize=11)
    caption(fig, info)
    fig.tight_layout(rect=(0, 0.05, 1, 0.95))
    fig.savefig(out, dpi=110)
    plt.close(fig)


# ---- chart (c): cost against patch count -------------------------------------------------------

def chart_cost_vs_patches(rows, info, out):
    rows = [r for r in rows if r.get("mesh", "uniform") != "hierarchical"]  # the uniform meshes' growth
    fig, axes = plt.subplots(1, 3, figsize=(18, 5.6))
    base = baseline_variant(rows)
    series = [r for r in rows if r["method"] == "series" and base
              and (r["drop_fraction"], r["precision"]) == base]
    orders = sorted({r["order_K"] for r in series})
    cmap = plt.get_cmap("viridis")

    def by_patches(sel, key):
        sel = sorted((r for r in sel if finite(r[key]) and r[key] > 0), key=lambda r: r["patches"])
        return [r["patches"] for r in sel], [r[key] for r in sel]

    def per_size(method, pick):
        """One row per patch size: the row of `method` chosen by pick (a key function, max)."""
        out_rows = {}
        for r in rows:
            if r["method"] == method:
                s = r["patch_size_scene_units"]
                if s not in out_rows or pick(r) > pick(out_rows[s]):
                    out_rows[s] = r
        return list(out_rows.values())

    any_rows = per_size("converged", lambda r: 0)
    for i, k in enumerate(orders):
        colour = cmap(i / max(1, len(orders) - 1))
        sel = [r for r in series if r["order_K"] == k]
        x, y = by_patches(sel, "precompute_seconds")
        axes[0].plot(x, y, marker="o", color=colour, label=f"series precompute, K={k:.0f}")
        x, y = by_patches(sel, "operator_bytes")
        axes[1].plot(x, y, marker="o", color=colour, label=f"Q, K={k:.0f} ({base[1]}, drop {base[0]:g})")
        x, y = by_patches(sel, "image_seconds")
        axes[2].plot(x, y, marker="o", color=colour, label=f"relight product, K={k:.0f}")
    x, y = by_patches(any_rows, "system_build_seconds")
    axes[0].plot(x, y, color="black", ls="--", marker="x", label="system build (form factors, transfer, T)")
    x, y = by_patches(any_rows, "gather_build_seconds")
    axes[0].plot(x, y, color="0.5", ls=":", marker="x", label="camera gather G")
    x, y = by_patches(any_rows, "operator_bytes")
    axes[1].plot(x, y, color="black", ls="--", marker="x", label="T and G (what the iterative solver reads)")
    if orders:
        k_max = max(orders)
        for drop, precision in variants(rows):
            if (drop, precision) == base:
                continue
            sel = [r for r in rows if r["method"] == "series" and r["order_K"] == k_max
                   and (r["drop_fraction"], r["precision"]) == (drop, precision)]
            x, y = by_patches(sel, "operator_bytes")
            axes[1].plot(x, y, marker=".", lw=0.9, alpha=0.6, ls="--" if drop != base[0] else "-",
                         color=cmap(1.0), label=f"Q, K={k_max:.0f} ({precision}, drop {drop:g})")
    for method in ("gauss-seidel", "jacobi"):
        sel = per_size(method, lambda r: r["sweeps"])
        if sel:
            x, y = by_patches(sel, "image_seconds")
            n = int(max(r["sweeps"] for r in sel))
            axes[2].plot(x, y, color=STYLE[method]["color"], marker=STYLE[method]["marker"], ls="--",
                         label=f"{method}, {n} sweeps + gather")
    x, y = by_patches(any_rows, "image_seconds")
    axes[2].plot(x, y, color="black", marker="*", ls=":", ms=9, label="Gauss-Seidel to 1e-9 + gather")
    titles = ("Precompute and setup time", "Operator memory", "Time per image after a change of lights")
    ylabels = ("time (s, log)", "bytes (log)", "time (s, log)")
    for ax, title, ylabel in zip(axes, titles, ylabels):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("patches (log)")
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
        ax.grid(True, which="minor", alpha=0.1)
        ax.legend(fontsize=7, loc="upper left")
    sizes = sorted({(r["patches"], r["patch_size_scene_units"]) for r in any_rows})
    fig.suptitle("How cost grows with the scene: patch sizes " +
                 ", ".join(f"{s:g} ({int(p)} patches)" for p, s in sizes), fontsize=11)
    caption(fig, info)
    fig.tight_layout(rect=(0, 0.05, 1, 0.95))
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("dir", help="the sweep's output directory (sweep.csv, machine.txt)")
    parser.add_argument("--out", help="where to write the PNG files (default: DIR)")
    args = parser.parse_args()
    csv_path = os.path.join(args.dir, "sweep.csv")
    if not os.path.exists(csv_path):
        print(f"charts.py: {csv_path} does not exist (run `polyrad sweep SCENE --out {args.dir}`)",
              file=sys.stderr)
        return 2
    rows = read_rows(csv_path)
    info = read_machine(os.path.join(args.dir, "machine.txt"))
    out = args.out or args.dir
    os.makedirs(out, exist_ok=True)
    written = []
    for name, chart in (("error_vs_time.png", chart_error_vs_time),
                        ("error_vs_order.png", chart_error_vs_order),
                        ("cost_vs_patches.png", chart_cost_vs_patches)):
        path = os.path.join(out, name)
        # All or nothing, as every polyrad output: draw into a temporary, rename when complete.
        tmp = os.path.join(out, f".{name}.{os.getpid()}.tmp.png")
        try:
            chart(rows, info, tmp)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)
        written.append(path)
    print("charts.py: wrote " + ", ".join(written), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
