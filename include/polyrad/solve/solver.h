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

#include "polyrad/transport/transport.h"
#include "polyrad/util/enum_names.h"

namespace polyrad {

// GMRES (Krylov, restarted, matrix-free per channel) and Chebyshev iteration degrade gracefully
// as the albedo nears 1, where Jacobi needs ln(eps) / ln(a) sweeps; `iterations` counts products
// with T. Chebyshev is a fixed polynomial in T (the one the accelerated series stores).
enum class SolveMethod { kJacobi, kGaussSeidel, kGmres, kChebyshev };
enum class SolveStatus { kConverged, kNotConverged, kDiverged };
template <>
struct EnumNames<SolveMethod> {
  static constexpr const char* kind = "solver";
  static constexpr std::array<std::pair<SolveMethod, const char*>, 4> table{
      {{SolveMethod::kJacobi, "jacobi"},
       {SolveMethod::kGaussSeidel, "gauss-seidel"},
       {SolveMethod::kGmres, "gmres"},
       {SolveMethod::kChebyshev, "chebyshev"}}};
};
template <>
struct EnumNames<SolveStatus> {
  static constexpr const char* kind = "solve status";
  static constexpr std::array<std::pair<SolveStatus, const char*>, 3> table{
      {{SolveStatus::kConverged, "converged"},
       {SolveStatus::kNotConverged, "not converged"},
       {SolveStatus::kDiverged, "diverged"}}};
};

struct SolveOptions {
  SolveMethod method = SolveMethod::kGaussSeidel;
  double tolerance = 1e-4;  // relative residual
  int max_iterations = 10000;
  // Fixed number of sweeps instead of a tolerance (Jacobi: the order-K power series).
  int fixed_sweeps = -1;
  // Chebyshev: the spectral radius bound rho; 0 estimates it (estimate_spectral_radius).
  double chebyshev_radius = 0.0;
  // Gauss-Seidel's first iterate instead of e, when it has e's rows and e is not zero: the same
  // fixed point, in fewer sweeps from a good guess (TransportOperator::solution_guess). Fixed
  // sweeps and the other methods start from e (Jacobi's sweeps are the power series of e).
  const Field* start = nullptr;
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

// The scene's own emission, t.emission(), from the build's guess where it left one
// (TransportOperator::solution_guess: a hierarchy's last solve between passes); any start in
// `options` is replaced by it.
SolveResult solve_emission(const TransportOperator& t, SolveOptions options = {});

// The relative residual ||e + T u - u|| / ||e|| of any u.
double relative_residual(const TransportOperator& t, const Field& e, const Field& u);

// How a method approaches a known solution: the products with T it needs to bring the relative
// error ||u - reference|| / ||reference|| (flux-weighted) to `tolerance`, and the error it has
// after `budget` products. Jacobi (= the power series), Gauss-Seidel and Chebyshev are followed
// sweep by sweep; GMRES is rerun with tighter inner tolerances. products < 0: not reached
// within max_products.
struct ConvergenceMeasure {
  long long products = -1;
  double seconds = 0.0;
  double error_at_budget = 0.0;
};
ConvergenceMeasure measure_convergence(const TransportOperator& t, const Field& e,
                                       const Field& reference, SolveMethod method, double tolerance,
                                       int budget, long long max_products);

// The decay rate of a sequence of term norms ||T^n e||: the last ratio of successive norms,
// extrapolated by Aitken's delta-squared when the ratios rise (as they do, toward the spectral
// radius, for a non-negative operator; the plain last ratio underestimates it).
double extrapolated_decay(const std::vector<double>& norms);

// T's spectral radius from `steps` power steps on e: the ratio of successive flux norms,
// extrapolated (Aitken) as it rises toward the radius, worst channel, times a 2 percent margin,
// capped by a_max (which bounds it).
double estimate_spectral_radius(const TransportOperator& t, const Field& e, int steps = 12);

// The Chebyshev semi-iteration for x = e + T x with T's spectrum in [-rho, rho] (Golub and
// Varga): x_0 = e, x_1 = e + T x_0, x_{k+1} = w_{k+1} (e + T x_k - x_{k-1}) + x_{k-1} with
// w_2 = 1 / (1 - rho^2 / 2), w_{k+1} = 1 / (1 - rho^2 w_k / 4). x_k is a degree-k polynomial
// in T applied to e, linear in e, and converges like (rho / (1 + sqrt(1 - rho^2)))^k where the
// power series converges like rho^k. F is a Field or a FieldBlock; Op is T, or anything with
// T's apply(const F&, F&) (the series precompute's PermutedTransport).
//
//   ChebyshevIteration<Field> it(t, e, rho);
//   for (int k = 0; k < K; ++k) it.step();     // it.x() = x_K
template <typename F, typename Op = TransportOperator>
class ChebyshevIteration {
 public:
  ChebyshevIteration(const Op& t, const F& e, double rho) : t_(t), e_(e), rho2_(rho * rho), x_(e) {}
  // Advances x by one product with T; returns the residual e + T x - x of the x it started from
  // (computed on the way).
  const F& step() {
    t_.apply(x_, tx_);
    residual_ = e_ + tx_ - x_;
    if (k_ == 0) {
      previous_ = x_;
      x_ = e_ + tx_;
    } else {
      w_ = k_ == 1 ? 1.0 / (1.0 - 0.5 * rho2_) : 1.0 / (1.0 - 0.25 * rho2_ * w_);
      F next = w_ * (e_ + tx_ - previous_) + previous_;
      previous_.swap(x_);
      x_.swap(next);
    }
    ++k_;
    return residual_;
  }
  const F& x() const { return x_; }

 private:
  const Op& t_;
  const F& e_;
  double rho2_;
  double w_ = 1.0;
  int k_ = 0;
  F x_, previous_, tx_, residual_;
};

}  // namespace polyrad
