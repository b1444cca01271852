// Rendering a scene by any method (app/render.h).
#include "polyrad/app/render.h"

#include <cmath>

#include "polyrad/app/precompute.h"
#include "polyrad/io/image_codec.h"
#include "polyrad/transport/memory_estimate.h"
#include "polyrad/util/stats.h"

namespace polyrad {

namespace {

// The series a render folds: view rows behind the render's own gather.
SeriesOptions render_series_options(const RenderOptions& o) {
  SeriesOptions so = o.series;
  so.output = SeriesOutput::kView;
  so.gather = o.gather;
  return so;
}

// The camera's share of the memory estimate (transport/memory_estimate.h): the gather, or the
// view rows and their deferred gather, or the path tracer's image and its error buffers; and
// the codec of the image a render is for (io/image_codec.h), loaded while all this is held,
// where the image needs it (a .pfm does not: 110 MiB of a 70 MiB render counted otherwise).
double camera_memory(const RenderOptions& o, const Scene& scene) {
  const std::int64_t pixels = static_cast<std::int64_t>(scene.camera.width) * scene.camera.height;
  double bytes = 48.0 * static_cast<double>(pixels);  // the path tracer's image and buffers
  if (o.method == RenderMethod::kIterative) {
    bytes = gather_memory(o.gather, pixels, o.gather.kind == GatherKind::kFinal);
  } else if (o.method == RenderMethod::kSeries) {
    bytes = rows_memory(render_series_options(o), scene);
  }
  return (o.image_codec ? image_codec_memory(static_cast<double>(pixels)) : 0.0) + bytes;
}

// The scene, timed as "load", and the world built from it (its mesh and ray caster times). The
// memory estimate is checked before the mesh is made (a tiny patch size or a huge image is
// refused at once), and `system` gets the camera's share for build_system's own check.
std::shared_ptr<const World> load_world(const std::string& path, const RenderOptions& o,
                                        SystemOptions& system, Report& report) {
  Stopwatch watch;
  Scene scene = load_scene(path, o.scene);
  report.seconds.push_back({"load", watch.seconds()});
  const Scene as_run = apply_overrides(scene, o.overrides);
  system.camera_bytes = camera_memory(o, as_run);
  MemoryEstimate need = estimate_memory(as_run, system);
  if (o.method == RenderMethod::kPathTrace) need.system = 0.0;
  require_memory_before_meshing(need, memory_budget(system.max_memory_bytes), scene.file);
  auto world = World::build(std::move(scene), o.overrides);
  report.scene = path;
  report.overrides = o.overrides;
  return world;
}

void render_iterative(RenderResult& r, const RenderOptions& o, const SystemOptions& system) {
  r.system = build_system(r.world, system);
  const TransportOperator& t = r.system->transport;
  SolveResult solution = solve_emission(t, o.solve);
  if (solution.status == SolveStatus::kDiverged || !solution.u.allFinite())
    throw NumericalError(solution.message.empty() ? "the solution is not finite"
                                                  : solution.message);
  if (solution.status == SolveStatus::kNotConverged) throw NumericalError(solution.message);
  // A final gather's rows are built block by block where they are applied, never held whole.
  Stopwatch direct_watch;
  const auto direct = mesh_direct_for(o.gather, t, *r.world);
  const double direct_seconds = direct_watch.seconds();
  const Gather gather =
      o.gather.kind == GatherKind::kFinal
          ? defer_gather(*r.world, r.world->camera(), t.layout(), o.gather, direct)
          : build_gather(*r.world, t.layout(), o.gather);
  Stopwatch watch;
  GatherWork work;
  r.image = gather_image(gather, solution.u, *r.world, &work);
  const double apply_seconds = watch.seconds() - work.seconds;

  Report& rep = r.report;
  rep.system = r.system->summary();
  rep.seconds.insert(rep.seconds.end(), r.system->times.begin(), r.system->times.end());
  rep.seconds.push_back({"solve", solution.seconds});
  if (direct) rep.seconds.push_back({"mesh_direct", direct_seconds});
  rep.seconds.push_back({"gather_build", gather.seconds + work.seconds});
  rep.seconds.push_back({"gather_apply", apply_seconds});
  rep.gather = summarize(gather, work);
  r.u = std::move(solution.u);
  solution.u.resize(0, 3);
  rep.solve = std::move(solution);
}

void render_series(RenderResult& r, const SeriesOptions& so, const SystemOptions& system) {
  auto sys = build_system(r.world, system);
  require_precompute_memory(so, *sys, system.max_memory_bytes);
  const SeriesOperator q = precompute_series(sys->transport, *r.world, so);
  const std::vector<float> e = q.column_emission();
  std::vector<float> out(3 * static_cast<std::size_t>(q.rows()));
  const double product_seconds = time_seconds([&] { q.apply(e.data(), out.data()); });
  r.image = series_image(q, out);
  if (!r.image.all_finite()) throw NumericalError("the image has non-finite pixels");

  Report& rep = r.report;
  rep.system = sys->summary();
  rep.series = q;
  rep.seconds.insert(rep.seconds.end(), sys->times.begin(), sys->times.end());
  rep.gather = summarize(q.gather, q.report.gather);
  rep.seconds.push_back({"gather_build", q.report.gather.seconds});
  rep.seconds.push_back({"series", q.report.seconds});
  rep.seconds.push_back({"product", product_seconds});
}

void render_pathtrace(RenderResult& r, const RenderOptions& o) {
  const PathTracer tracer(*r.world);
  PathTraceOptions po = o.pathtrace;
  po.standard_error = true;
  const PathTraceResult traced = tracer.render(r.world->camera(), po);
  if (!traced.image.all_finite())
    throw NumericalError("the path-traced image has non-finite pixels");
  r.image = traced.image;

  Report& rep = r.report;
  rep.seconds.insert(rep.seconds.end(), r.world->times().begin(), r.world->times().end());
  rep.seconds.push_back({"path_tracing", traced.seconds});
  rep.pathtrace = summarize(traced, po);
}

}  // namespace

Image gather_image(const Gather& gather, const Field& u, const World& world, GatherWork* work) {
  Image image = apply_gather(gather, u, scene_emission(world.patches()), work);
  if (!image.all_finite()) throw NumericalError("the image has non-finite pixels");
  return image;
}

RenderResult render(const std::string& scene_path, const RenderOptions& o) {
  Stopwatch watch;
  RenderResult r;
  r.report.command = "render";
  r.report.method = enum_name(o.method);
  const SeriesOptions series = render_series_options(o);
  const bool folds = o.method == RenderMethod::kSeries;
  SystemOptions system = system_for_gather(o.system, o.gather, folds ? &series : nullptr);
  if (folds) check_series_options(series, system);
  r.world = load_world(scene_path, o, system, r.report);
  switch (o.method) {
    case RenderMethod::kIterative:
      render_iterative(r, o, system);
      break;
    case RenderMethod::kSeries:
      render_series(r, series, system);
      break;
    case RenderMethod::kPathTrace:
      render_pathtrace(r, o);
      break;
  }
  r.report.seconds.push_back({"total", watch.seconds()});
  r.report.finish();
  return r;
}

}  // namespace polyrad
