#include "polyrad/util/sampling.h"

#include <array>
#include <cmath>
#include <mutex>

#include "polyrad/util/error.h"

namespace polyrad {

namespace {

GaussRule make_rule(int n) {
  // Newton's method on P_n from the Chebyshev-like first guesses, then map [-1,1] -> [0,1].
  GaussRule r;
  r.node.resize(n);
  r.weight.resize(n);
  for (int k = 0; k < n; ++k) {
    double x = std::cos(kPi * (k + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = x;
      for (int m = 2; m <= n; ++m) {
        double p2 = ((2.0 * m - 1.0) * x * p1 - (m - 1.0) * p0) / m;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    r.node[k] = 0.5 * (1.0 - x);
    r.weight[k] = 1.0 / ((1.0 - x * x) * dp * dp);  // (2/((1-x^2)P'^2)) / 2 for [0, 1]
  }
  return r;
}

}  // namespace

const GaussRule& gauss_legendre(int n) {
  POLYRAD_CHECK(n >= 1 && n <= 16);
  static std::array<GaussRule, 17> rules;
  static std::once_flag once;
  std::call_once(once, [] {
    for (int m = 1; m <= 16; ++m) rules[m] = make_rule(m);
  });
  return rules[n];
}

}  // namespace polyrad
