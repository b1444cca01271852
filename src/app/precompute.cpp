// The precompute workflow (app/precompute.h).
#include "polyrad/app/precompute.h"

namespace polyrad {

void check_series_options(const SeriesOptions& series, const SystemOptions& system) {
  // --reorder rcm renumbers T's stored link rows, and on the fly there are none: refused before
  // the system is built rather than after.
  if (series.reorder == SeriesReorder::kRcm && system.specular_on_the_fly)
    throw InputError(
        "--reorder rcm renumbers T's stored rows; --specular-on-the-fly stores none "
        "(use --reorder none)");
  if (series.reorder == SeriesReorder::kRcm && system.mesh == MeshKind::kHierarchical)
    throw InputError(
        "--reorder rcm renumbers T's stored rows; a hierarchical mesh keeps T "
        "factored in its trees and links (use --reorder none)");
  if (series.output == SeriesOutput::kSolution && system.mesh == MeshKind::kHierarchical)
    throw InputError(
        "a hierarchical mesh's solution rows are its leaves, which relight cannot "
        "rebuild from the scene; use --output view (or --mesh uniform)");
}

PrecomputeResult precompute(const std::string& scene_path, const PrecomputeOptions& o) {
  check_series_options(o.series, o.system);
  Stopwatch watch;
  Report rep;
  rep.command = "precompute";
  rep.scene = scene_path;
  rep.overrides = o.overrides;
  Scene scene = load_scene(scene_path, o.scene);
  rep.seconds.push_back({"load", watch.lap()});
  SystemOptions system = o.system;  // with the view rows' share of the memory estimate
  system.camera_bytes = rows_memory(o.series, apply_overrides(scene, o.overrides));
  auto sys = build_system(std::move(scene), o.overrides, system);
  SeriesOperator q = precompute_series(sys->transport, *sys->world, o.series);
  rep.system = sys->summary();
  rep.series = q;
  rep.seconds.insert(rep.seconds.end(), sys->times.begin(), sys->times.end());
  if (q.output == SeriesOutput::kView)
    rep.seconds.push_back({"gather_build", q.report.gather_seconds});
  rep.seconds.push_back({"series", q.report.seconds});
  rep.seconds.push_back({"total", watch.seconds()});
  rep.finish();
  return {std::move(q), std::move(rep)};
}

}  // namespace polyrad
