// polyrad demo [--out DIR]: the main job on the default scene, end to end.
//
//   1. the glossy radiosity system of the scene (form factors, specular transfer, operator T);
//   2. the iterative solution and its image (the reference every faster method is tested against);
//   3. the precomputed truncated power series (view rows), written as a .prt file;
//   4. relighting with it: one sparse product per new light, timed against the iterative solve;
//   5. a path-traced reference, and the radiosity image compared with it.
// Everything lands in DIR with report.json and summary.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <sstream>

#include "cli_common.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/util/files.h"
#include "polyrad/io/image_io.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/io/prt_file.h"
#include "polyrad/scene/scene.h"
#include "polyrad/solve/series.h"

#ifndef POLYRAD_SCENES_DIR
#define POLYRAD_SCENES_DIR "scenes"
#endif

namespace polyrad::cli {

namespace {

struct DemoFlags {
  std::string out = "out";
  std::string scene = std::string(POLYRAD_SCENES_DIR) + "/cornell-mirror-cube.json";
  int spp = 256;
  int repeats = 21;
};

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void say(const char* what) { std::fprintf(stderr, "polyrad demo: %s\n", what); }

// The median time of `repeats` products.
double product_seconds(const SeriesOperator& q, const std::vector<float>& e, std::vector<float>& out,
                       int repeats) {
  std::vector<double> times;
  for (int r = 0; r < repeats; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    q.apply(e.data(), out.data());
    times.push_back(since(t0));
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

int run_demo(const DemoFlags& f) {
  make_directories(f.out);
  const std::string dir = f.out + "/";
  auto t_all = std::chrono::steady_clock::now();

  say("building the glossy radiosity system (form factors, specular transfer, operator)");
  auto sys = build_system(load_scene(f.scene), PipelineOptions{});
  const auto& t = sys->transport;
  Gather gather = build_gather(sys->scene.camera, sys->patches, sys->scene.materials, *sys->caster,
                               t, GatherOptions{});

  say("solving iteratively (Gauss-Seidel to a relative residual of 1e-4)");
  SolveResult solution = solve(t, t.emission(), SolveOptions{});
  if (!solution.ok()) throw NumericalError(solution.message);
  auto tg = std::chrono::steady_clock::now();
  Image radiosity = apply_gather(gather, solution.u);
  const double iterative_seconds = solution.seconds + since(tg);
  write_image(radiosity, dir + "radiosity.exr");
  write_image(radiosity, dir + "radiosity.png");

  say("precomputing the truncated power series (tolerance 1e-3, view rows)");
  SeriesOptions so;
  so.tolerance = 1e-3;
  SeriesOperator q = precompute_series(t, sys->patches, sys->scene, &gather, so);
  write_prt(q, dir + "scene.prt");

  say("relighting: one sparse product per new light");
  std::vector<float> out(3 * static_cast<std::size_t>(q.rows()));
  struct Relight {
    const char* file;
    const char* what;
    Rgb emission;
    double seconds;
  };
  std::vector<Relight> relights = {{"relit-as-scene", "the scene's light", q.columns[0].emission, 0},
                                   {"relit-double", "twice as bright", 2.0 * q.columns[0].emission, 0},
                                   {"relit-blue", "a cold blue light", Rgb(4, 12, 17), 0}};
  const std::string light = q.columns[0].object;
  for (auto& r : relights) {
    std::vector<float> e = q.column_emission({{light, r.emission}});
    r.seconds = product_seconds(q, e, out, f.repeats);
    write_image(series_image(q, out), dir + r.file + ".png");
  }
  // The product against the iterative solution it replaces.
  Image relit = series_image(q, [&] {
    std::vector<float> e = q.column_emission();
    q.apply(e.data(), out.data());
    return out;
  }());
  ImageComparison series_vs_iterative = compare_images(relit, radiosity);

  say("path tracing a reference (the same scene, materials and camera)");
  PathTracer tracer(sys->patches, sys->scene.materials, *sys->caster);
  PathTraceOptions po;
  po.spp = f.spp;
  PathTraceResult traced = tracer.render(sys->scene.camera, po);
  write_image(traced.image, dir + "pathtraced.exr");
  write_image(traced.image, dir + "pathtraced.png");
  RegionMap regions = object_regions(sys->scene, sys->patches, *sys->caster);
  ImageComparison vs_reference = compare_images(radiosity, traced.image, {}, &regions);
  Image error = error_picture(radiosity, traced.image, 0.25, 0.01);
  write_image(side_by_side(radiosity, traced.image, error, 1.0, 4), dir + "compare.png");

  // report.json and summary.md.
  const double product = relights[0].seconds;
  JsonWriter w;
  w.begin_object().value("command", "demo");
  write_system(w, *sys);
  write_solve(w, solution);
  auto times = sys->times;
  times.push_back({"solve", solution.seconds});
  times.push_back({"gather_build", gather.seconds});
  times.push_back({"series_precompute", q.report.seconds});
  times.push_back({"product_median", product});
  times.push_back({"iterative_image", iterative_seconds});
  times.push_back({"path_trace", traced.seconds});
  times.push_back({"total", since(t_all)});
  write_stage_times(w, times);
  w.begin_object("series")
      .value("order", q.report.order)
      .value("aposteriori_estimate", q.report.aposteriori_estimate)
      .value("nnz", static_cast<long long>(q.nnz()))
      .value("bytes", q.bytes())
      .value("speedup_over_iterative", iterative_seconds / product)
      .value("relative_l1_vs_iterative", series_vs_iterative.relative_l1)
      .end_object();
  w.begin_object("path_traced_reference")
      .value("spp", f.spp)
      .value("relative_rmse", vs_reference.relative_rmse)
      .value("mean_relative_error", vs_reference.mean_relative_error);
  w.begin_array("regions");
  for (const auto& r : vs_reference.regions)
    w.begin_object().value("name", r.name).value("pixels", r.pixels).value("luminance_difference", r.luminance_difference).end_object();
  w.end_array().end_object();
  w.value("peak_memory_bytes", peak_memory_bytes());
  w.value("machine", machine_description());
  w.end_object();
  write_file_atomic(dir + "report.json", w.str());

  std::ostringstream md;
  md.precision(3);
  md << "# polyrad demo: " << sys->scene.file << "\n\n"
     << "Machine: " << machine_description() << "\n\n"
     << "| | |\n|---|---|\n"
     << "| patches / unknowns (B + specular links) | " << sys->patches.size() << " / " << t.size() << " |\n"
     << "| operator T | " << t.nnz_diffuse() << " diffuse + " << t.nnz_specular() << " specular non-zeros, "
     << t.bytes() / 1e6 << " MB |\n"
     << "| form factors + specular transfer | " << sys->seconds("form_factors") << " s + "
     << sys->seconds("specular_transfer") << " s |\n"
     << "| iterative solve + gather (" << solution.iterations << " Gauss-Seidel sweeps) | "
     << iterative_seconds * 1e3 << " ms |\n"
     << "| series precompute (order " << q.report.order << ", view rows) | " << q.report.seconds
     << " s, " << q.bytes() / 1e6 << " MB |\n"
     << "| relight: one product (median of " << f.repeats << ") | " << product * 1e3 << " ms, "
     << iterative_seconds / product << "x faster than the iterative solve |\n"
     << "| series image vs iterative image | relative L1 " << series_vs_iterative.relative_l1 << " |\n"
     << "| radiosity vs path tracer (" << f.spp << " spp) | relative RMSE "
     << vs_reference.relative_rmse << ", mean relative error " << vs_reference.mean_relative_error << " |\n\n"
     << "Region means, radiosity against the path tracer:\n\n| region | difference |\n|---|---|\n";
  for (const auto& r : vs_reference.regions)
    md << "| " << r.name << " | " << 100.0 * r.luminance_difference << " % |\n";
  md << "\nImages: radiosity.png (iterative), relit-*.png (one product each), pathtraced.png, "
        "compare.png (radiosity | path traced | error: red where radiosity is brighter).\n";
  write_file_atomic(dir + "summary.md", md.str());
  std::fputs(md.str().c_str(), stdout);
  say(("done; everything is in " + f.out + "/").c_str());
  return kExitOk;
}

}  // namespace

void add_demo_command(CLI::App& app, int& exit_code) {
  auto flags = std::make_shared<DemoFlags>();
  CLI::App* cmd = app.add_subcommand("demo", "Run the main job on the default scene");
  cmd->add_option("--out", flags->out, "Output directory")->capture_default_str();
  cmd->add_option("--scene", flags->scene, "Scene to use instead of the default")->check(CLI::ExistingFile);
  cmd->add_option("--spp", flags->spp, "Samples per pixel of the path-traced reference")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd->callback([flags, &exit_code] { exit_code = run_demo(*flags); });
}

}  // namespace polyrad::cli
