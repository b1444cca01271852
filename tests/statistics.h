// Statistics shared by the tests of estimators: Pearson's chi-square test of sampled counts
// against cell probabilities, with its p-value from the regularised incomplete gamma function,
// and running moments (mean, standard error) of Monte Carlo estimates.
//
//   test::ChiSquare c = test::chi_square(prob, count, n);
//   EXPECT_GE(c.p_value, 1e-5);
//   test::Moments m;  for (...) m.add(x);  EXPECT_NEAR(m.mean(), exact, 4 * m.std_error());
//
// Cost: O(cells) for the test; O(1) a sample for the moments.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace polyrad::test {

// Regularised upper incomplete gamma Q(a, x) (Numerical Recipes 6.2): series below a + 1,
// Lentz's continued fraction above.
double gamma_q(double a, double x);

struct ChiSquare {
  double statistic = 0.0, p_value = 1.0;
  int dof = 0;
};

// Pearson's test of counts against cell probabilities (summing to 1) for n draws. Cells expected
// to hold fewer than 5 are pooled; a pool still below 5 joins the smallest remaining cell.
ChiSquare chi_square(const std::vector<double>& prob, const std::vector<long>& count, long n);

// Running mean and standard error.
struct Moments {
  double n = 0.0, sum = 0.0, sum2 = 0.0;
  void add(double x) {
    n += 1.0;
    sum += x;
    sum2 += x * x;
  }
  double mean() const { return sum / n; }
  double std_error() const {
    double m = mean();
    return std::sqrt(std::max(0.0, sum2 / n - m * m) / n);
  }
};

}  // namespace polyrad::test
