// The precompute workflow (app/precompute.h).
#include "polyrad/app/precompute.h"

#include <algorithm>

#include "polyrad/transport/memory_estimate.h"
#include "polyrad/util/machine.h"

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

SystemOptions system_for_gather(SystemOptions system, const GatherOptions& gather,
                                const SeriesOptions* series) {
  system.hierarchy.link_tolerance = link_tolerance_for(gather, system.hierarchy.link_tolerance);
  if (system.mesh) return system;
  const bool uniform_rows =
      system.specular_on_the_fly || (series && (series->output == SeriesOutput::kSolution ||
                                                series->reorder == SeriesReorder::kRcm));
  system.mesh = gather.kind == GatherKind::kPatch && !uniform_rows ? MeshKind::kHierarchical
                                                                   : MeshKind::kUniform;
  return system;
}

void require_precompute_memory(const SeriesOptions& series, RadiositySystem& sys,
                               double max_memory_bytes) {
  const World& w = *sys.world;
  const TransportOperator& t = sys.transport;
  const auto columns =
      static_cast<double>(series_columns(w.patches(), w.scene(), series.basis).size());
  const auto unknowns = static_cast<double>(t.size());
  const std::int64_t pixels = static_cast<std::int64_t>(w.camera().width) * w.camera().height;
  const bool view = series.output == SeriesOutput::kView;
  MemoryEstimate m;
  m.patches = static_cast<double>(sys.num_unknown_patches());
  m.visible_pairs = static_cast<double>(sys.form_factors.stats.pairs_visible);
  // What the run holds now, not its peak so far: the build's transient peak is behind it.
  m.base = static_cast<double>(resident_memory_bytes());
  m.camera = rows_memory(series, view ? static_cast<double>(pixels) : unknowns, unknowns, columns) +
             (view ? gather_memory(series.gather, pixels, true) : 0.0);
  if (sys.hierarchy) {
    // Each application of a hierarchical T holds two node-sized blocks (gathered and pulled).
    const double batch =
        std::min(columns, static_cast<double>(series_batch(series, unknowns, columns)));
    m.system = static_cast<double>(sys.hierarchy->op()->nodes()) * 2.0 * 3.0 * 8.0 * batch;
  }
  if (m.total() > sys.estimated_memory.total()) sys.estimated_memory = m;
  require_memory(m, memory_budget(max_memory_bytes), w.scene().file);
}

PrecomputeResult precompute(const std::string& scene_path, const PrecomputeOptions& o) {
  const SystemOptions chosen = system_for_gather(o.system, o.series.gather, &o.series);
  check_series_options(o.series, chosen);
  Stopwatch watch;
  Report rep;
  rep.command = "precompute";
  rep.scene = scene_path;
  rep.overrides = o.overrides;
  Scene scene = load_scene(scene_path, o.scene);
  rep.seconds.push_back({"load", watch.lap()});
  // With the gather's mesh and link tolerance, if none is chosen, and the view rows' share of the
  // memory estimate.
  SystemOptions system = chosen;
  system.camera_bytes = rows_memory(o.series, apply_overrides(scene, o.overrides));
  auto sys = build_system(std::move(scene), o.overrides, system);
  require_precompute_memory(o.series, *sys, o.system.max_memory_bytes);
  SeriesOperator q = precompute_series(sys->transport, *sys->world, o.series);
  rep.system = sys->summary();
  rep.series = q;
  rep.seconds.insert(rep.seconds.end(), sys->times.begin(), sys->times.end());
  if (q.output == SeriesOutput::kView) {
    rep.gather = summarize(q.gather, q.report.gather);
    rep.seconds.push_back({"gather_build", q.report.gather.seconds});
  }
  rep.seconds.push_back({"series", q.report.seconds});
  rep.seconds.push_back({"total", watch.seconds()});
  rep.finish();
  return {std::move(q), std::move(rep)};
}

}  // namespace polyrad
