// The main job on one scene, end to end (app/demo.h).
#include "polyrad/app/demo.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "polyrad/app/render.h"
#include "polyrad/io/image_codec.h"
#include "polyrad/io/image_io.h"
#include "polyrad/io/prt_file.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/files.h"
#include "polyrad/util/machine.h"
#include "polyrad/util/stats.h"

namespace polyrad {

namespace {

void say(const char* what) { std::fprintf(stderr, "polyrad demo: %s\n", what); }

}  // namespace

DemoResult demo(const DemoOptions& f) {
  if (f.scene.empty()) throw InputError("the demo needs a scene");
  make_directories(f.out);
  const std::string dir = f.out + "/";
  Stopwatch watch;

  say("building the glossy radiosity system (form factors, specular transfer, operator)");
  auto loaded = World::load(f.scene);
  // The final gather is stored (the iterative image and the precompute's view rows both read
  // it), beside the view rows, and the codec of its PNGs: the camera's share of the memory
  // estimate.
  const Camera& camera = loaded->camera();
  SystemOptions system;
  const auto pixels = static_cast<std::int64_t>(camera.width) * camera.height;
  system.camera_bytes = gather_memory(GatherOptions::final_gather(), pixels, false) +
                        rows_memory(SeriesOptions{}, loaded->scene()) +
                        image_codec_memory(static_cast<double>(pixels));
  auto sys = build_system(std::move(loaded), system);
  const World& world = *sys->world;
  const auto& t = sys->transport;
  const GatherOptions gather_options = GatherOptions::final_gather();
  const Gather gather = build_gather(world, t.layout(), gather_options,
                                     mesh_direct_for(gather_options, t, world).get());

  say("solving iteratively (Gauss-Seidel to a relative residual of 1e-4)");
  SolveResult solution = solve_emission(t);
  if (!solution.ok()) throw NumericalError(solution.message);
  Stopwatch gather_watch;
  const Image radiosity = gather_image(gather, solution.u, world);
  const double iterative_seconds = solution.seconds + gather_watch.seconds();
  write_image(radiosity, dir + "radiosity.exr");
  write_image(radiosity, dir + "radiosity.png");

  say("precomputing the truncated power series (tolerance 1e-3, view rows)");
  SeriesOptions so;
  so.tolerance = 1e-3;
  const SeriesOperator q = precompute_series(t, world, so, &gather);
  write_prt(q, dir + "scene.prt");

  say("relighting: one sparse product per new light");
  std::vector<float> out(3 * static_cast<std::size_t>(q.rows()));
  struct Relight {
    const char* file;
    const char* what;
    Rgb emission;
    double seconds;
  };
  std::vector<Relight> relights = {
      {"relit-as-scene", "the scene's light", q.columns[0].emission, 0},
      {"relit-double", "twice as bright", 2.0 * q.columns[0].emission, 0},
      {"relit-blue", "a cold blue light", Rgb(4, 12, 17), 0}};
  const std::string light = q.columns[0].object;
  for (auto& r : relights) {
    std::vector<float> e = q.column_emission({{light, r.emission}});
    r.seconds = time_repeats(f.repeats, [&] { q.apply(e.data(), out.data()); }).median;
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
  const PathTracer tracer(world);
  PathTraceOptions po;
  po.spp = f.spp;
  const PathTraceResult traced = tracer.render(world.camera(), po);
  write_image(traced.image, dir + "pathtraced.exr");
  write_image(traced.image, dir + "pathtraced.png");
  const RegionMap regions = object_regions(world);
  ImageComparison vs_reference = compare_images(radiosity, traced.image, {}, &regions);
  Image error = error_picture(radiosity, traced.image, 0.25, 0.01);
  write_image(side_by_side(radiosity, traced.image, error, 1.0, 4), dir + "compare.png");

  // report.json and summary.md.
  const double product = relights[0].seconds;
  DemoResult result;
  Report& rep = result.report;
  rep.command = "demo";
  rep.scene = f.scene;
  rep.system = sys->summary();
  rep.solve = solution;
  rep.solve->u.resize(0, 3);
  rep.gather = summarize(gather);
  rep.series = q;
  rep.pathtrace = summarize(traced, po);
  rep.comparison = vs_reference;  // radiosity against the path tracer
  rep.figures = {{"product_seconds_median", product},
                 {"iterative_image_seconds", iterative_seconds},
                 {"speedup_over_iterative", iterative_seconds / product},
                 {"series_relative_l1_vs_iterative", series_vs_iterative.relative_l1}};
  rep.seconds = sys->times;
  rep.seconds.push_back({"solve", solution.seconds});
  rep.seconds.push_back({"gather_build", gather.seconds});
  rep.seconds.push_back({"series_precompute", q.report.seconds});
  rep.seconds.push_back({"product_median", product});
  rep.seconds.push_back({"iterative_image", iterative_seconds});
  rep.seconds.push_back({"path_trace", traced.seconds});
  rep.seconds.push_back({"total", watch.seconds()});
  rep.finish();
  write_file_atomic(dir + "report.json", to_json(rep));

  std::ostringstream md;
  md.precision(3);
  md << "# polyrad demo: " << world.scene().file << "\n\n"
     << "Machine: " << machine_description() << "\n\n"
     << "| | |\n|---|---|\n"
     << "| patches / unknowns (B + specular links) | " << world.patches().size() << " / "
     << t.size() << " |\n"
     << "| operator T | " << t.nnz_diffuse() << " diffuse + " << t.nnz_specular()
     << " specular non-zeros, " << t.bytes() / 1e6 << " MB |\n"
     << "| form factors + specular transfer | " << sys->seconds("form_factors") << " s + "
     << sys->seconds("specular_transfer") << " s |\n"
     << "| iterative solve + gather (" << solution.iterations << " Gauss-Seidel sweeps) | "
     << iterative_seconds * 1e3 << " ms |\n"
     << "| series precompute (order " << q.report.order << ", view rows) | " << q.report.seconds
     << " s, " << q.bytes() / 1e6 << " MB |\n"
     << "| relight: one product (median of " << f.repeats << ") | " << product * 1e3 << " ms, "
     << iterative_seconds / product << "x faster than the iterative solve |\n"
     << "| series image vs iterative image | relative L1 " << series_vs_iterative.relative_l1
     << " |\n"
     << "| radiosity vs path tracer (" << f.spp << " spp) | relative RMSE "
     << vs_reference.relative_rmse << ", mean relative error " << vs_reference.mean_relative_error
     << " |\n\n"
     << "Region means, radiosity against the path tracer:\n\n| region | difference |\n|---|---|\n";
  for (const auto& r : vs_reference.regions)
    md << "| " << r.name << " | " << 100.0 * r.luminance_difference << " % |\n";
  md << "\nImages: radiosity.png (iterative), relit-*.png (one product each), pathtraced.png, "
        "compare.png (radiosity | path traced | error: red where radiosity is brighter).\n";
  write_file_atomic(dir + "summary.md", md.str());
  say(("done; everything is in " + f.out + "/").c_str());
  result.summary = md.str();
  return result;
}

}  // namespace polyrad
