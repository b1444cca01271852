// Rendering a scene by any method (app/render.h).
#include "polyrad/app/render.h"

#include <cmath>

#include "polyrad/app/precompute.h"
#include "polyrad/util/stats.h"

namespace polyrad {

namespace {

// The scene, timed as "load", and the world built from it (its mesh and ray caster times).
std::shared_ptr<const World> load_world(const std::string& path, const RenderOptions& o,
                                        Report& report) {
  Stopwatch watch;
  Scene scene = load_scene(path, o.scene);
  report.seconds.push_back({"load", watch.seconds()});
  auto world = World::build(std::move(scene), o.overrides);
  report.scene = path;
  report.overrides = o.overrides;
  return world;
}

void render_iterative(RenderResult& r, const RenderOptions& o) {
  r.system = build_system(r.world, o.system);
  const TransportOperator& t = r.system->transport;
  SolveResult solution = solve(t, t.emission(), o.solve);
  if (solution.status == SolveStatus::kDiverged || !solution.u.allFinite())
    throw NumericalError(solution.message.empty() ? "the solution is not finite"
                                                  : solution.message);
  if (solution.status == SolveStatus::kNotConverged) throw NumericalError(solution.message);
  // A final gather's rows are built block by block where they are applied, never held whole.
  const Gather gather = o.gather.kind == GatherKind::kFinal
                            ? defer_gather(*r.world, r.world->camera(), t.layout(), o.gather)
                            : build_gather(*r.world, t.layout(), o.gather);
  Stopwatch watch;
  GatherWork work;
  r.image = gather_image(gather, solution.u, *r.world, &work);
  const double apply_seconds = watch.seconds() - work.seconds;

  Report& rep = r.report;
  rep.system = r.system->summary();
  rep.seconds.insert(rep.seconds.end(), r.system->times.begin(), r.system->times.end());
  rep.seconds.push_back({"solve", solution.seconds});
  rep.seconds.push_back({"gather_build", gather.seconds + work.seconds});
  rep.seconds.push_back({"gather_apply", apply_seconds});
  rep.gather = summarize(gather, work);
  r.u = std::move(solution.u);
  solution.u.resize(0, 3);
  rep.solve = std::move(solution);
}

void render_series(RenderResult& r, const RenderOptions& o) {
  check_series_options(o.series, o.system);
  auto sys = build_system(r.world, o.system);
  SeriesOptions so = o.series;
  so.output = SeriesOutput::kView;
  so.gather = o.gather;
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
  rep.seconds.push_back({"gather_build", q.report.gather_seconds});
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
  r.world = load_world(scene_path, o, r.report);
  switch (o.method) {
    case RenderMethod::kIterative:
      render_iterative(r, o);
      break;
    case RenderMethod::kSeries:
      render_series(r, o);
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
