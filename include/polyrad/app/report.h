// The one report every workflow returns (app/render.h, precompute.h, relight.h, compare.h, ...):
// what ran, on what, the figures of each part that ran, the seconds of each stage, the peak
// memory and the machine. Parts that did not run stay empty and are not written. to_json() is
// what `--report R.json` writes, for every subcommand alike.
//
//   RenderResult r = render(options);
//   write_file_atomic("r.json", to_json(r.report));
//   double solve_s = stage_seconds(r.report.seconds, "solve");
//
// Cost: a copy of each part's figures (no fields, no images, no operator values).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/solve/series_operator.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/stats.h"
#include "polyrad/util/timer.h"

namespace polyrad {

// The camera gather that made an image: its options and what building it cost.
struct GatherSummary {
  GatherOptions options;
  long long rays = 0, nnz = 0;
  std::size_t bytes = 0;
  double seconds = 0.0;
  MirrorChainCount mirror_chains;
};
// Why light through facing mirrors stays on the links where the chain budget cut the chains
// short (at 1 percent of the hits that face such mirrors or more), or "": on a room of four
// mirror walls the default budget keeps chains of up to 6 walls, its floor 0.8 percent dark.
std::string describe_chain_cut(const GatherSummary& g);
// work: what reading a deferred gather cost (its rows are built where they are read).
GatherSummary summarize(const Gather& g, const GatherWork& work = {});
// The gather behind a view operator's rows (SeriesReport::gather).
GatherSummary summarize(const GatherOptions& options, const GatherWork& cost);

// A path-traced image: the options that matter for reproducing it and what it cost.
struct PathTraceSummary {
  int width = 0, height = 0, spp = 0, max_depth = 0;
  std::uint64_t seed = 0;
  PathStats stats;
  double seconds = 0.0;
  // Mean over pixels with signal of the standard error over the radiance (NaN if not known):
  // the noise left in a reference.
  double mean_relative_standard_error = 0.0;
};
// The summary of a path-traced image made with options o (its error image, when it has one,
// gives the mean relative standard error).
PathTraceSummary summarize(const PathTraceResult& r, const PathTraceOptions& o);
// Why the image is biased dark where paths were cut at max_depth still carrying light (one path
// in 10,000 or more), or "" where too few were: the light they would still have gathered is
// missing (facing mirrors of albedo 0.99: a tenth of the paths cut at 64 segments, the image
// 10.7 percent dark against 4096).
std::string describe_truncation(const PathTraceSummary& p);
// Mean over pixels with signal of standard error / radiance (luminance), NaN without an error
// image: the noise left in a path-traced reference.
double mean_relative_standard_error(const PathTraceResult& r);

// Products that relit an operator.
struct RelightSummary {
  std::map<std::string, Rgb> emission;  // the lights set, as given (others kept the scene's)
  RepeatTimes product;                  // seconds of the product, over repeats
  std::size_t bytes_touched = 0;        // Q, e and the output, once
  double gather_seconds = 0.0;          // solution rows: the gather that made the image
};

struct Report {
  std::string command;  // render, precompute, relight, compare, demo, ...
  std::string method;   // render: iterative, series or pathtrace
  std::string scene;    // the scene file
  std::vector<std::pair<std::string, std::string>> inputs;  // other files read, by role
  std::optional<SceneOverrides> overrides;
  std::optional<SystemSummary> system;
  std::optional<SolveResult> solve;  // its field u left empty
  std::optional<GatherSummary> gather;
  std::optional<SeriesMetadata> series;
  std::optional<PathTraceSummary> pathtrace;
  std::optional<RelightSummary> relight;
  std::optional<ImageComparison> comparison;
  // Warnings a workflow finds beside those its parts describe (kind, message), as the others
  // printed on stderr and written in the report's `warnings`.
  std::vector<std::pair<std::string, std::string>> warnings;
  // Named figures a workflow derives (a speed-up, an error between two of its images).
  std::vector<std::pair<std::string, double>> figures;
  StageTimes seconds;
  std::size_t peak_memory_bytes = 0;
  std::string machine;

  // Sets the peak memory and the machine: call when the work is done.
  void finish();
};

std::string to_json(const Report& report);

}  // namespace polyrad
