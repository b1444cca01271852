// Jacobi and Gauss-Seidel on u = e + T u (solver.h).
#include "polyrad/solver.h"

#include <chrono>
#include <cmath>
#include <sstream>

namespace polyrad {

const char* solve_method_name(SolveMethod m) {
  return m == SolveMethod::kJacobi ? "jacobi" : "gauss-seidel";
}

const char* solve_status_name(SolveStatus s) {
  switch (s) {
    case SolveStatus::kConverged: return "converged";
    case SolveStatus::kNotConverged: return "not converged";
    case SolveStatus::kDiverged: return "diverged";
  }
  return "?";
}

double relative_residual(const TransportOperator& t, const Field& e, const Field& u) {
  Field tu;
  t.apply(u, tu);
  Field r = e + tu - u;
  double norm_e = t.flux_norm(e);
  return norm_e > 0.0 ? t.flux_norm(r) / norm_e : t.flux_norm(r);
}

namespace {

// Growth for this many sweeps in a row, beyond the starting residual, means divergence.
constexpr int kGrowthSweeps = 8;

// Returns true (and fills the result) if the residual history shows divergence.
bool diverging(const std::vector<double>& history, const TransportOperator& t, SolveResult& r) {
  double last = history.back();
  std::ostringstream msg;
  if (!std::isfinite(last)) {
    msg << "the iteration produced non-finite values at sweep " << history.size();
  } else {
    int n = static_cast<int>(history.size());
    if (n <= kGrowthSweeps) return false;
    for (int k = n - kGrowthSweeps; k < n; ++k)
      if (!(history[k] > history[k - 1])) return false;
    if (!(last > history.front())) return false;
    double q = std::pow(last / history[n - 1 - kGrowthSweeps], 1.0 / kGrowthSweeps);
    msg << "the iteration diverges: the residual grew by " << q << " per sweep over the last "
        << kGrowthSweeps << " sweeps (spectral radius above 1)";
  }
  if (t.max_albedo() > 1.0)
    msg << "; the largest material albedo bound is " << t.max_albedo() << " > 1";
  r.status = SolveStatus::kDiverged;
  r.message = msg.str();
  return true;
}

}  // namespace

SolveResult solve(const TransportOperator& t, const Field& e, const SolveOptions& options) {
  auto t0 = std::chrono::steady_clock::now();
  SolveResult r;
  r.method = options.method;
  r.u = e;
  const double norm_e = t.flux_norm(e);
  const int max_sweeps = options.fixed_sweeps >= 0 ? options.fixed_sweeps : options.max_iterations;
  if (norm_e == 0.0) {
    r.status = SolveStatus::kConverged;
    r.message = "no emission: the solution is zero";
    return r;
  }
  Field next(e.rows(), 3);
  bool done = options.fixed_sweeps == 0;
  while (!done && r.iterations < max_sweeps) {
    double change;
    if (options.method == SolveMethod::kJacobi) {
      t.apply(r.u, next);
      next += e;
      change = t.flux_norm(next - r.u) / norm_e;  // = ||T^(n+1) e|| / ||e|| from u_0 = e
      r.u.swap(next);
    } else {
      next = r.u;
      t.gauss_seidel_sweep(e, r.u);
      change = t.flux_norm(r.u - next) / norm_e;
    }
    ++r.iterations;
    r.sweep_residual.push_back(change);
    if (diverging(r.sweep_residual, t, r)) {
      r.u = e;  // never hand back the blown-up iterate
      break;
    }
    if (options.fixed_sweeps < 0 && change < options.tolerance) {
      // The change bounds the residual of the previous iterate; confirm on the returned one.
      r.residual = relative_residual(t, e, r.u);
      if (r.residual < options.tolerance) {
        r.status = SolveStatus::kConverged;
        done = true;
      }
    }
  }
  if (r.status != SolveStatus::kDiverged) {
    if (!done || options.fixed_sweeps >= 0) r.residual = relative_residual(t, e, r.u);
    if (options.fixed_sweeps >= 0) {
      r.status = SolveStatus::kConverged;
      r.message = "stopped after the requested " + std::to_string(r.iterations) + " sweeps";
    } else if (!done) {
      std::ostringstream msg;
      msg << "no convergence after " << r.iterations << " sweeps: relative residual "
          << r.residual << " above the tolerance " << options.tolerance;
      r.status = SolveStatus::kNotConverged;
      r.message = msg.str();
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace polyrad
