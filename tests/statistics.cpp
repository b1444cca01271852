// Statistics shared by the tests (statistics.h).
#include "statistics.h"

#include <algorithm>
#include <limits>

namespace polyrad::test {

double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  double front = std::exp(-x + a * std::log(x) - std::lgamma(a));
  if (x < a + 1.0) {
    double ap = a, del = 1.0 / a, sum = del;
    for (int n = 0; n < 100000 && std::abs(del) > std::abs(sum) * 1e-16; ++n) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
    }
    return std::max(0.0, 1.0 - sum * front);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, cf = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    cf = b + an / cf;
    if (std::abs(cf) < tiny) cf = tiny;
    d = 1.0 / d;
    double del = d * cf;
    h *= del;
    if (std::abs(del - 1.0) < 1e-16) break;
  }
  return front * h;
}

ChiSquare chi_square(const std::vector<double>& prob, const std::vector<long>& count, long n) {
  std::vector<double> e;
  std::vector<double> o;
  double pool_e = 0.0, pool_o = 0.0;
  for (size_t i = 0; i < prob.size(); ++i) {
    double ei = std::max(0.0, prob[i]) * n;
    if (ei < 5.0) {
      pool_e += ei;
      pool_o += count[i];
    } else {
      e.push_back(ei);
      o.push_back(static_cast<double>(count[i]));
    }
  }
  if (pool_e >= 5.0 || e.empty()) {
    e.push_back(pool_e);
    o.push_back(pool_o);
  } else {
    size_t k = std::min_element(e.begin(), e.end()) - e.begin();
    e[k] += pool_e;
    o[k] += pool_o;
  }
  ChiSquare r;
  for (size_t i = 0; i < e.size(); ++i) {
    if (e[i] <= 0.0) {
      if (o[i] > 0.0) r.statistic = std::numeric_limits<double>::infinity();
      continue;
    }
    r.statistic += (o[i] - e[i]) * (o[i] - e[i]) / e[i];
  }
  r.dof = static_cast<int>(e.size()) - 1;
  r.p_value = std::isfinite(r.statistic) ? gamma_q(0.5 * r.dof, 0.5 * r.statistic) : 0.0;
  return r;
}

}  // namespace polyrad::test
