// Speed against accuracy (app/sweep.h).
#include "polyrad/app/sweep.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <sstream>

#include "polyrad/app/reference_cache.h"
#include "polyrad/app/report.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/files.h"
#include "polyrad/util/machine.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/stats.h"

namespace polyrad {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The reference and the sweep's path-traced points use different seeds: with one seed the
// first n samples of each reference pixel would be the n-spp image's, and its error would look
// smaller than it is.
constexpr std::uint64_t kReferenceSeed = 0x5eed5eedull;
constexpr std::uint64_t kPointSeed = 1;
constexpr double kConvergedTolerance = 1e-9;

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
  std::string mesh;    // uniform | hierarchical
  double patch_size = kNaN;
  double link_tolerance = kNaN;  // hierarchical meshes
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
      {"mesh", [](const SweepRow& r) { return r.mesh; }},
      {"patch_size_scene_units", [](const SweepRow& r) { return cell(r.patch_size); }},
      {"link_tolerance", [](const SweepRow& r) { return cell(r.link_tolerance); }},
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
      {"error_vs_converged_rel_rmse",
       [](const SweepRow& r) { return cell(r.vs_converged.rel_rmse); }},
      {"error_vs_converged_mean_rel",
       [](const SweepRow& r) { return cell(r.vs_converged.mean_rel); }},
      {"error_vs_converged_rel_l1", [](const SweepRow& r) { return cell(r.vs_converged.rel_l1); }},
      {"error_vs_reference_rel_rmse",
       [](const SweepRow& r) { return cell(r.vs_reference.rel_rmse); }},
      {"error_vs_reference_mean_rel",
       [](const SweepRow& r) { return cell(r.vs_reference.mean_rel); }},
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

// ---- one discretisation ------------------------------------------------------------------------

struct PathTracedPoint {
  int spp;
  Image image;
  double seconds;
};

// One mesh of the sweep: a uniform one at a patch size, or a hierarchical one on its patches.
struct Discretisation {
  double patch_size = kNaN;
  SystemOptions system;
  std::string label() const {
    char text[96];
    if (system.mesh == MeshKind::kHierarchical)
      std::snprintf(text, sizeof text, "patch size %g, hierarchical, link tolerance %g", patch_size,
                    system.hierarchy.tolerance());
    else
      std::snprintf(text, sizeof text, "patch size %g", patch_size);
    return text;
  }
};

void sweep_discretisation(const SweepOptions& f, const Scene& scene, const Discretisation& d,
                          const Image& reference, const std::vector<PathTracedPoint>& traced,
                          std::vector<SweepRow>& rows) {
  const double patch_size = d.patch_size;
  const std::string label = d.label();
  std::fprintf(stderr, "polyrad sweep: %s\n", label.c_str());
  Stopwatch watch;
  auto sys = build_system(World::build(scene, {.patch_size = patch_size}), d.system);
  const double system_seconds = watch.seconds();
  const TransportOperator& t = sys->transport;
  const World& world = *sys->world;
  const auto direct = mesh_direct_for(f.gather, t, world);
  const Gather gather = build_gather(world, t.layout(), f.gather, direct.get());
  const std::string cut = describe_chain_cut(summarize(gather));
  if (!cut.empty())
    std::fprintf(stderr, "polyrad sweep: warning: %s: %s\n", label.c_str(), cut.c_str());
  const Field e = t.emission();
  const double norm_e = t.flux_norm(e);
  const double a = t.max_albedo();
  auto apriori = [a](int k) { return a < 1.0 ? std::pow(a, k + 1) / (1.0 - a) : kNaN; };

  SolveOptions tight;
  tight.method = SolveMethod::kGaussSeidel;
  tight.tolerance = kConvergedTolerance;
  tight.max_iterations = 1000000;
  Stopwatch converged_watch;
  SolveResult converged = solve(t, e, tight);
  if (!converged.ok())
    throw NumericalError(label + ": the converged solution failed: " + converged.message);
  const std::vector<Rgb> emission = scene_emission(world.patches());
  const Image converged_image = apply_gather(gather, converged.u, emission);
  const double converged_seconds = converged_watch.seconds();
  auto solution_error = [&](const Field& u) {
    return norm_e > 0.0 ? t.flux_norm(converged.u - u) / norm_e : kNaN;
  };

  auto base_row = [&](const char* method) {
    SweepRow r;
    r.method = method;
    r.mesh = enum_name(d.system.mesh.value_or(MeshKind::kUniform));
    r.patch_size = patch_size;
    if (d.system.mesh == MeshKind::kHierarchical) r.link_tolerance = d.system.hierarchy.tolerance();
    r.patches = static_cast<long long>(sys->num_unknown_patches());  // a hierarchy's leaves
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

  const long long points = static_cast<long long>(
      2 * f.sweeps.size() + traced.size() + f.orders.size() * f.drops.size() * f.precisions.size());
  Progress progress("sweep, " + label, points);

  // The iterative solver after n sweeps; the time includes the gather that makes the image.
  for (SolveMethod m : {SolveMethod::kJacobi, SolveMethod::kGaussSeidel}) {
    for (int n : f.sweeps) {
      SolveOptions so;
      so.method = m;
      so.fixed_sweeps = n;
      SolveResult result;
      Image image;
      const RepeatTimes times = time_repeats(f.repeats, [&] {
        result = solve(t, e, so);
        image = apply_gather(gather, result.u, emission);
      });
      if (result.status == SolveStatus::kDiverged) throw NumericalError(result.message);
      SweepRow r = base_row(enum_name(m));
      r.sweeps = n;
      r.image_seconds = times.median;
      r.image_seconds_min = times.min;
      r.repeats = times.repeats;
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
        so.precision = enum_from_name<ValuePrecision>(precision);
        so.output = SeriesOutput::kView;
        so.gather = f.gather;
        so.progress = false;
        SeriesOperator q;
        Stopwatch precompute_watch;
        {
          const QuietProgress quiet;  // one display, the sweep's
          q = precompute_series(t, world, so, &gather);
        }
        const double precompute_seconds = precompute_watch.seconds();
        const std::vector<float> columns = q.column_emission();
        std::vector<float> out(3 * static_cast<size_t>(q.rows()));
        const RepeatTimes times =
            time_repeats(f.repeats, [&] { q.apply(columns.data(), out.data()); });
        const Image image = series_image(q, out);
        SweepRow r = base_row("series");
        r.order = order;
        r.drop = drop;
        r.precision = precision;
        r.image_seconds = times.median;
        r.image_seconds_min = times.min;
        r.precompute_seconds = precompute_seconds;
        r.repeats = times.repeats;
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
  std::fprintf(stderr,
               "polyrad sweep: %s: %zu patches, %lld unknowns, built in %.2f s, "
               "converged in %d sweeps\n",
               label.c_str(), static_cast<size_t>(sys->num_unknown_patches()),
               static_cast<long long>(t.size()), system_seconds, converged.iterations);
}

}  // namespace

void apply_quick_preset(SweepOptions& o, const SweepChoices& chosen) {
  // The finest patches cost the most (form factors and transfer grow with the square of the
  // patch count, the precompute with nnz(T)): 35 keeps the sweep near three minutes with the
  // hierarchical mesh (163 to 177 s on 2 cores).
  if (!chosen.patch_sizes) o.patch_sizes = {100, 50, 35};
  if (!chosen.drops) o.drops = {0.0, 1e-3};
  // One hierarchical mesh on the coarsest patches: the point a render with this gather makes.
  if (!chosen.link_tolerances) o.link_tolerances = {link_tolerance_for(o.gather)};
  // 512: its own noise (about 3 percent relative L1 on the mirror cube) stays below the
  // discretisation error that the converged solutions show against it.
  if (!chosen.reference_spp) o.reference_spp = 512;
}

SweepResult sweep(const std::string& scene_path, const SweepOptions& f) {
  if (std::filesystem::exists(f.out) && !std::filesystem::is_directory(f.out))
    throw InputError("--out '" + f.out + "' is a file, not a directory");
  if (f.patch_sizes.empty()) throw InputError("--patch-sizes lists no patch size");
  Stopwatch watch;
  const std::string load_at_start = load_average();
  const Scene scene = load_scene(scene_path);
  make_directories(f.out);  // after the scene has been read: bad input leaves nothing behind

  // The path tracer meshes the scene as it is: its answer does not depend on the patch size.
  const auto pt_world = World::build(scene);
  const PathTracer tracer(*pt_world);
  std::fprintf(stderr, "polyrad sweep: %s, reference at %d spp\n", scene_path.c_str(),
               f.reference_spp);
  PathTraceOptions reference_options;
  reference_options.spp = f.reference_spp;
  reference_options.seed = kReferenceSeed;
  reference_options.max_depth = f.max_depth;
  const CachedReference reference = cached_reference(f.out, *pt_world, reference_options);
  if (reference.reused)
    std::fprintf(stderr, "polyrad sweep: reusing %s/reference.exr\n", f.out.c_str());
  PathTraceSummary reference_paths;
  reference_paths.max_depth = reference_options.max_depth;
  reference_paths.stats = reference.stats;
  const std::string cut = describe_truncation(reference_paths);
  if (!cut.empty())
    std::fprintf(stderr, "polyrad sweep: warning: the reference: %s\n", cut.c_str());

  std::vector<PathTracedPoint> traced;
  {
    Progress progress("sweep, path tracer", static_cast<long long>(f.spp.size()));
    for (int spp : f.spp) {
      PathTraceOptions o;
      o.spp = spp;
      o.seed = kPointSeed;
      o.max_depth = f.max_depth;
      o.progress = false;
      PathTraceResult r = tracer.render(scene.camera, o);
      if (!r.image.all_finite()) throw NumericalError("a path-traced image has non-finite pixels");
      traced.push_back({spp, std::move(r.image), r.seconds});
      progress.advance();
    }
  }

  std::vector<SweepRow> rows;
  std::vector<Discretisation> meshes;
  for (double ps : f.patch_sizes) {
    Discretisation d{ps, {}};
    d.system.mesh = MeshKind::kUniform;
    meshes.push_back(d);
  }
  for (double tau : f.link_tolerances) {
    Discretisation d{f.patch_sizes.front(), {}};
    d.system.mesh = MeshKind::kHierarchical;
    d.system.hierarchy.link_tolerance = tau;
    meshes.push_back(d);
  }
  for (const Discretisation& d : meshes)
    sweep_discretisation(f, scene, d, reference.image, traced, rows);

  std::ostringstream m;
  m << "machine: " << machine_description() << '\n'
    << "threads: " << omp_get_max_threads() << '\n'
    << "date: " << utc_now() << '\n'
    << "scene: " << std::filesystem::path(scene_path).filename().string() << '\n'
    << "camera: " << scene.camera.width << "x" << scene.camera.height << '\n'
    << "reference: path traced, " << f.reference_spp << " spp, " << cell(reference.seconds) << " s"
    << (reference.reused ? " (cached)" : "") << '\n'
    << "reference_paths_cut_at_max_depth: " << reference.stats.truncated << " of "
    << reference.stats.paths << '\n'
    << "timing_repeats: " << f.repeats << '\n'
    << "load_average: " << load_at_start << " at the start, " << load_average() << " at the end\n"
    << "sweep_seconds: " << cell(watch.seconds()) << '\n';
  write_file_atomic(f.out + "/sweep.csv", csv_text(rows));
  write_file_atomic(f.out + "/machine.txt", m.str());
  return {static_cast<long long>(rows.size()), watch.seconds(), reference.reused};
}

}  // namespace polyrad
