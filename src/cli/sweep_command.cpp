// polyrad sweep SCENE --out DIR: speed against accuracy (issue 6).
//
// Varies the patch size, the series order K, its drop tolerance and value precision, the number
// of Jacobi / Gauss-Seidel sweeps and the path tracer's samples per pixel, and for every point
// measures what the image costs and how far it is from two references:
//   - the converged solution of the same discretisation (Gauss-Seidel to a relative residual of
//     1e-9, through the same camera gather): the error the knob itself adds;
//   - a high-sample path-traced image, sharing none of the discretisation: the error a user
//     sees, discretisation included. It is cached in DIR (reference.exr and reference.json, the
//     key it was made with), so that reruns with other knobs reuse it.
// Writes DIR/sweep.csv (one row per point, column names with units, empty cells where a column
// does not apply) and DIR/machine.txt (the machine, threads, date, scene and reference), which
// scripts/charts.py turns into the charts.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <sstream>

#include "cli_common.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/util/files.h"
#include "polyrad/io/image_io.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/geometry/mesher.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/util/progress.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/scene.h"
#include "polyrad/solve/series.h"

namespace polyrad::cli {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The reference and the sweep's path-traced points use different seeds: with one seed the
// first n samples of each reference pixel would be the n-spp image's, and its error would look
// smaller than it is.
constexpr std::uint64_t kReferenceSeed = 0x5eed5eedull;
constexpr std::uint64_t kPointSeed = 1;
constexpr double kConvergedTolerance = 1e-9;

struct SweepFlags {
  std::string scene, out;
  std::vector<double> patch_sizes{100, 50, 25};
  std::vector<int> orders{0, 1, 2, 4, 8, 16, 32};
  std::vector<double> drops{0.0, 1e-4, 1e-3, 1e-2};
  std::vector<std::string> precisions{"float", "half"};
  std::vector<int> sweeps{1, 2, 4, 8, 16, 32};
  std::vector<int> spp{1, 4, 16, 64};
  int reference_spp = 1024;
  int repeats = 5;
  bool quick = false;
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? kNaN : v[v.size() / 2];
}

double fastest(const std::vector<double>& v) {
  return v.empty() ? kNaN : *std::min_element(v.begin(), v.end());
}

// The load average (1, 5, 15 minutes): timings on a busy machine are slower and noisier, and the
// charts say so.
std::string load_average() {
  std::ifstream in("/proc/loadavg");
  double l1 = 0, l5 = 0, l15 = 0;
  if (!(in >> l1 >> l5 >> l15)) return "unknown";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f %.2f %.2f", l1, l5, l15);
  return buf;
}

// The library's own progress displays (each precompute, each path-traced image) would leave
// one finished line per point; inside a point only the sweep's display is drawn.
class InnerProgressOff {
 public:
  InnerProgressOff() : was_(Progress::enabled()) { Progress::set_enabled(false); }
  ~InnerProgressOff() { Progress::set_enabled(was_); }
  InnerProgressOff(const InnerProgressOff&) = delete;
  InnerProgressOff& operator=(const InnerProgressOff&) = delete;

 private:
  bool was_;
};

// How far image a is from reference b (compare_images).
struct ErrorFigures {
  double rel_rmse = kNaN, mean_rel = kNaN, rel_l1 = kNaN;
};

ErrorFigures image_error(const Image& a, const Image& b) {
  if (!a.all_finite()) throw NumericalError("a sweep image has non-finite pixels");
  CompareOptions o;
  o.worst_pixels = 0;
  ImageComparison c = compare_images(a, b, o);
  return {c.relative_rmse, c.mean_relative_error, c.relative_l1};
}

// One point of the sweep. NaN and negative integers mean "does not apply" (an empty cell).
struct SweepRow {
  std::string method;  // series | jacobi | gauss-seidel | converged | pathtrace
  double patch_size = kNaN;
  long long patches = -1, unknowns = -1;
  int order = -1;
  double drop = kNaN;
  std::string precision;
  int sweeps = -1, spp = -1;
  double image_seconds = kNaN;       // from a change of emission to the image (median)
  double image_seconds_min = kNaN;   // ... the fastest repeat: less disturbed by other load
  double precompute_seconds = kNaN;  // series: the precompute of Q
  double system_seconds = kNaN;      // mesh, ray caster, form factors, transfer, operator T
  double gather_seconds = kNaN;      // building the camera gather G
  int repeats = -1;
  double operator_bytes = kNaN;  // what the method reads per image: Q, or T and G
  double operator_nnz = kNaN;
  double peak_rss_bytes = kNaN;
  double a_max = kNaN, apriori_bound = kNaN, aposteriori_estimate = kNaN;
  double dropped_relative = kNaN;
  double solution_error = kNaN;  // ||u* - u||_flux / ||e||_flux: what the a-priori bound bounds
  double residual = kNaN;
  ErrorFigures vs_converged, vs_reference;
};

std::string cell(double x) {
  if (!std::isfinite(x)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}
std::string cell(long long n) { return n < 0 ? "" : std::to_string(n); }

using Column = std::pair<const char*, std::function<std::string(const SweepRow&)>>;

// The columns of sweep.csv, in order. Names carry units; scripts/charts.py reads them by name.
const std::vector<Column>& columns() {
  static const std::vector<Column> c = {
      {"method", [](const SweepRow& r) { return r.method; }},
      {"patch_size_scene_units", [](const SweepRow& r) { return cell(r.patch_size); }},
      {"patches", [](const SweepRow& r) { return cell(r.patches); }},
      {"unknowns", [](const SweepRow& r) { return cell(r.unknowns); }},
      {"order_K", [](const SweepRow& r) { return cell(static_cast<long long>(r.order)); }},
      {"drop_fraction", [](const SweepRow& r) { return cell(r.drop); }},
      {"precision", [](const SweepRow& r) { return r.precision; }},
      {"sweeps", [](const SweepRow& r) { return cell(static_cast<long long>(r.sweeps)); }},
      {"spp", [](const SweepRow& r) { return cell(static_cast<long long>(r.spp)); }},
      {"image_seconds", [](const SweepRow& r) { return cell(r.image_seconds); }},
      {"image_seconds_min", [](const SweepRow& r) { return cell(r.image_seconds_min); }},
      {"precompute_seconds", [](const SweepRow& r) { return cell(r.precompute_seconds); }},
      {"system_build_seconds", [](const SweepRow& r) { return cell(r.system_seconds); }},
      {"gather_build_seconds", [](const SweepRow& r) { return cell(r.gather_seconds); }},
      {"timing_repeats", [](const SweepRow& r) { return cell(static_cast<long long>(r.repeats)); }},
      {"operator_bytes", [](const SweepRow& r) { return cell(r.operator_bytes); }},
      {"operator_nnz", [](const SweepRow& r) { return cell(r.operator_nnz); }},
      {"peak_rss_bytes", [](const SweepRow& r) { return cell(r.peak_rss_bytes); }},
      {"a_max", [](const SweepRow& r) { return cell(r.a_max); }},
      {"apriori_bound_rel", [](const SweepRow& r) { return cell(r.apriori_bound); }},
      {"aposteriori_estimate_rel", [](const SweepRow& r) { return cell(r.aposteriori_estimate); }},
      {"dropped_relative", [](const SweepRow& r) { return cell(r.dropped_relative); }},
      {"solution_error_flux_rel", [](const SweepRow& r) { return cell(r.solution_error); }},
      {"residual_rel", [](const SweepRow& r) { return cell(r.residual); }},
      {"error_vs_converged_rel_rmse", [](const SweepRow& r) { return cell(r.vs_converged.rel_rmse); }},
      {"error_vs_converged_mean_rel", [](const SweepRow& r) { return cell(r.vs_converged.mean_rel); }},
      {"error_vs_converged_rel_l1", [](const SweepRow& r) { return cell(r.vs_converged.rel_l1); }},
      {"error_vs_reference_rel_rmse", [](const SweepRow& r) { return cell(r.vs_reference.rel_rmse); }},
      {"error_vs_reference_mean_rel", [](const SweepRow& r) { return cell(r.vs_reference.mean_rel); }},
      {"error_vs_reference_rel_l1", [](const SweepRow& r) { return cell(r.vs_reference.rel_l1); }},
  };
  return c;
}

std::string csv_text(const std::vector<SweepRow>& rows) {
  std::ostringstream s;
  const auto& cols = columns();
  for (size_t c = 0; c < cols.size(); ++c) s << (c ? "," : "") << cols[c].first;
  s << '\n';
  for (const auto& r : rows) {
    for (size_t c = 0; c < cols.size(); ++c) s << (c ? "," : "") << cols[c].second(r);
    s << '\n';
  }
  return s.str();
}

std::string utc_now() {
  std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// ---- the path-traced reference, cached in DIR --------------------------------------------------

struct Reference {
  Image image;
  double seconds = 0.0;
  bool reused = false;
};

// What a cached image was made from, as one string; any difference makes it stale.
std::string reference_key(const Scene& scene, const PathTraceOptions& o) {
  std::ostringstream k;
  k << "scene_hash=" << scene.hash << ";camera=" << scene.camera.width << "x" << scene.camera.height
    << ";spp=" << o.spp << ";seed=" << o.seed << ";max_depth=" << o.max_depth
    << ";roulette_depth=" << o.roulette_depth;
  return k.str();
}

Reference path_traced_reference(const std::string& dir, const Scene& scene, const PathTracer& tracer,
                                int spp) {
  const std::string image_path = dir + "/reference.exr", key_path = dir + "/reference.json";
  PathTraceOptions o;
  o.spp = spp;
  o.seed = kReferenceSeed;
  const std::string key = reference_key(scene, o);
  Reference ref;
  if (std::filesystem::exists(image_path) && std::filesystem::exists(key_path)) {
    JsonValue stored = parse_json(read_text_file(key_path, "the reference's key"), key_path);
    const JsonValue* k = stored.find("key");
    if (k && k->is(JsonValue::Kind::kString) && k->string == key) {
      ref.image = read_image(image_path);
      const JsonValue* s = stored.find("seconds");
      ref.seconds = s && s->is(JsonValue::Kind::kNumber) ? s->number : kNaN;
      ref.reused = true;
      return ref;
    }
    std::fprintf(stderr, "polyrad sweep: %s is stale (other scene, camera or samples); rendering it again\n",
                 image_path.c_str());
  }
  PathTraceResult r = tracer.render(scene.camera, o);
  if (!r.image.all_finite()) throw NumericalError("the path-traced reference has non-finite pixels");
  write_image(r.image, image_path);
  JsonWriter w;
  w.begin_object();
  w.value("key", key);
  w.value("seconds", r.seconds);
  w.value("rays", r.stats.rays);
  w.end_object();
  write_file_atomic(key_path, w.str());
  // Read back, so that a first run and a rerun measure against the same (half-float) values.
  ref.image = read_image(image_path);
  ref.seconds = r.seconds;
  return ref;
}

// ---- one discretisation ------------------------------------------------------------------------

struct PathTracedPoint {
  int spp;
  Image image;
  double seconds;
};

void sweep_patch_size(const SweepFlags& f, const Scene& scene, double patch_size,
                      const Image& reference, const std::vector<PathTracedPoint>& traced,
                      std::vector<SweepRow>& rows) {
  std::fprintf(stderr, "polyrad sweep: patch size %g\n", patch_size);
  PipelineOptions po;
  po.patch_size = patch_size;
  auto t0 = std::chrono::steady_clock::now();
  auto sys = build_system(scene, po);
  const double system_seconds = seconds_since(t0);
  const TransportOperator& t = sys->transport;
  Gather gather = build_gather(sys->scene.camera, sys->patches, sys->scene.materials, *sys->caster,
                               t, GatherOptions{});
  const Field e = t.emission();
  const double norm_e = t.flux_norm(e);
  const double a = t.max_albedo();
  auto apriori = [a](int k) { return a < 1.0 ? std::pow(a, k + 1) / (1.0 - a) : kNaN; };

  SolveOptions tight;
  tight.method = SolveMethod::kGaussSeidel;
  tight.tolerance = kConvergedTolerance;
  tight.max_iterations = 1000000;
  auto tc = std::chrono::steady_clock::now();
  SolveResult converged = solve(t, e, tight);
  if (!converged.ok())
    throw NumericalError("patch size " + std::to_string(patch_size) + ": the converged solution failed: " +
                         converged.message);
  const Image converged_image = apply_gather(gather, converged.u);
  const double converged_seconds = seconds_since(tc);
  auto solution_error = [&](const Field& u) {
    return norm_e > 0.0 ? t.flux_norm(converged.u - u) / norm_e : kNaN;
  };

  auto base_row = [&](const char* method) {
    SweepRow r;
    r.method = method;
    r.patch_size = patch_size;
    r.patches = static_cast<long long>(sys->patches.size());
    r.unknowns = static_cast<long long>(t.size());
    r.system_seconds = system_seconds;
    r.gather_seconds = gather.seconds;
    r.a_max = a;
    return r;
  };
  const double iterative_bytes = static_cast<double>(t.bytes() + gather.bytes());
  const double iterative_nnz = static_cast<double>(t.weights().nnz() + gather.g.nnz());

  {
    SweepRow r = base_row("converged");
    r.sweeps = converged.iterations;
    r.image_seconds = r.image_seconds_min = converged_seconds;
    r.repeats = 1;
    r.operator_bytes = iterative_bytes;
    r.operator_nnz = iterative_nnz;
    r.residual = converged.residual;
    r.solution_error = 0.0;
    r.vs_converged = {0.0, 0.0, 0.0};
    r.vs_reference = image_error(converged_image, reference);
    r.peak_rss_bytes = static_cast<double>(peak_memory_bytes());
    rows.push_back(r);
  }

  const long long points = static_cast<long long>(2 * f.sweeps.size() + traced.size() +
                                                  f.orders.size() * f.drops.size() * f.precisions.size());
  char stage[64];
  std::snprintf(stage, sizeof stage, "sweep, patch size %g", patch_size);
  Progress progress(stage, points);

  // The iterative solver after n sweeps; the time includes the gather that makes the image.
  for (SolveMethod m : {SolveMethod::kJacobi, SolveMethod::kGaussSeidel}) {
    for (int n : f.sweeps) {
      SolveOptions so;
      so.method = m;
      so.fixed_sweeps = n;
      std::vector<double> times;
      SolveResult result;
      Image image;
      for (int k = 0; k < f.repeats; ++k) {
        auto ts = std::chrono::steady_clock::now();
        result = solve(t, e, so);
        image = apply_gather(gather, result.u);
        times.push_back(seconds_since(ts));
      }
      if (result.status == SolveStatus::kDiverged) throw NumericalError(result.message);
      SweepRow r = base_row(solve_method_name(m));
      r.sweeps = n;
      r.image_seconds = median(times);
      r.image_seconds_min = fastest(times);
      r.repeats = f.repeats;
      r.operator_bytes = iterative_bytes;
      r.operator_nnz = iterative_nnz;
      // u_0 = e; Jacobi's n-th iterate is the order-n series, and Gauss-Seidel's lies between
      // it and u* (T is non-negative), so the a-priori bound holds for both.
      r.apriori_bound = apriori(n);
      r.residual = result.residual;
      r.solution_error = solution_error(result.u);
      r.vs_converged = image_error(image, converged_image);
      r.vs_reference = image_error(image, reference);
      r.peak_rss_bytes = static_cast<double>(peak_memory_bytes());
      rows.push_back(r);
      progress.advance();
    }
  }

  // The relight product. Its solution-space error is that of the order-K truncated series, which
  // is exactly Jacobi's K-th iterate (solver.h): the product itself only has pixels.
  for (int order : f.orders) {
    SolveOptions jk;
    jk.method = SolveMethod::kJacobi;
    jk.fixed_sweeps = order;
    const double truncation_error = solution_error(solve(t, e, jk).u);
    for (double drop : f.drops)
      for (const std::string& precision : f.precisions) {
        SeriesOptions so;
        so.order = order;
        so.drop = drop;
        so.precision = precision == "half" ? ValuePrecision::kHalf : ValuePrecision::kFloat;
        so.output = SeriesOutput::kView;
        so.progress = false;
        SeriesOperator q;
        auto tp = std::chrono::steady_clock::now();
        {
          InnerProgressOff quiet;
          q = precompute_series(t, sys->patches, sys->scene, &gather, so);
        }
        const double precompute_seconds = seconds_since(tp);
        const std::vector<float> emission = q.column_emission();
        std::vector<float> out(3 * static_cast<size_t>(q.rows()));
        std::vector<double> times;
        for (int k = 0; k < f.repeats; ++k) {
          auto ta = std::chrono::steady_clock::now();
          q.apply(emission.data(), out.data());
          times.push_back(seconds_since(ta));
        }
        const Image image = series_image(q, out);
        SweepRow r = base_row("series");
        r.order = order;
        r.drop = drop;
        r.precision = precision;
        r.image_seconds = median(times);
        r.image_seconds_min = fastest(times);
        r.precompute_seconds = precompute_seconds;
        r.repeats = f.repeats;
        r.operator_bytes = static_cast<double>(q.bytes());
        r.operator_nnz = static_cast<double>(q.nnz());
        r.apriori_bound = q.report.apriori_bound;
        r.aposteriori_estimate = q.report.aposteriori_estimate;
        r.dropped_relative = q.report.dropped_relative;
        r.solution_error = truncation_error;
        r.vs_converged = image_error(image, converged_image);
        r.vs_reference = image_error(image, reference);
        r.peak_rss_bytes = static_cast<double>(peak_memory_bytes());
        rows.push_back(r);
        progress.advance();
      }
  }

  // The path tracer knows no patches; its points repeat per discretisation so that each one's
  // chart has them, measured against that discretisation's converged image.
  for (const PathTracedPoint& p : traced) {
    SweepRow r = base_row("pathtrace");
    r.system_seconds = kNaN;
    r.gather_seconds = kNaN;
    r.a_max = kNaN;
    r.spp = p.spp;
    r.image_seconds = r.image_seconds_min = p.seconds;
    r.repeats = 1;
    r.vs_converged = image_error(p.image, converged_image);
    r.vs_reference = image_error(p.image, reference);
    r.peak_rss_bytes = static_cast<double>(peak_memory_bytes());
    rows.push_back(r);
    progress.advance();
  }
  progress.finish();
  std::fprintf(stderr, "polyrad sweep: patch size %g: %zu patches, %lld unknowns, built in %.2f s, converged in %d sweeps\n",
               patch_size, sys->patches.size(), static_cast<long long>(t.size()), system_seconds,
               converged.iterations);
}

// ---- the command -------------------------------------------------------------------------------

int run_sweep(const SweepFlags& f) {
  if (std::filesystem::exists(f.out) && !std::filesystem::is_directory(f.out))
    throw InputError("--out '" + f.out + "' is a file, not a directory");
  if (f.patch_sizes.empty()) throw InputError("--patch-sizes lists no patch size");
  auto t0 = std::chrono::steady_clock::now();
  const std::string load_at_start = load_average();
  const Scene scene = load_scene(f.scene);
  make_directories(f.out);  // after the scene has been read: bad input leaves nothing behind

  // The path tracer meshes the scene as it is: its answer does not depend on the patch size.
  const PatchSet pt_patches = mesh_scene(scene);
  const RayCaster pt_caster(pt_patches);
  const PathTracer tracer(pt_patches, scene.materials, pt_caster);
  std::fprintf(stderr, "polyrad sweep: %s, reference at %d spp\n", f.scene.c_str(), f.reference_spp);
  const Reference reference = path_traced_reference(f.out, scene, tracer, f.reference_spp);
  if (reference.reused)
    std::fprintf(stderr, "polyrad sweep: reusing %s/reference.exr\n", f.out.c_str());

  std::vector<PathTracedPoint> traced;
  {
    Progress progress("sweep, path tracer", static_cast<long long>(f.spp.size()));
    for (int spp : f.spp) {
      PathTraceOptions o;
      o.spp = spp;
      o.seed = kPointSeed;
      o.progress = false;
      PathTraceResult r = tracer.render(scene.camera, o);
      if (!r.image.all_finite()) throw NumericalError("a path-traced image has non-finite pixels");
      traced.push_back({spp, std::move(r.image), r.seconds});
      progress.advance();
    }
  }

  std::vector<SweepRow> rows;
  for (double ps : f.patch_sizes) sweep_patch_size(f, scene, ps, reference.image, traced, rows);

  std::ostringstream m;
  m << "machine: " << machine_description() << '\n'
    << "threads: " << omp_get_max_threads() << '\n'
    << "date: " << utc_now() << '\n'
    << "scene: " << std::filesystem::path(f.scene).filename().string() << '\n'
    << "camera: " << scene.camera.width << "x" << scene.camera.height << '\n'
    << "reference: path traced, " << f.reference_spp << " spp, "
    << cell(reference.seconds) << " s" << (reference.reused ? " (cached)" : "") << '\n'
    << "timing_repeats: " << f.repeats << '\n'
    << "load_average: " << load_at_start << " at the start, " << load_average() << " at the end\n"
    << "sweep_seconds: " << cell(seconds_since(t0)) << '\n';
  write_file_atomic(f.out + "/sweep.csv", csv_text(rows));
  write_file_atomic(f.out + "/machine.txt", m.str());
  std::fprintf(stderr, "polyrad sweep: %zu points in %.1f s; wrote %s/sweep.csv, %s/machine.txt\n",
               rows.size(), seconds_since(t0), f.out.c_str(), f.out.c_str());
  return kExitOk;
}

}  // namespace

void add_sweep_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<SweepFlags>();
  CLI::App* cmd = app.add_subcommand(
      "sweep", "Speed against accuracy: time and error of the series, the iterative solver and the path tracer");
  cmd->add_option("scene", f->scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", f->out, "Output directory (sweep.csv, machine.txt, the cached reference)")
      ->required();
  auto* patch_sizes = cmd->add_option("--patch-sizes", f->patch_sizes, "Patch sizes (scene units)")
                          ->delimiter(',')
                          ->check(CLI::PositiveNumber)
                          ->capture_default_str();
  cmd->add_option("--orders", f->orders, "Series orders K")
      ->delimiter(',')
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  auto* drops = cmd->add_option("--drops", f->drops, "Series drop tolerances (share of a column's energy dropped)")
                    ->delimiter(',')
                    ->check(CLI::Range(0.0, 0.999999))
                    ->capture_default_str();
  cmd->add_option("--precisions", f->precisions, "Series value precisions")
      ->delimiter(',')
      ->check(CLI::IsMember({"float", "half"}))
      ->capture_default_str();
  cmd->add_option("--sweeps", f->sweeps, "Jacobi and Gauss-Seidel sweep counts")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
  cmd->add_option("--spp", f->spp, "Path tracer samples per pixel")
      ->delimiter(',')
      ->check(CLI::Range(1, 1 << 24))
      ->capture_default_str();
  auto* reference_spp = cmd->add_option("--reference-spp", f->reference_spp,
                                        "Samples per pixel of the path-traced reference")
                            ->check(CLI::Range(1, 1 << 24))
                            ->capture_default_str();
  cmd->add_option("--repeats", f->repeats, "Timed repeats of each product and solve (median)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_flag("--quick", f->quick,
                "The demo's preset, about a minute on 2 cores: patch sizes 100,50,35, drops 0,1e-3, "
                "reference at 512 spp (flags given explicitly still win)");
  cmd->callback([=, &exit_code] {
    if (f->quick) {
      // The finest patches cost the most (form factors and transfer grow with the square of the
      // patch count, the precompute with nnz(T)): 35 keeps the demo near a minute.
      if (!patch_sizes->count()) f->patch_sizes = {100, 50, 35};
      if (!drops->count()) f->drops = {0.0, 1e-3};
      // 512: its own noise (about 3 percent relative L1 on the mirror cube) stays below the
      // discretisation error that the converged solutions show against it.
      if (!reference_spp->count()) f->reference_spp = 512;
    }
    exit_code = run_sweep(*f);
  });
}

}  // namespace polyrad::cli
