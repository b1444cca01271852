// The light sampler (world/light_sampling.h): which patch a number picks, and the density of
// the point it draws, against what they must be by definition.
#include "polyrad/world/light_sampling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "test_support.h"

namespace polyrad {
namespace {

// A parallelogram, a trapezoid, a triangle and a quad with no parallel sides, side by side.
PatchSet mixed_patches() {
  Patch tri = test::make_quad({0, 3, 0}, {2, 3, 0}, {0.5, 4, 0}, {0.5, 4, 0});
  tri.corners = 3;
  return test::make_patch_set(
      {test::make_quad({0, 0, 0}, {2, 0, 0}, {2.5, 1, 0}, {0.5, 1, 0}),
       test::make_quad({0, 1.5, 0}, {2, 1.5, 0}, {1.5, 2.5, 0}, {0, 2.5, 0}), tri,
       test::make_quad({3, 0, 0}, {5, 0, 0}, {4.5, 1.2, 0}, {3, 1, 0})});
}

// u picks the first patch (of those with a positive weight, in order) whose cumulative weight
// share exceeds u, as a search of the cumulative shares finds it; the sampler's guide table
// must not change that anywhere, on the shares' boundaries least of all.
TEST(LightSampling, ChoiceIsTheFirstPatchWhoseCumulativeShareExceedsTheNumber) {
  std::vector<Patch> many;
  std::vector<double> weight;
  for (int k = 0; k < 40; ++k) {
    many.push_back(
        test::make_quad({k * 1.0, 0, 0}, {k + 0.5, 0, 0}, {k + 0.5, 1, 0}, {k * 1.0, 1, 0}));
    // Uneven weights, some zero (never drawn), a run of tiny ones.
    weight.push_back(k % 7 == 3 ? 0.0 : (k > 20 && k < 26 ? 1e-9 : 1.0 + (k * 37 % 11)));
  }
  const PatchSet patches = test::make_patch_set(many);
  const LightSampler sampler(patches, weight);
  std::vector<PatchId> drawn;
  std::vector<double> cdf;
  double total = 0.0, running = 0.0;
  for (double w : weight) total += w;
  for (PatchId p = 0; p < static_cast<PatchId>(weight.size()); ++p) {
    if (!(weight[p] > 0.0)) continue;
    drawn.push_back(p);
    running += weight[p];
    cdf.push_back(running / total);
  }
  cdf.back() = 1.0;
  std::vector<double> us;
  for (int k = 0; k <= 4000; ++k) us.push_back(std::min(k / 4000.0, std::nextafter(1.0, 0.0)));
  for (double c : cdf)
    for (double u : {std::nextafter(c, 0.0), c, std::nextafter(c, 2.0)})
      if (u >= 0.0 && u < 1.0) us.push_back(u);
  for (std::size_t k = 1; k < drawn.size(); ++k) {  // the guide's own steps, k / n
    const double g = static_cast<double>(k) / static_cast<double>(drawn.size());
    for (double u : {std::nextafter(g, 0.0), g, std::nextafter(g, 2.0)}) us.push_back(u);
  }
  for (double u : us) {
    const auto e =
        static_cast<std::size_t>(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
    const PatchId expected = drawn[std::min(e, drawn.size() - 1)];
    ASSERT_EQ(sampler.sample(u, Vec2(0.5, 0.5)).patch, expected) << "u = " << u;
  }
}

// The density sample() reports is the one area_pdf() gives at the point drawn, and 1 / density
// averages to the area over select: select / area everywhere on triangles and parallelograms,
// through the bilinear map's Jacobian on other quads (the midpoint rule is exact for it on a
// planar quad, where the Jacobian is linear in the parameters).
TEST(LightSampling, DensityOfEachPointIsTheAreaDensityThere) {
  const PatchSet patches = mixed_patches();
  const std::vector<double> weight{1.0, 2.0, 0.5, 1.5};
  const LightSampler sampler(patches, weight);
  const double total = 5.0;
  for (PatchId p = 0; p < 4; ++p) {
    const double select = weight[p] / total;
    double inverse_sum = 0.0;
    const int n = 64;
    // The points on p: stratified over the unit square, through sample(u) with u.x inside p's
    // share of [0, 1) (the cumulative shares are 0.2, 0.6, 0.7 and 1).
    const double lo = p == 0 ? 0.0 : (p == 1 ? 0.2 : (p == 2 ? 0.6 : 0.7));
    const double hi = p == 0 ? 0.2 : (p == 1 ? 0.6 : (p == 2 ? 0.7 : 1.0));
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const Vec2 u(lo + (hi - lo) * (a + 0.5) / n, (b + 0.5) / n);
        const LightSample s = sampler.sample(u);
        ASSERT_EQ(s.patch, p);
        ASSERT_GT(s.area_pdf, 0.0);
        EXPECT_NEAR(sampler.area_pdf(p, s.point) / s.area_pdf, 1.0, 1e-9);
        if (p == 0 || p == 2) {
          EXPECT_NEAR(s.area_pdf * patches[p].area / select, 1.0, 1e-12);
        }
        inverse_sum += 1.0 / s.area_pdf;
      }
    EXPECT_NEAR(inverse_sum / (n * n) * select / patches[p].area, 1.0, 1e-9) << "patch " << p;
  }
  EXPECT_EQ(sampler.area_pdf(0, patches[0].centroid), 0.2 / patches[0].area);
}

}  // namespace
}  // namespace polyrad
