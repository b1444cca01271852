// Flags of `polyrad render`, shared by the per-method implementations.
#pragma once

#include <string>

#include "cli_common.h"

namespace polyrad::cli {

struct RenderFlags {
  std::string scene, output, report, patches_csv;
  std::string method = "iterative";  // iterative | series | pathtrace
  // iterative
  std::string solver = "gauss-seidel";
  double tolerance = 1e-4;
  int max_iterations = 10000;
  // series
  int order = -1;  // -1: chosen from --tolerance
  std::string acceleration = "none";
  std::string reorder = "none";
  // path tracer
  int spp = 64;
  std::uint64_t seed = 1;
  // gather and image
  GatherFlags gather;
  double exposure = 1.0;
  SystemFlags system;
};

// One per method; each returns an exit code and writes its outputs only on success.
int render_iterative(const RenderFlags& f);
int render_series(const RenderFlags& f);
int render_pathtrace(const RenderFlags& f);

}  // namespace polyrad::cli
