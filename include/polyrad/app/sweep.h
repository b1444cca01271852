// Speed against accuracy: the experiment behind `polyrad sweep` and its charts.
//
// Varies the patch size (and, on a hierarchical mesh, the link tolerance), the series order K,
// its drop tolerance and value precision, the number of Jacobi / Gauss-Seidel sweeps and the
// path tracer's samples per pixel, and for every point
// measures what the image costs and how far it is from two references:
//   - the converged solution of the same discretisation (Gauss-Seidel to a relative residual of
//     1e-9, through the same camera gather): the error the knob itself adds;
//   - a high-sample path-traced image, sharing none of the discretisation: the error a user
//     sees, discretisation included. It is cached in the output folder (app/reference_cache.h).
// Writes DIR/sweep.csv (one row per point, column names with units, empty cells where a column
// does not apply) and DIR/machine.txt (machine, threads, date, scene, reference, load), which
// scripts/charts.py turns into the charts.
//
//   SweepOptions o;
//   o.out = "out/sweep";
//   o.patch_sizes = {100, 50};
//   SweepResult r = sweep("scenes/cornell-box.json", o);
//
// Cost: a radiosity system per patch size, a converged solve, a precompute per (K, drop,
// precision) point, repeats of every product and solve, and the reference (cached).
#pragma once

#include <string>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/render/path_tracer.h"

namespace polyrad {

struct SweepOptions {
  std::string out;  // the folder (made when missing; a file there is an InputError)
  std::vector<double> patch_sizes{100, 50, 25};
  // Hierarchical meshes, one per link tolerance, whose roots are the first patch size's patches
  // (empty: uniform meshes only).
  std::vector<double> link_tolerances;
  std::vector<int> orders{0, 1, 2, 4, 8, 16, 32};
  std::vector<double> drops{0.0, 1e-4, 1e-3, 1e-2};
  std::vector<std::string> precisions{"float", "half"};
  std::vector<int> sweeps{1, 2, 4, 8, 16, 32};
  std::vector<int> spp{1, 4, 16, 64};
  int reference_spp = 1024;
  // Most segments of a path, the reference's and the path-traced points'.
  int max_depth = PathTraceOptions{}.max_depth;
  int repeats = 5;
  GatherOptions gather = GatherOptions::final_gather();  // the gather of every radiosity image
};

struct SweepResult {
  long long points = 0;
  double seconds = 0.0;
  bool reference_reused = false;
};

SweepResult sweep(const std::string& scene_path, const SweepOptions& options);

// Which of the quick preset's knobs the caller chose (those keep the caller's values).
struct SweepChoices {
  bool patch_sizes = false, link_tolerances = false, drops = false, reference_spp = false;
};

// The demo's preset (`sweep --quick`), about two minutes on 2 cores: patch sizes 100, 50, 35, one
// hierarchical mesh at the link tolerance o.gather takes (link_tolerance_for), drops 0 and
// 1e-3, the reference at 512 spp; what `chosen` names is left as it is.
void apply_quick_preset(SweepOptions& o, const SweepChoices& chosen);

}  // namespace polyrad
