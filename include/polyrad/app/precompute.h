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
  SystemOptions system;  // a mesh left unset, a link tolerance left 0: system_for_gather
  // Its gather: folded into view rows, or recorded for solution rows.
  SeriesOptions series = precompute_series_defaults();
};

struct PrecomputeResult {
  SeriesOperator op;
  Report report;
};

// Throws InputError before any work when series and system options contradict each other.
void check_series_options(const SeriesOptions& series, const SystemOptions& system);

// The system that `render` and `precompute` build behind `gather`, with what the caller left
// unset chosen for that gather: the link tolerance (link_tolerance_for) and the mesh. Where the
// pixels read the mesh (the patch gather) it decides the image, and the hierarchical mesh gives
// 0.26 to 0.59 of the uniform mesh's relative RMSE on the same patches (cornell-box 0.097
// against 0.352; the room 0.096 against 0.163), less than a uniform mesh of half the patch size
// in less time (README, "The mesh follows the gather"). Behind the final gather the mesh carries
// only the light one bounce away, and on a room-sized scene the uniform mesh reaches the same
// error in less time: uniform there. Uniform also where a series needs the uniform mesh's rows
// (solution rows, the RCM order) or the system builds its rows on the fly.
SystemOptions system_for_gather(SystemOptions system, const GatherOptions& gather,
                                const SeriesOptions* series = nullptr);

// The precompute's memory once the system is built, from its real unknowns (patches and links,
// or a hierarchy's leaves and links) and columns, on top of what the run holds already: throws
// InputError with the estimate when it exceeds the budget (max_memory_bytes, or 80 percent of
// RAM), and raises sys.estimated_memory to it when larger.
void require_precompute_memory(const SeriesOptions& series, RadiositySystem& sys,
                               double max_memory_bytes);
PrecomputeResult precompute(const std::string& scene_path, const PrecomputeOptions& options);

}  // namespace polyrad
