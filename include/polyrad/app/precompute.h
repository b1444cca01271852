// The precompute as one library call: the workflow behind `polyrad precompute`. Builds the
// world and its radiosity system with the options given, then the series operator; the
// operator records everything relighting needs to read it back (scene hash, overrides, gather).
//
//   PrecomputeOptions o;
//   o.series.tolerance = 1e-3;
//   o.series.output = SeriesOutput::kSolution;
//   PrecomputeResult r = precompute("scenes/cornell-box.json", o);
//   write_prt(r.op, "out/scene.prt");
//
// Throws InputError (bad scene, options that contradict each other), NumericalError (the
// series diverges). Cost: the system's build plus the precompute (series_precompute.h).
#pragma once

#include <string>

#include "polyrad/app/report.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/transport/system.h"

namespace polyrad {

// The series options of a precompute: the final gather (the library's SeriesOptions default to
// the patch gather, as it has always built).
inline SeriesOptions precompute_series_defaults() {
  SeriesOptions o;
  o.gather = GatherOptions::final_gather();
  return o;
}

struct PrecomputeOptions {
  SceneOptions scene;
  SceneOverrides overrides;
  SystemOptions system;  // a link tolerance left 0: link_tolerance_for(series.gather)
  // Its gather: folded into view rows, or recorded for solution rows.
  SeriesOptions series = precompute_series_defaults();
};

struct PrecomputeResult {
  SeriesOperator op;
  Report report;
};

// Throws InputError before any work when series and system options contradict each other.
void check_series_options(const SeriesOptions& series, const SystemOptions& system);
// The precompute's memory once the system is built, from its real unknowns (patches and links,
// or a hierarchy's leaves and links) and columns, on top of what the run holds already: throws
// InputError with the estimate when it exceeds the budget (max_memory_bytes, or 80 percent of
// RAM), and raises sys.estimated_memory to it when larger.
void require_precompute_memory(const SeriesOptions& series, RadiositySystem& sys,
                               double max_memory_bytes);
PrecomputeResult precompute(const std::string& scene_path, const PrecomputeOptions& options);

}  // namespace polyrad
