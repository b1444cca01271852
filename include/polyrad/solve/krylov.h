// GMRES on (I - T) u = e, matrix-free, one colour channel at a time: what `solve` runs for
// SolveMethod::kGmres (solve/solver.h), where the albedo nears 1 and Jacobi would need
// ln(eps) / ln(a) sweeps.
//
//   long long products;  std::string why;
//   bool ok = gmres_solve(t, e, 1e-8, 10000, u, products, why);
//
// Each channel is solved to the relative tolerance in Eigen's 2-norm (restart 50); the caller
// checks the flux-weighted residual, which is what polyrad reports. Cost: `products` products
// with one channel of T; memory 50 vectors of unknowns.
#pragma once

#include <string>

#include "polyrad/transport/transport.h"

namespace polyrad {

// false, with `message`, when a channel did not reach the tolerance within max_products / 3.
bool gmres_solve(const TransportOperator& t, const Field& e, double tolerance, int max_products,
                 Field& u, long long& products, std::string& message);

}  // namespace polyrad
