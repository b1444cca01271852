// How many products with T each iterative method needs on a scene, and the error each leaves at
// a fixed budget: the workflow behind `polyrad convergence` and scripts/convergence_chart.py.
// Each scene's reference is GMRES far past the tolerance, checked by its residual.
//
//   ConvergenceOptions o;
//   std::vector<ConvergenceRow> rows = convergence({"scenes/stability/furnace-0.99.json"}, o);
//   std::string csv = convergence_csv(rows);
//
// Throws NumericalError for a scene whose albedo allows no finite solution. Cost: per scene the
// system, the reference solve and each method's iterations up to max_products.
#pragma once

#include <string>
#include <vector>

#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"

namespace polyrad {

struct ConvergenceOptions {
  double tolerance = 1e-3;  // relative error to reach (flux-weighted, against the reference)
  int budget = 50;          // products at which every method's error is measured
  int max_products = 200000;
  SceneOptions scene;
  SceneOverrides overrides;
  SystemOptions system;
};

struct ConvergenceRow {
  std::string scene;  // the file's stem
  double max_albedo = 0.0;
  SolveMethod method = SolveMethod::kJacobi;
  ConvergenceMeasure measure;
};

std::vector<ConvergenceRow> convergence(const std::vector<std::string>& scene_paths,
                                        const ConvergenceOptions& options);
// scene,max_albedo,method,products_to_tolerance,seconds_to_tolerance,error_at_budget,budget,tolerance
std::string convergence_csv(const std::vector<ConvergenceRow>& rows,
                            const ConvergenceOptions& options);

}  // namespace polyrad
