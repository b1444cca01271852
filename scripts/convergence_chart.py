#!/usr/bin/env python3
"""Chart of `polyrad convergence` output: products with T each method needs, against albedo.

    /usr/bin/python3 scripts/convergence_chart.py TABLE.csv OUT.png [--caption TEXT]

Reads only the CSV the command wrote (scene, max_albedo, method, products_to_tolerance,
error_at_budget, budget, tolerance); scenes named furnace-* make the curves, any other scene is
drawn as separate markers at its albedo.
"""
import argparse
import csv
import sys

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit("convergence_chart.py: matplotlib is missing (Debian package python3-matplotlib)")

NEEDED = ["scene", "max_albedo", "method", "products_to_tolerance", "error_at_budget", "budget", "tolerance"]
STYLE = {"jacobi": ("Jacobi = power series", "o-"), "gauss-seidel": ("Gauss-Seidel", "s-"),
         "chebyshev": ("Chebyshev polynomial", "^-"), "gmres": ("GMRES", "D-")}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("table")
    parser.add_argument("out")
    parser.add_argument("--caption", default="")
    args = parser.parse_args()
    with open(args.table, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or any(c not in rows[0] for c in NEEDED):
        sys.exit("convergence_chart.py: %s lacks the columns %s" % (args.table, ", ".join(NEEDED)))
    tolerance = float(rows[0]["tolerance"])
    budget = int(rows[0]["budget"])

    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8))
    notes = []
    for method, (label, style) in STYLE.items():
        furn = sorted((float(r["max_albedo"]), int(r["products_to_tolerance"]), float(r["error_at_budget"]))
                      for r in rows if r["method"] == method and r["scene"].startswith("furnace"))
        if not furn:
            continue
        x = [1.0 / (1.0 - a) for a, _, _ in furn]
        reached = [(xx, p) for xx, (_, p, _) in zip(x, furn) if p > 0]
        left.plot([xx for xx, _ in reached], [p for _, p in reached], style, label=label)
        right.plot(x, [max(e, 1e-17) for _, _, e in furn], style, label=label)
        for r in rows:
            if r["method"] == method and not r["scene"].startswith("furnace"):
                xx = 1.0 / (1.0 - float(r["max_albedo"]))
                p = int(r["products_to_tolerance"])
                marker = style[0]
                if p > 0:
                    left.plot([xx], [p], marker, color=left.lines[-1].get_color(), mfc="none", ms=11)
                else:
                    notes.append(("%s does not converge on %s" % (label.split(" ")[0], r["scene"]),
                                  left.lines[-1].get_color()))
                right.plot([xx], [max(float(r["error_at_budget"]), 1e-17)], marker,
                           color=right.lines[-1].get_color(), mfc="none", ms=11)
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("1 / (1 - albedo)   (albedo 0.9, 0.99, 0.999)")
        ax.grid(True, which="both", alpha=0.3)
    left.set_ylabel("products with T to reach relative error %g" % tolerance)
    left.set_title("Work needed as the albedo nears 1\n(lines: white furnaces; open markers: two facing mirrors)")
    right.set_ylabel("relative error after %d products" % budget)
    right.set_title("Error at a fixed budget of %d products" % budget)
    left.legend(fontsize=8)
    for n, (text, colour) in enumerate(notes):
        left.text(0.98, 0.04 + 0.06 * n, text, transform=left.transAxes, ha="right", fontsize=8, color=colour)
    if args.caption:
        fig.text(0.5, 0.005, args.caption, ha="center", fontsize=7, color="0.35")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
