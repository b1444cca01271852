// Jacobi and Gauss-Seidel on u = e + T u (solver.h).
#include "polyrad/solve/solver.h"

#include <cmath>
#include <memory>
#include <sstream>

#include "polyrad/solve/krylov.h"
#include "polyrad/util/timer.h"

namespace polyrad {

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
  if (t.max_albedo() > 1.0) msg << "; " << t.divergence_hint();
  r.status = SolveStatus::kDiverged;
  r.message = msg.str();
  return true;
}

}  // namespace

namespace {

// GMRES solves (I - T) u = e even when the series behind it diverges, and then returns a
// meaningless u; a few power steps tell whether T's spectral radius exceeds 1 first.
bool spectral_radius_above_one(const TransportOperator& t, const Field& e, double* growth) {
  Field x = e, y;
  double previous = t.flux_norm(x);
  int growing = 0;
  for (int n = 0; n < 40 && previous > 0.0; ++n) {
    t.apply(x, y);
    x.swap(y);
    double norm = t.flux_norm(x);
    *growth = norm / previous;
    growing = *growth > 1.0 ? growing + 1 : 0;
    previous = norm;
    if (growing >= kGrowthSweeps || !std::isfinite(norm)) return true;
  }
  return false;
}

SolveResult solve_gmres(const TransportOperator& t, const Field& e, const SolveOptions& options,
                        const Stopwatch& watch) {
  SolveResult r;
  r.method = SolveMethod::kGmres;
  r.u = e;
  double growth = 0.0;
  if (t.max_albedo() > 1.0 && spectral_radius_above_one(t, e, &growth)) {
    r.status = SolveStatus::kDiverged;
    r.message = "the transport has spectral radius above 1 (its powers grow by " +
                std::to_string(growth) + " per step): no finite solution; " + t.divergence_hint();
    return r;
  }
  // GMRES minimises the 2-norm residual per channel; tighten it until the flux-weighted
  // residual, polyrad's measure, meets the tolerance.
  long long total = 0;
  double inner = options.tolerance;
  for (int attempt = 0; attempt < 6; ++attempt, inner *= 0.1) {
    long long products = 0;
    std::string message;
    bool converged = gmres_solve(t, e, inner, options.max_iterations, r.u, products, message);
    total += products;
    r.residual = relative_residual(t, e, r.u);
    r.sweep_residual.push_back(r.residual);
    r.message = message;
    if (r.residual < options.tolerance) {
      r.status = SolveStatus::kConverged;
      break;
    }
    if (!converged || total >= options.max_iterations) break;
  }
  r.iterations = static_cast<int>(total);
  if (r.status != SolveStatus::kConverged && r.message.empty())
    r.message = "GMRES stopped at relative residual " + std::to_string(r.residual);
  r.seconds = watch.seconds();
  return r;
}

}  // namespace

namespace {

SolveResult solve_chebyshev(const TransportOperator& t, const Field& e, const SolveOptions& options,
                            const Stopwatch& watch) {
  SolveResult r;
  r.method = SolveMethod::kChebyshev;
  r.u = e;
  const double norm_e = t.flux_norm(e);
  if (norm_e == 0.0) {
    r.status = SolveStatus::kConverged;
    return r;
  }
  if (!(t.max_albedo() < 1.0)) {
    r.status = SolveStatus::kDiverged;
    r.message = "Chebyshev iteration needs every albedo below 1; " + t.divergence_hint();
    return r;
  }
  const double rho =
      options.chebyshev_radius > 0.0 ? options.chebyshev_radius : estimate_spectral_radius(t, e);
  ChebyshevIteration<Field> it(t, e, rho);
  const int limit = options.fixed_sweeps >= 0 ? options.fixed_sweeps : options.max_iterations;
  while (r.iterations < limit) {
    double residual = t.flux_norm(it.step()) / norm_e;  // of the iterate before this step
    r.sweep_residual.push_back(residual);
    if (diverging(r.sweep_residual, t, r)) {
      r.message += " (the radius " + std::to_string(rho) + " assumed may be too small)";
      r.u = e;
      return r;
    }
    if (options.fixed_sweeps < 0 && residual < options.tolerance) break;  // the previous x
    ++r.iterations;
  }
  r.u = it.x();
  r.residual = relative_residual(t, e, r.u);
  r.status = options.fixed_sweeps >= 0 || r.residual < options.tolerance
                 ? SolveStatus::kConverged
                 : SolveStatus::kNotConverged;
  if (r.status == SolveStatus::kNotConverged)
    r.message = "Chebyshev iteration reached relative residual " + std::to_string(r.residual);
  r.seconds = watch.seconds();
  return r;
}

}  // namespace

double extrapolated_decay(const std::vector<double>& norms) {
  const size_t n = norms.size();
  auto ratio = [&](size_t k) { return norms[k - 1] > 0.0 ? norms[k] / norms[k - 1] : 0.0; };
  if (n < 2) return 0.0;
  double r2 = ratio(n - 1);
  if (n < 4) return r2;
  double r1 = ratio(n - 2), r0 = ratio(n - 3);
  double curvature = r2 - 2.0 * r1 + r0;
  double aitken = curvature != 0.0 ? r2 - (r2 - r1) * (r2 - r1) / curvature : r2;
  // A rising sequence extrapolates upward; otherwise keep the largest recent ratio.
  double q = std::max({r0, r1, r2});
  if (r2 > r1 && aitken > q && std::isfinite(aitken)) q = aitken;
  return q;
}

double estimate_spectral_radius(const TransportOperator& t, const Field& e, int steps) {
  std::vector<double> norms[3];
  Field x = e, y;
  for (int k = 0; k <= steps; ++k) {
    Eigen::Array3d n = t.flux_norm_channels(x);
    for (int c = 0; c < 3; ++c) norms[c].push_back(n[c]);
    if (k == steps) break;
    t.apply(x, y);
    x.swap(y);
  }
  double rho = 0.0;
  for (const auto& n : norms) rho = std::max(rho, extrapolated_decay(n));
  rho *= 1.02;
  return t.max_albedo() > 0.0 ? std::min(rho, t.max_albedo()) : rho;
}

SolveResult solve_emission(const TransportOperator& t, SolveOptions options) {
  options.start = t.solution_guess();
  return solve(t, t.emission(), options);
}

SolveResult solve(const TransportOperator& t, const Field& e, const SolveOptions& options) {
  const Stopwatch watch;
  if (options.method == SolveMethod::kGmres) return solve_gmres(t, e, options, watch);
  if (options.method == SolveMethod::kChebyshev) return solve_chebyshev(t, e, options, watch);
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
  if (options.method == SolveMethod::kGaussSeidel && options.fixed_sweeps < 0 && options.start &&
      options.start->rows() == e.rows())
    r.u = *options.start;
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
      msg << "no convergence after " << r.iterations << " sweeps: relative residual " << r.residual
          << " above the tolerance " << options.tolerance;
      r.status = SolveStatus::kNotConverged;
      r.message = msg.str();
    }
  }
  r.seconds = watch.seconds();
  return r;
}

}  // namespace polyrad

namespace polyrad {

namespace {

double relative_error(const TransportOperator& t, const Field& u, const Field& reference) {
  return t.flux_norm(u - reference) / t.flux_norm(reference);
}

}  // namespace

ConvergenceMeasure measure_convergence(const TransportOperator& t, const Field& e,
                                       const Field& reference, SolveMethod method, double tolerance,
                                       int budget, long long max_products) {
  ConvergenceMeasure m;
  const Stopwatch watch;
  auto elapsed = [&] { return watch.seconds(); };
  if (method == SolveMethod::kGmres) {
    for (double inner = 1e-1; inner >= 1e-14 && m.products < 0; inner *= 0.1) {
      SolveOptions o;
      o.method = method;
      o.tolerance = inner;
      o.max_iterations = static_cast<int>(std::min<long long>(max_products, 1 << 30));
      SolveResult r = solve(t, e, o);
      if (relative_error(t, r.u, reference) <= tolerance) {
        m.products = r.iterations;
        m.seconds = elapsed();
      }
    }
    SolveOptions o;
    o.method = method;
    o.tolerance = 1e-300;  // stop on the budget only
    o.max_iterations = budget;
    m.error_at_budget = relative_error(t, solve(t, e, o).u, reference);
    return m;
  }
  // Stationary methods and Chebyshev: one product a step, followed as they go.
  const int overhead = method == SolveMethod::kChebyshev ? 12 : 0;  // the radius estimate's steps
  std::unique_ptr<ChebyshevIteration<Field>> cheb;
  if (method == SolveMethod::kChebyshev)
    cheb =
        std::make_unique<ChebyshevIteration<Field>>(t, e, estimate_spectral_radius(t, e, overhead));
  Field u = e, next;
  if (budget <= overhead) m.error_at_budget = relative_error(t, e, reference);
  for (long long n = 1; n + overhead <= max_products; ++n) {
    if (cheb) {
      cheb->step();
      u = cheb->x();
    } else if (method == SolveMethod::kGaussSeidel) {
      t.gauss_seidel_sweep(e, u);
    } else {
      t.apply(u, next);
      u = e + next;
    }
    double err = relative_error(t, u, reference);
    if (n + overhead == budget) m.error_at_budget = err;
    if (m.products < 0 && err <= tolerance) {
      m.products = n + overhead;
      m.seconds = elapsed();
    }
    if ((m.products >= 0 && n + overhead >= budget) || !std::isfinite(err)) break;
  }
  return m;
}

}  // namespace polyrad
