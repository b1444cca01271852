#!/usr/bin/python3
"""Summarises the Google Benchmark JSON that scripts/bench.sh writes into a markdown report.

    scripts/bench_summary.py out/bench        # reads transport.json, series.json,
                                              # form_factors.json, serve.json and
                                              # hierarchy.json; prints the report and writes
                                              # out/bench/summary.md

Figures are medians of iterations timed one by one (the *median_ms* and *_per_second counters)
rather than benchmark's means, which a burst of load from elsewhere inflates. Each target
gets PASS or FAIL with its margin; the exit status is 0 either way, because a
benchmark reports and a test enforces (docs/benchmarks.md). Standard library only.
"""
import json
import os
import platform
import sys
import time

CACHE_BYTES = 32 * 1024 * 1024  # beyond this the bandwidth target applies

# name, comparison, limit: the targets.
RAY_RATIO_LIMIT = 0.7   # form-factor shadow rays/s / bare occlusion rays/s, at least
FF_SECONDS_LIMIT = 30.0  # form factors of the Cornell box at patch size 25, seconds, below
FF_SECONDS_PATCH_SIZE = 25
MEMORY_LIMIT = 2.0      # glossy operator memory / classic system memory, at most
SWEEP_LIMIT = 2.0       # glossy sweep time / classic sweep time, at most
BANDWIDTH_LIMIT = 0.6   # product bytes/s / triad bytes/s, at least, beyond cache
SPEEDUP_LIMIT = 1000.0  # iterative solve + gather time / product time, at least
OVERHEAD_LIMIT_MS = 2.0  # relight request latency - product - PNG encoding, at most
IMAGES_PER_SECOND_LIMIT = 30.0  # images a second served to 4 clients, at least
RSS_GROWTH_LIMIT_MIB = 4.0  # resident memory growth over 9,000 requests ("flat"), at most
HIERARCHY_LIMIT = 0.1   # hierarchical render / uniform patch size 17 render, time and peak, at most


def load(path):
    """The JSON of one program, or None: missing, or empty because a --benchmark_filter matched
    none of its benchmarks."""
    if not os.path.exists(path) or os.path.getsize(path) == 0:
        return None
    with open(path) as f:
        return json.load(f)


def params(entry):
    """The benchmark's name and its arguments: 'sweep/patch_size:50/operator:0/...' ->
    ('sweep', {'patch_size': 50, 'operator': 0})."""
    parts = entry["run_name"].split("/")
    name, args = None, {}
    for p in parts:
        if ":" in p:
            key, value = p.split(":", 1)
            try:
                args[key] = float(value) if "." in value else int(value)
            except ValueError:
                args[key] = value
        elif p not in ("real_time", "manual_time"):
            name = p  # the last plain part: fixtures are named Fixture/method
    return name, args


def runs(report, name):
    """The iterations (not aggregates) of one benchmark family, with their arguments."""
    if report is None:
        return []
    out = []
    for e in report.get("benchmarks", []):
        if e.get("run_type", "iteration") != "iteration":
            continue
        n, args = params(e)
        if n == name:
            out.append((args, e))
    return out


def aggregates(report, name, which="median"):
    """The aggregate rows (median, mean, ...) of a benchmark run with repetitions."""
    if report is None:
        return []
    return [(params(e)[1], e) for e in report.get("benchmarks", [])
            if e.get("run_type") == "aggregate" and e.get("aggregate_name") == which
            and params(e)[0] == name]


def failed(e):
    return e.get("error_occurred", False)


def verdict(ok, text):
    return ("PASS" if ok else "FAIL") + " (" + text + ")"


def mib(b):
    return "%.2f MiB" % (b / 2**20)


def gbs(b):
    return "%.2f GB/s" % (b / 1e9)


def times(x):
    return "%.1fx" % x if x < 10 else "%.0fx" % x


def ms(x):
    return "%.3f ms" % x if x < 100 else "%.0f ms" % x


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def machine(reports):
    ctx = next((r["context"] for r in reports if r), {})
    caches = ", ".join(
        "L%d %s %s%s" % (c["level"], c["type"].lower(),
                         mib(c["size"]) if c["size"] >= 2**20 else "%d KiB" % (c["size"] // 1024),
                         " shared by %d CPUs" % c["num_sharing"] if c.get("num_sharing", 0) > 1 else "")
        for c in ctx.get("caches", []))
    lines = [
        "- Date: %s" % ctx.get("date", time.strftime("%Y-%m-%dT%H:%M:%S")),
        "- CPU: %s (/proc/cpuinfo), %s logical CPUs at %s MHz, %s" % (
            ctx.get("cpu_model", cpu_model()), ctx.get("num_cpus", "?"), ctx.get("mhz_per_cpu", "?"),
            "frequency scaling on" if ctx.get("cpu_scaling_enabled") else "no frequency scaling reported"),
        "- Caches (as reported): %s" % (caches or "unknown"),
        "- OpenMP threads: %s; host: %s %s" % (ctx.get("omp_max_threads", "?"), platform.system(), platform.release()),
    ]
    for r in reports:
        if r and "load_avg" in r["context"]:
            lines.append("- Load average when %s started: %s" % (
                os.path.basename(r["context"].get("executable", "?")),
                ", ".join("%.2f" % x for x in r["context"]["load_avg"])))
    return "\n".join(lines)


def transport_section(rep, verdicts):
    out = ["## Glossy operator against the classic system (`transport_bench`)", ""]
    if rep is None:
        return out + ["(no transport.json)", ""]
    sweeps = {(a["patch_size"], a["operator"]): e for a, e in runs(rep, "sweep") if not failed(e)}
    builds = {a["patch_size"]: e for a, e in runs(rep, "specular_transfer_build") if not failed(e)}
    rows, rows_otf = [], []
    for a, e in sorted(runs(rep, "glossy_vs_classic"), key=lambda x: -x[0]["patch_size"]):
        if failed(e):
            continue
        ps = a["patch_size"]
        mem, sweep = e["memory_ratio"], e["sweep_ratio"]
        mem_v = verdict(mem <= MEMORY_LIMIT, "%.2f <= %.1f" % (mem, MEMORY_LIMIT) if mem <= MEMORY_LIMIT
                        else "%.2f > %.1f, over by %.0f%%" % (mem, MEMORY_LIMIT, 100 * (mem / MEMORY_LIMIT - 1)))
        sweep_v = verdict(sweep <= SWEEP_LIMIT, "%.2f <= %.1f" % (sweep, SWEEP_LIMIT) if sweep <= SWEEP_LIMIT
                          else "%.2f > %.1f, over by %.0f%%" % (sweep, SWEEP_LIMIT, 100 * (sweep / SWEEP_LIMIT - 1)))
        verdicts.append(("memory, patch size %d" % ps, mem_v))
        verdicts.append(("sweep time, patch size %d" % ps, sweep_v))
        rows.append([ps, int(e["patches"]), int(e["links"]),
                     "%d" % e["nnz_classic"], "%d + %d" % (e["nnz_diffuse"], e["nnz_specular"]),
                     mib(e["bytes_classic"]),
                     "%s + %s" % (mib(e["bytes_glossy_operator"]), mib(e["bytes_transfer"])),
                     "**%.2f** (operator alone %.2f)" % (mem, e["memory_ratio_operator"]), mem_v,
                     ms(e["sweep_classic_ms"]), ms(e["sweep_glossy_ms"]), "**%.2f**" % sweep, sweep_v])
        # The stored sweep from the alternating loop: more samples than sweep/operator:0.
        stored, otf = e["sweep_glossy_ms"], sweeps.get((ps, 2))
        build = builds.get(ps)
        rows_otf.append([ps,
                         "%.2f s" % (build["median_ms"] / 1e3) if build else "-",
                         "%d" % build["entries"] if build else "-",
                         "%.2f s" % build["form_factors_s"] if build else "-",
                         mib(e["bytes_glossy"]), mib(e["bytes_on_the_fly"]),
                         "%.2f" % e["on_the_fly_memory_ratio"],
                         ms(stored),
                         ms(otf["median_ms"]) if otf else "-",
                         "%.0f" % (otf["median_ms"] / stored) if otf else "-"])
    out.append("Targets: the glossy operator at most %.0fx the classic system's memory and one sweep "
               "at most %.0fx its time. Glossy memory = operator T (`transport.bytes()`) + the specular "
               "transfer the system keeps (`specular.bytes()`); classic = its T. Sweep times are "
               "medians of the two sweeps timed alternately in one loop." % (MEMORY_LIMIT, SWEEP_LIMIT))
    out.append("")
    out.append(table(["patch size", "patches", "links", "nnz classic", "nnz glossy (diffuse + specular)",
                      "classic", "glossy (T + transfer)", "memory ratio", "target <= 2",
                      "classic sweep", "glossy sweep", "sweep ratio", "target <= 2"], rows))
    out.append("")
    out.append("Stored against on the fly (section 4.1), and the transfer build:")
    out.append("")
    out.append(table(["patch size", "transfer build", "transfer entries", "form factors (once)",
                      "stored T + transfer", "on-the-fly T", "on-the-fly / stored memory",
                      "stored sweep", "on-the-fly sweep", "on-the-fly / stored time"], rows_otf))
    out.append("")
    out.append("Times are medians; the form factors were timed once, when the system was built.")
    out.append("")
    srows = []
    for a, e in sorted(runs(rep, "solve"), key=lambda x: (-x[0]["patch_size"], x[0]["operator"], x[0]["method"])):
        if failed(e):
            srows.append([a["patch_size"], e.get("label", ""), "error: " + e.get("error_message", ""), "", ""])
            continue
        srows.append([a["patch_size"], e.get("label", ""), int(e["iterations"]), "%.1e" % e["residual"],
                      ms(e["median_ms"])])
    out.append("The whole iterative solve, to a relative residual of 1e-4:")
    out.append("")
    out.append(table(["patch size", "operator, method", "sweeps", "residual", "time (median)"], srows))
    out.append("")
    return out


def series_section(rep, verdicts):
    out = ["## The precomputed series (`series_bench`)", ""]
    if rep is None:
        return out + ["(no series.json)", ""]
    llc = max((c["size"] for c in rep["context"].get("caches", [])), default=0)
    prows = []
    for a, e in sorted(runs(rep, "product"), key=lambda x: x[0]["pixels_per_side"]):
        if failed(e):
            continue
        ratio = e["bandwidth_ratio"]
        if e["bytes"] > CACHE_BYTES:
            v = verdict(ratio >= BANDWIDTH_LIMIT, "%.2f >= %.1f" % (ratio, BANDWIDTH_LIMIT) if ratio >= BANDWIDTH_LIMIT
                        else "%.2f < %.1f, short by %.0f%%" % (ratio, BANDWIDTH_LIMIT, 100 * (1 - ratio / BANDWIDTH_LIMIT)))
            verdicts.append(("product bandwidth, %d^2 pixels (%s)" % (a["pixels_per_side"], mib(e["bytes"])), v))
        else:
            v = "n/a (fits in cache)"
        prows.append(["%d^2" % a["pixels_per_side"], int(e["cols"]), "%d" % e["nnz"], mib(e["bytes"]),
                      gbs(e["product_bytes_per_second"]), gbs(e["triad_bytes_per_second"]),
                      "**%.2f**" % ratio, v, "yes" if llc and e["bytes"] > llc else "no"])
    out.append("The relight product (view mode, one column per light patch, K = 20) against a STREAM "
               "triad over the same bytes, alternated in one loop; medians. Bytes = the operator + the "
               "emission and output vectors. Target: ratio >= %.1f beyond %s." % (BANDWIDTH_LIMIT, mib(CACHE_BYTES)))
    out.append("")
    out.append(table(["camera", "columns", "nnz", "bytes touched", "product", "triad", "ratio", "target >= 0.6",
                      "beyond the reported last-level cache (%s)" % mib(llc)], prows))
    out.append("")
    trows = [[mib(e["bytes"]), gbs(e["median_bytes_per_second"])]
             for a, e in sorted(runs(rep, "triad"), key=lambda x: x[0]["MiB"]) if not failed(e)]
    out.append("The triad alone (median):")
    out.append("")
    out.append(table(["bytes", "triad"], trows))
    out.append("")
    krows = [[int(e["order"]), "%.0f ms" % e["median_ms"], "%d" % e["nnz"], mib(e["bytes"]),
              "%.3g" % e["apriori_bound"], "%.3g" % e["aposteriori_estimate"]]
             for a, e in sorted(runs(rep, "precompute"), key=lambda x: x[0]["order"]) if not failed(e)]
    out.append("Precompute time against the order K (the scene's 256^2 view, patch basis; gather built beforehand):")
    out.append("")
    out.append(table(["K", "time", "nnz", "bytes", "a-priori bound", "a-posteriori estimate"], krows))
    out.append("")
    rrows = [[int(a["order"]), "%.3f s" % e["none_median_s"], "%.3f s" % e["rcm_median_s"], "%.3f" % e["ratio"],
              "%d -> %d" % (e["bandwidth_before"], e["bandwidth_after"]), "%.0f ms" % e["reorder_ms"]]
             for a, e in sorted(runs(rep, "precompute_reorder"), key=lambda x: x[0]["order"]) if not failed(e)]
    if rrows:
        out.append("The same precompute with T's unknowns as built and renumbered by reverse Cuthill-McKee "
                   "(alternated, medians; ratio = none over rcm, above 1 when the reordering is faster):")
        out.append("")
        out.append(table(["K", "none", "rcm", "ratio", "bandwidth", "ordering"], rrows))
        out.append("")
    def key(a):
        return (a.get("patch_size", 0) or -1, a["basis"], a["tolerance_exp"])

    def size_name(ps):  # 0: the scene as written
        return "as written (50, lamp 20)" if ps == 0 else "%d" % ps
    products = {key(a): e for a, e in runs(rep, "relight_product") if not failed(e)}
    rrows = []
    for a, e in sorted(runs(rep, "iterative_same_error"), key=lambda x: key(x[0])):
        if failed(e):
            continue
        basis = "patch" if a["basis"] == 0 else "object"
        ps = a.get("patch_size", 0)
        p = products.get(key(a))
        speedup = e["speedup"]
        if speedup >= SPEEDUP_LIMIT:
            v = verdict(True, "%s >= %.0fx" % (times(speedup), SPEEDUP_LIMIT))
        elif speedup >= SPEEDUP_LIMIT / 2:
            v = verdict(False, "%s, short by %.0f%%" % (times(speedup), 100 * (1 - speedup / SPEEDUP_LIMIT)))
        else:
            v = verdict(False, "%s, short by a factor %.0f" % (times(speedup), SPEEDUP_LIMIT / speedup))
        verdicts.append(("relight speedup, patch sizes %s, %s basis, tolerance 1e-%d" % (size_name(ps), basis, a["tolerance_exp"]), v))
        rrows.append(["%s, %s patches" % (size_name(ps), int(e["patches"]) if "patches" in e else "?"), basis, "1e-%d" % a["tolerance_exp"], int(p["order"]) if p else "-",
                      "%d" % p["nnz"] if p else "-", mib(p["bytes"]) if p else "-",
                      "%.2e" % e["series_image_error"], ms(e["product_median_ms"]),
                      int(e["sweeps"]), "%.2e" % e["image_error"], ms(e["median_ms"]),
                      "**%s**" % times(speedup), v])
    out.append("Relighting against the iterative solve to the same error (view mode, the scene's 256^2 "
               "camera): the product of an operator precomputed to a tolerance, against the fewest "
               "Gauss-Seidel sweeps + camera gather whose image is at least as close to a converged "
               "(1e-12) reference, in relative L1 over the image. Medians; the product is timed again "
               "right after the solves. Target: speedup >= %.0fx." % SPEEDUP_LIMIT)
    out.append("")
    out.append(table(["patch size", "basis", "tolerance", "K", "nnz", "bytes", "product image error", "product",
                      "GS sweeps", "GS image error", "GS + gather", "speedup", "target >= 1000x"], rrows))
    out.append("")
    frows = []
    for a, e in sorted(runs(rep, "final_gather_same_error"), key=lambda x: x[0]["basis"]):
        if failed(e):
            continue
        basis = "patch" if a["basis"] == 0 else "object"
        speedup = e["speedup"]
        ok = speedup >= SPEEDUP_LIMIT
        v = verdict(ok, "%s >= %.0fx" % (times(speedup), SPEEDUP_LIMIT) if ok
                    else "%s, short by %.0f%%" % (times(speedup), 100 * (1 - speedup / SPEEDUP_LIMIT)))
        verdicts.append(("relight speedup with the final gather, as written, %s basis" % basis, v))
        frows.append([basis, int(e["order"]), "%.2e" % e["series_image_error"], ms(e["product_median_ms"]),
                      int(e["sweeps"]), "%.2e" % e["image_error"], ms(e["median_ms"]), "**%s**" % times(speedup),
                      ms(e["stored_gather_ms"]), times(e["speedup_stored_gather"]), v])
    if frows:
        out.append("The same with the final gather (the default), cornell-mirror-cube as written, tolerance "
                   "1e-3: the fewest Gauss-Seidel sweeps + the final gather built and applied (its rows in "
                   "blocks), against the product; and, beside it, the sweeps + the apply of a final gather "
                   "kept in memory, which a change of lights alone need not rebuild. Target: speedup "
                   ">= %.0fx." % SPEEDUP_LIMIT)
        out.append("")
        out.append(table(["basis", "K", "product image error", "product", "GS sweeps", "GS image error",
                          "GS + final gather", "speedup", "GS + stored gather", "speedup (stored)",
                          "target >= 1000x"], frows))
        out.append("")
    return out


def form_factor_section(rep, verdicts):
    out = ["## Form factors against a bare occlusion loop (`form_factor_bench`)", ""]
    if rep is None:
        return out + ["(no form_factors.json)", ""]
    alone = {a["patch_size"]: e for a, e in runs(rep, "form_factors") if not failed(e)}
    versus = {a["patch_size"]: e for a, e in runs(rep, "form_factors_vs_bare") if not failed(e)}
    rows = []
    for ps in sorted(set(alone) | set(versus), reverse=True):
        f, e = alone.get(ps), versus.get(ps)
        v = t = "-"
        if e:
            ratio, seconds = e["ray_ratio"], e["seconds"]
            v = verdict(ratio >= RAY_RATIO_LIMIT, "%.2f >= %.1f" % (ratio, RAY_RATIO_LIMIT) if ratio >= RAY_RATIO_LIMIT
                        else "%.2f < %.1f, short by %.0f%%" % (ratio, RAY_RATIO_LIMIT, 100 * (1 - ratio / RAY_RATIO_LIMIT)))
            verdicts.append(("form-factor rays/s against the bare loop, patch size %d" % ps, v))
            if ps == FF_SECONDS_PATCH_SIZE:
                t = verdict(seconds < FF_SECONDS_LIMIT, "%.1f s < %.0f s" % (seconds, FF_SECONDS_LIMIT) if seconds < FF_SECONDS_LIMIT
                            else "%.1f s >= %.0f s, over by %.0f%%" % (seconds, FF_SECONDS_LIMIT, 100 * (seconds / FF_SECONDS_LIMIT - 1)))
                verdicts.append(("form factors, patch size %d, %d patches" % (ps, int(e["patches"])), t))
        any_e = e or f
        rows.append([ps, int(any_e["patches"]), "%d" % any_e["pairs_facing"], "%d" % any_e["rays"],
                     "%d" % any_e["nnz"], mib(any_e["bytes"]),
                     "%.2f s" % f["seconds"] if f else "-",
                     "%.3f s" % f["exposure_seconds"] if f else "-",
                     "%.2f s" % e["seconds"] if e else "-", "%.2f s" % e["bare_seconds"] if e else "-",
                     "%.2fM" % (e["ff_rays_per_second"] / 1e6) if e else "%.2fM" % (f["rays_per_second"] / 1e6),
                     "%.2fM" % (e["bare_rays_per_second"] / 1e6) if e else "-",
                     "**%.2f** (CPU time %.2f)" % (e["ray_ratio"], e["ray_ratio_cpu"]) if e else "-", v, t])
    out.append("The whole `compute_form_factors` (exposed areas, pair culling, outer rule, contour "
               "integrals, shadow rays) alternated in one loop with a bare loop that casts as many "
               "shadow rays through the same `RayCaster` with the same OpenMP team; medians. Rays are "
               "the form factors' shadow rays; ratio = form-factor rays/s over bare rays/s (the bare "
               "loop's time over the form factors'). Targets: ratio >= %.1f; patch size %d in under "
               "%.0f s." % (RAY_RATIO_LIMIT, FF_SECONDS_PATCH_SIZE, FF_SECONDS_LIMIT))
    out.append("")
    out.append(table(["patch size", "patches", "facing pairs", "shadow rays", "nnz", "bytes",
                      "form factors alone", "of which exposed areas", "form factors (alternated)",
                      "bare loop", "form-factor rays/s", "bare rays/s", "ratio", "target >= 0.7",
                      "target < 30 s"], rows))
    out.append("")
    return out


def serve_section(rep, verdicts):
    out = ["## The relighting server (`serve_bench`)", ""]
    if rep is None:
        return out + ["(no serve.json)", ""]
    rows = []
    trip = next((e["latency_median_ms"] for a, e in runs(rep, "round_trip") if not failed(e)), None)
    for a, e in aggregates(rep, "request") or runs(rep, "request"):
        if failed(e):
            continue
        over = e["overhead_ms"]
        v = verdict(over <= OVERHEAD_LIMIT_MS, "%.2f ms <= %.0f ms" % (over, OVERHEAD_LIMIT_MS) if over <= OVERHEAD_LIMIT_MS
                    else "%.2f ms > %.0f ms" % (over, OVERHEAD_LIMIT_MS))
        verdicts.append(("relight request latency over product + PNG", v))
        rows.append([ms(e["latency_median_ms"]), ms(e["product_median_ms"]), ms(e["encode_median_ms"]),
                     ms(e["server_median_ms"]), "**%s**" % ms(over), ms(e["outside_server_ms"]),
                     ms(trip) if trip is not None else "-", v])
    out.append("One client, keep-alive, POST /api/relight -> PNG at 256^2 on the demo's view operator; "
               "medians over seven runs of each run's medians. The product and encoding times are the "
               "server's own (its response headers); in the server = the whole request there, parsing to "
               "encoding; overhead = latency - product - encoding and outside the server = latency - in "
               "the server, each request's (the product's time has a long tail under load, so a "
               "difference of medians would be no request's); GET /api/operator = the HTTP exchange "
               "alone. "
               "Target: latency - product - encoding <= %.0f ms." % OVERHEAD_LIMIT_MS)
    out.append("")
    out.append(table(["latency", "product", "PNG encoding", "in the server", "overhead",
                      "outside the server", "GET /api/operator", "target <= 2 ms"], rows))
    out.append("")
    trows = []
    for a, e in sorted(runs(rep, "throughput"), key=lambda x: x[0]["clients"]):
        if failed(e):
            continue
        rate = e["images_per_second"]
        v = "-"
        if a["clients"] == 4:
            v = verdict(rate >= IMAGES_PER_SECOND_LIMIT, "%.0f >= %.0f" % (rate, IMAGES_PER_SECOND_LIMIT)
                        if rate >= IMAGES_PER_SECOND_LIMIT else "%.0f < %.0f" % (rate, IMAGES_PER_SECOND_LIMIT))
            verdicts.append(("images a second, 4 clients", v))
        trows.append([a["clients"], "**%.0f**" % rate, "%.0f" % e["images_per_second_serialised"],
                      "%.2f" % e["concurrent_over_serialised"], v])
    out.append("Clients asking at once, each on its own connection: medians of 7 rounds of 100 requests "
               "a client, with concurrent products (the server's default) and one at a time, the two "
               "servers asked alternately. Target: >= %.0f images/s with 4 clients." % IMAGES_PER_SECOND_LIMIT)
    out.append("")
    out.append(table(["clients", "images/s", "images/s, products one at a time", "ratio", "target >= 30"], trows))
    out.append("")
    mrows = []
    for a, e in runs(rep, "memory"):
        if failed(e):
            continue
        growth = e["rss_growth_mib"]
        v = verdict(growth <= RSS_GROWTH_LIMIT_MIB, "%.1f MiB <= %.0f MiB" % (growth, RSS_GROWTH_LIMIT_MIB)
                    if growth <= RSS_GROWTH_LIMIT_MIB else "%.1f MiB > %.0f MiB" % (growth, RSS_GROWTH_LIMIT_MIB))
        verdicts.append(("resident memory over 10,000 requests", v))
        mrows.append(["%.1f MiB" % e["rss_after_1000_mib"], "%.1f MiB" % e["rss_after_5500_mib"],
                      "%.1f MiB" % e["rss_after_10000_mib"], "**%.1f MiB**" % growth, v])
    out.append("10,000 requests from 4 clients; the resident memory of the process (server and clients). "
               "Target: flat (growth after the first 1,000 at most %.0f MiB)." % RSS_GROWTH_LIMIT_MIB)
    out.append("")
    out.append(table(["after 1,000", "after 5,500", "after 10,000", "growth", "target: flat"], mrows))
    out.append("")
    return out


def hierarchy_section(rep, verdicts):
    out = ["## The hierarchical mesh (`hierarchy_bench`)", ""]
    if rep is None:
        return out + ["(no hierarchy.json)", ""]
    rows = []
    # (counter prefix of the hierarchical run, what it is); runs written before the mesh
    # configurations have only the first.
    configurations = (("", "hierarchical", "hierarchical"),
                      ("mesh_", "mesh", "hierarchical, --indirect mesh"),
                      ("mesh1_", "mesh1", "hierarchical, --indirect mesh --refine-passes 1"),
                      ("mesh60_", "mesh60", "hierarchical, --indirect mesh, tuned for time (roots 60, "
                       "tau 0.07, one pass, --mesh-near-distance 1 --near-samples 0)"))
    for a, e in runs(rep, "mirror_cube_render"):
        if failed(e):
            continue
        for prefix, name, label in configurations:
            if prefix + "time_ratio" not in e:
                continue
            for what, key in (("time", "time_ratio"), ("peak memory", "memory_ratio")):
                r = e[prefix + key]
                v = verdict(r <= HIERARCHY_LIMIT,
                            "%.3f %s %.1f" % (r, "<=" if r <= HIERARCHY_LIMIT else ">", HIERARCHY_LIMIT))
                verdicts.append(("mirror cube: %s render's %s over uniform 17's" % (label, what), v))
            rows.append([label, "%.1f s" % e[name + "_s"], "%.1f s" % e["uniform17_s"],
                         "**%.3f**" % e[prefix + "time_ratio"], mib(e[name + "_peak_bytes"]),
                         mib(e["uniform17_peak_bytes"]), "**%.3f**" % e[prefix + "memory_ratio"]])
    out.append("cornell-mirror-cube, `polyrad render --gather final` writing a .pfm, each render a process "
               "of its own, alternated; medians of the iterations. Hierarchical at the default link "
               "tolerance of its gather against uniform patch size 17 (rays). Target: at most %.1f of the time "
               "and of the peak (the image error, no worse, is the README's hierarchy study)." % HIERARCHY_LIMIT)
    out.append("")
    out.append(table(["configuration", "time", "uniform 17", "time ratio", "peak", "uniform 17 peak",
                      "memory ratio"], rows))
    out.append("")
    return out


def main():
    directory = sys.argv[1] if len(sys.argv) > 1 else "out/bench"
    transport = load(os.path.join(directory, "transport.json"))
    series = load(os.path.join(directory, "series.json"))
    form_factors = load(os.path.join(directory, "form_factors.json"))
    serve = load(os.path.join(directory, "serve.json"))
    hierarchy = load(os.path.join(directory, "hierarchy.json"))
    reports = [transport, series, form_factors, serve, hierarchy]
    if all(r is None for r in reports):
        sys.exit("bench_summary: no transport.json, series.json, form_factors.json, serve.json or "
                 "hierarchy.json in " + directory)
    verdicts = []
    lines = ["# polyrad benchmarks", "", machine(reports), ""]
    lines += transport_section(transport, verdicts)
    lines += series_section(series, verdicts)
    lines += form_factor_section(form_factors, verdicts)
    lines += serve_section(serve, verdicts)
    lines += hierarchy_section(hierarchy, verdicts)
    lines += ["## Targets", "", table(["target", "result"], verdicts), ""]
    text = "\n".join(lines)
    print(text)
    with open(os.path.join(directory, "summary.md"), "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
