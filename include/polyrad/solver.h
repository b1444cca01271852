// The plain iterative solver of u = e + T u: the reference every faster method is tested
// against.
//
// Jacobi: u_{n+1} = e + T u_n. Started from u_0 = e, its K-th iterate is exactly the order-K
// truncated power series sum_{n<=K} T^n e (papers/glossy-radiosity.md, section 5), which is
// what ties it to the precomputed polynomial. Gauss-Seidel updates rows in place and needs
// fewer sweeps. Both stop when the relative residual ||e + T u - u|| / ||e|| (flux-weighted
// 1-norm) falls below the tolerance, and return a status in the manner of Eigen's info():
// divergence and non-convergence are statuses with a message, never NaN in the answer.
//
//   SolveResult r = solve(t, t.emission(), {.method = SolveMethod::kGaussSeidel});
//   if (r.status != SolveStatus::kConverged) report(r.message);
//
// Cost: one pass over T per sweep (apply() for Jacobi, in-place rows for Gauss-Seidel).
#pragma once

#include <string>
#include <vector>

#include "polyrad/transport.h"

namespace polyrad {

enum class SolveMethod { kJacobi, kGaussSeidel };
enum class SolveStatus { kConverged, kNotConverged, kDiverged };
const char* solve_method_name(SolveMethod m);
const char* solve_status_name(SolveStatus s);

struct SolveOptions {
  SolveMethod method = SolveMethod::kGaussSeidel;
  double tolerance = 1e-4;  // relative residual
  int max_iterations = 10000;
  // Fixed number of sweeps instead of a tolerance (Jacobi: the order-K power series).
  int fixed_sweeps = -1;
};

struct SolveResult {
  SolveStatus status = SolveStatus::kNotConverged;
  SolveMethod method = SolveMethod::kGaussSeidel;
  int iterations = 0;
  double residual = 0.0;               // relative, of the returned u
  std::vector<double> sweep_residual;  // relative residual (Jacobi: ||T^n e|| / ||e||) per sweep
  double seconds = 0.0;
  std::string message;
  Field u;
  bool ok() const { return status == SolveStatus::kConverged; }
};

SolveResult solve(const TransportOperator& t, const Field& e, const SolveOptions& options = {});

// The relative residual ||e + T u - u|| / ||e|| of any u.
double relative_residual(const TransportOperator& t, const Field& e, const Field& u);

}  // namespace polyrad
