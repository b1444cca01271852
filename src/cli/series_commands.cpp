// polyrad precompute / relight, and render --method series: the precomputed power series.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <sstream>

#include "render_flags.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/util/files.h"
#include "polyrad/io/image_io.h"
#include "polyrad/io/prt_file.h"
#include "polyrad/solve/series.h"

namespace polyrad::cli {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void write_series_report(JsonWriter& w, const SeriesOperator& q) {
  const SeriesReport& r = q.report;
  w.value("output", series_output_name(q.output));
  w.value("basis", series_basis_name(q.basis));
  w.value("precision", value_precision_name(q.precision));
  w.value("rows", static_cast<long long>(q.rows()));
  w.value("columns", static_cast<long long>(q.cols()));
  w.value("order", r.order);
  w.value("max_albedo", r.max_albedo);
  w.value("apriori_bound", r.apriori_bound);
  w.value("aposteriori_estimate", r.aposteriori_estimate);
  w.value("last_term_norm", r.term_norms.empty() ? 0.0 : r.term_norms.back());
  w.value("spectral_radius_estimate", r.spectral_radius);
  w.value("acceleration", r.acceleration == SeriesAcceleration::kChebyshev ? "chebyshev" : "none");
  w.value("residual_bound", r.residual_bound);
  w.begin_array("term_norms");
  for (double x : r.term_norms) w.element(x);
  w.end_array();
  w.value("nnz", static_cast<long long>(q.nnz()));
  w.value("bytes", q.bytes());
  w.value("dropped_energy", r.dropped_energy);
  w.value("dropped_relative", r.dropped_relative);
  w.value("reorder", series_reorder_name(r.reorder));
  w.value("bandwidth_before", r.bandwidth_before);
  w.value("bandwidth_after", r.bandwidth_after);
  w.value("reorder_seconds", r.reorder_seconds);
}

// Parses NAME=R,G,B.
std::pair<std::string, Rgb> parse_emission(const std::string& text) {
  auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError("--emission expects NAME=R,G,B, got '" + text + "'");
  std::string name = text.substr(0, eq);
  std::stringstream ss(text.substr(eq + 1));
  Rgb c;
  char comma1 = 0, comma2 = 0;
  if (!(ss >> c[0] >> comma1 >> c[1] >> comma2 >> c[2]) || comma1 != ',' || comma2 != ',' || !ss.eof())
    throw InputError("--emission expects NAME=R,G,B with three numbers, got '" + text + "'");
  if ((c < 0.0).any() || !c.isFinite().all()) throw InputError("--emission for '" + name + "' must be finite and not negative");
  return {name, c};
}

SeriesOptions series_options(int order, double tolerance, double drop, const std::string& precision,
                             const std::string& output, const std::string& basis,
                             const std::string& acceleration, const std::string& reorder) {
  SeriesOptions o;
  if (acceleration == "chebyshev") o.acceleration = SeriesAcceleration::kChebyshev;
  o.reorder = reorder == "rcm" ? SeriesReorder::kRcm : SeriesReorder::kNone;
  o.order = order;
  o.tolerance = tolerance;
  o.drop = drop;
  o.precision = precision == "half" ? ValuePrecision::kHalf : ValuePrecision::kFloat;
  o.output = output == "solution" ? SeriesOutput::kSolution : SeriesOutput::kView;
  o.basis = basis == "object" ? SeriesBasis::kObject : SeriesBasis::kPatch;
  return o;
}

// The image of a product: view mode directly; solution mode through the scene camera's gather,
// rebuilt from the scene the operator was made from (given the operator's --patch-size, if any).
Image product_image(const SeriesOperator& q, const std::vector<float>& out, Scene* scene,
                    double* gather_seconds) {
  if (q.output == SeriesOutput::kView) return series_image(q, out);
  POLYRAD_CHECK(scene != nullptr);
  auto t0 = std::chrono::steady_clock::now();
  override_patch_size(*scene, q.patch_size);
  PatchSet patches = mesh_scene(*scene);
  if (static_cast<int>(patches.size()) != q.layout.num_patches)
    throw InputError("the scene meshes into " + std::to_string(patches.size()) +
                     " patches but the operator has " + std::to_string(q.layout.num_patches));
  RayCaster caster(patches);
  Gather g = build_gather(scene->camera, patches, scene->materials, caster, q.layout, q.gather);
  Image img = apply_gather(g, series_field(q, out));
  if (gather_seconds) *gather_seconds = seconds_since(t0);
  return img;
}

// ---- precompute ------------------------------------------------------------------------------

struct PrecomputeFlags {
  std::string scene, output, report, output_kind = "view", precision = "float", basis = "patch",
      acceleration = "none", reorder = "none";
  int order = -1;
  double tolerance = 1e-3, drop = 0.0;
  GatherFlags gather;  // view rows: the gather folded in; solution rows: the one relight builds
  SystemFlags system;
};

// Before the scene is built: --reorder rcm renumbers T's stored link rows, and on the fly there
// are none (precompute_series would refuse it only after the whole build).
void check_reorder(const std::string& reorder, const SystemFlags& system) {
  if (reorder == "rcm" && system.on_the_fly)
    throw InputError("--reorder rcm renumbers T's stored rows; --specular-on-the-fly stores none "
                     "(use --reorder none)");
}

int run_precompute(const PrecomputeFlags& f) {
  check_reorder(f.reorder, f.system);
  check_output_path(f.output, "operator file");
  if (!f.report.empty()) check_output_path(f.report, "report");
  auto t0 = std::chrono::steady_clock::now();
  auto sys = build_system(load_scene(f.scene, f.system.scene_options()), f.system.pipeline());
  print_warnings(*sys);
  SeriesOptions o = series_options(f.order, f.tolerance, f.drop, f.precision, f.output_kind, f.basis,
                                   f.acceleration, f.reorder);
  const GatherOptions go = f.gather.options(f.system.classic);
  std::unique_ptr<Gather> gather;
  if (o.output == SeriesOutput::kView)
    gather = std::make_unique<Gather>(build_gather(sys->scene.camera, sys->patches, sys->scene.materials,
                                                   *sys->caster, sys->transport, go));
  SeriesOperator q = precompute_series(sys->transport, sys->patches, sys->scene, gather.get(), o);
  if (o.output == SeriesOutput::kSolution) q.gather = go;
  q.patch_size = f.system.patch_size;
  auto tw = std::chrono::steady_clock::now();
  write_prt(q, f.output);
  double write_seconds = seconds_since(tw);
  if (!f.report.empty()) {
    JsonWriter w;
    w.begin_object().value("command", "precompute");
    write_system(w, *sys);
    write_series_report(w, q);
    auto times = sys->times;
    if (gather) times.push_back({"gather_build", gather->seconds});
    times.push_back({"series", q.report.seconds});
    times.push_back({"write", write_seconds});
    times.push_back({"total", seconds_since(t0)});
    write_stage_times(w, times);
    w.value("peak_memory_bytes", peak_memory_bytes());
    w.value("machine", machine_description());
    w.end_object();
    write_file_atomic(f.report, w.str());
  }
  const bool cheb = q.report.acceleration == SeriesAcceleration::kChebyshev;
  std::fprintf(stderr, "polyrad: %s operator, %s of order %d (%s %.2e), %lld x %lld, %lld non-zeros, %.1f MB; wrote %s\n",
               series_output_name(q.output), cheb ? "Chebyshev polynomial" : "power series",
               q.report.order, cheb ? "residual bound" : "a-posteriori estimate",
               cheb ? q.report.residual_bound : q.report.aposteriori_estimate,
               static_cast<long long>(q.rows()),
               static_cast<long long>(q.cols()), static_cast<long long>(q.nnz()), q.bytes() / 1e6,
               f.output.c_str());
  return kExitOk;
}

// ---- relight ---------------------------------------------------------------------------------

struct RelightFlags {
  std::string prt, output, report, scene;
  std::vector<std::string> emission;
  int repeats = 5;
  double exposure = 1.0;
};

int run_relight(const RelightFlags& f) {
  check_image_path(f.output);
  if (!f.report.empty()) check_output_path(f.report, "report");
  std::map<std::string, Rgb> overrides;
  for (const auto& text : f.emission) {
    auto [name, value] = parse_emission(text);
    if (overrides.count(name)) throw InputError("--emission names '" + name + "' twice");
    overrides[name] = value;
  }
  auto t0 = std::chrono::steady_clock::now();
  SeriesOperator q = read_prt(f.prt);
  double load_seconds = seconds_since(t0);
  // A stale operator (its scene changed since) is refused: the scene is hashed again.
  std::string scene_path = f.scene.empty() ? q.scene_file : f.scene;
  std::unique_ptr<Scene> scene;
  try {
    scene = std::make_unique<Scene>(load_scene(scene_path));
  } catch (const InputError& e) {
    throw InputError(SourceLocation{f.prt}, "cannot check the operator against its scene '" +
                                                scene_path + "' (" + e.message() +
                                                "); pass --scene PATH if it moved");
  }
  if (scene->hash != q.scene_hash)
    throw InputError(SourceLocation{f.prt}, "stale operator: the scene '" + scene_path +
                                                "' has changed since it was precomputed (or it was built from another scene)");
  std::vector<float> e = q.column_emission(overrides);
  std::vector<float> out(3 * static_cast<std::size_t>(q.rows()));
  // The product, timed over repeats (median): what a change of lights costs.
  std::vector<double> times;
  for (int r = 0; r < std::max(1, f.repeats); ++r) {
    auto tp = std::chrono::steady_clock::now();
    q.apply(e.data(), out.data());
    times.push_back(seconds_since(tp));
  }
  std::sort(times.begin(), times.end());
  double median = times[times.size() / 2];
  double gather_seconds = 0.0;
  Image img = product_image(q, out, scene.get(), &gather_seconds);
  if (!img.all_finite()) throw NumericalError("the relit image has non-finite pixels");
  write_image(img, f.output, ImageWriteOptions{f.exposure});
  if (!f.report.empty()) {
    JsonWriter w;
    w.begin_object().value("command", "relight").value("operator", f.prt);
    write_series_report(w, q);
    w.value("product_seconds_median", median);
    w.value("product_repeats", static_cast<int>(times.size()));
    w.value("bytes_touched", q.bytes() + 3 * sizeof(float) * (static_cast<std::size_t>(q.cols()) + q.rows()));
    w.value("bytes_per_second", (q.bytes() + 12.0 * (q.cols() + q.rows())) / median);
    w.begin_object("seconds").value("load", load_seconds).value("product", median).value("gather", gather_seconds).end_object();
    w.value("peak_memory_bytes", peak_memory_bytes());
    w.value("machine", machine_description());
    w.end_object();
    write_file_atomic(f.report, w.str());
  }
  std::fprintf(stderr, "polyrad: relit with one product of %lld non-zeros in %.3f ms (median of %zu); wrote %s\n",
               static_cast<long long>(q.nnz()), 1e3 * median, times.size(), f.output.c_str());
  return kExitOk;
}

}  // namespace

// ---- render --method series ------------------------------------------------------------------

int render_series(const RenderFlags& f) {
  check_reorder(f.reorder, f.system);
  check_image_path(f.output);
  if (!f.report.empty()) check_output_path(f.report, "report");
  if (!f.patches_csv.empty()) throw InputError("--patches needs --method iterative (a view-mode series has no patch values)");
  auto t0 = std::chrono::steady_clock::now();
  auto sys = build_system(load_scene(f.scene, f.system.scene_options()), f.system.pipeline());
  print_warnings(*sys);
  Gather gather = build_gather(sys->scene.camera, sys->patches, sys->scene.materials, *sys->caster,
                               sys->transport, f.gather.options(f.system.classic));
  SeriesOptions o = series_options(f.order, f.tolerance, 0.0, "float", "view", "patch", f.acceleration,
                                   f.reorder);
  SeriesOperator q = precompute_series(sys->transport, sys->patches, sys->scene, &gather, o);
  std::vector<float> e = q.column_emission();
  std::vector<float> out(3 * static_cast<std::size_t>(q.rows()));
  auto tp = std::chrono::steady_clock::now();
  q.apply(e.data(), out.data());
  double product_seconds = seconds_since(tp);
  Image img = series_image(q, out);
  if (!img.all_finite()) throw NumericalError("the image has non-finite pixels");
  write_image(img, f.output, ImageWriteOptions{f.exposure});
  if (!f.report.empty()) {
    JsonWriter w;
    w.begin_object().value("command", "render").value("method", "series");
    write_system(w, *sys);
    write_series_report(w, q);
    auto times = sys->times;
    times.push_back({"gather_build", gather.seconds});
    times.push_back({"series", q.report.seconds});
    times.push_back({"product", product_seconds});
    times.push_back({"total", seconds_since(t0)});
    write_stage_times(w, times);
    w.value("peak_memory_bytes", peak_memory_bytes());
    w.value("machine", machine_description());
    w.end_object();
    write_file_atomic(f.report, w.str());
  }
  std::fprintf(stderr, "polyrad: %zu patches, series of order %d, product %.3f ms; wrote %s\n",
               sys->patches.size(), q.report.order, 1e3 * product_seconds, f.output.c_str());
  return kExitOk;
}

void add_precompute_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<PrecomputeFlags>();
  CLI::App* cmd = app.add_subcommand("precompute", "Precompute the truncated power series of the transport operator");
  cmd->add_option("scene", f->scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  // `-o FILE` names the file and `--output view|solution` the rows, as the precompute has always
  // been documented; `--file` and `--rows` are longer spellings of the same two.
  cmd->add_option("-o,--file", f->output, "Operator file to write (.prt)")->required();
  auto* order = cmd->add_option("--order", f->order, "Order K of the series")->check(CLI::Range(0, 100000));
  cmd->add_option("--tolerance", f->tolerance, "Choose K for this relative error (flux-weighted)")
      ->check(CLI::Range(1e-14, 1.0))
      ->excludes(order)
      ->capture_default_str();
  cmd->add_option("--drop", f->drop, "Drop each column's smallest entries, up to this share of its energy")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--precision", f->precision, "Stored value precision")
      ->check(CLI::IsMember({"float", "half"}))
      ->capture_default_str();
  cmd->add_option("--output,--rows,--output-kind", f->output_kind, "Rows: the camera's pixels, or every unknown")
      ->check(CLI::IsMember({"view", "solution"}))
      ->capture_default_str();
  cmd->add_option("--basis", f->basis, "Columns: one per emitting patch, or one per emitting object")
      ->check(CLI::IsMember({"patch", "object"}))
      ->capture_default_str();
  cmd->add_option("--acceleration", f->acceleration,
                  "Plain power series, or the Chebyshev polynomial (fewer terms near albedo 1; "
                  "needs a real spectrum, as diffuse scenes have)")
      ->check(CLI::IsMember({"none", "chebyshev"}))
      ->capture_default_str();
  cmd->add_option("--reorder", f->reorder,
                  "Number the unknowns as built, or by reverse Cuthill-McKee for the locality of "
                  "the precompute's products (the same operator; a second copy of T while it "
                  "runs)")
      ->check(CLI::IsMember({"none", "rcm"}))
      ->capture_default_str();
  cmd->add_option("--report", f->report, "Write a JSON report here");
  f->gather.add(*cmd);
  f->system.add(*cmd);
  cmd->callback([f, &exit_code] { exit_code = run_precompute(*f); });
}

void add_relight_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<RelightFlags>();
  CLI::App* cmd = app.add_subcommand("relight", "Relight with a precomputed operator: one sparse product");
  cmd->add_option("operator", f->prt, "Operator file (.prt)")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", f->output, "Image: .exr or .pfm (linear), .png (tonemapped)")->required();
  cmd->add_option("--emission", f->emission, "NAME=R,G,B: new emission of a light (repeatable; 0,0,0 turns it off)");
  cmd->add_option("--scene", f->scene, "The scene, if it moved since the precompute");
  cmd->add_option("--repeats", f->repeats, "Time the product over this many repeats (median)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--exposure", f->exposure, "Exposure of the .png tonemap")->check(CLI::PositiveNumber);
  cmd->add_option("--report", f->report, "Write a JSON report here");
  cmd->callback([f, &exit_code] { exit_code = run_relight(*f); });
}

}  // namespace polyrad::cli
