// The light sampler (world/light_sampling.h): which patch a number picks, and the density of
// the point it draws, against what they must be by definition; the lights' boxes, against
// the rays that meet a light.
#include "polyrad/world/light_sampling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "polyrad/util/sampling.h"
#include "polyrad/world/world.h"
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

// Every ray that meets a light's front, as the ray caster finds it from the origin it lifts off
// a patch, is one the lights' boxes let through, and most other rays are not. On the room (six
// lamps, six boxes): rays from points all over the room, half toward points on the lamps with
// up to a twentieth of a lamp's size added (to graze their edges from both sides), half in
// uniform directions.
TEST(LightSampling, BoxesLetThroughEveryRayThatMeetsALight) {
  const auto world = World::load(test::scene_path("room"));
  const PatchSet& patches = world->patches();
  const RayCaster& caster = world->caster();
  const LightBounds bounds(patches);
  ASSERT_EQ(bounds.boxes(), 6u);
  Rng rng(7);
  const auto n = static_cast<std::uint32_t>(patches.size());
  int met = 0, let_through = 0, rays = 0;
  for (int k = 0; k < 40000; ++k) {
    const PatchId i = static_cast<PatchId>(rng.next() % n);
    if (patches[i].emitter) continue;
    double density;
    const Vec3 x = patches[i].sample(Vec2(rng.uniform32(), rng.uniform32()), &density);
    Vec3 d;
    if (k % 2 == 0) {
      const LightSample l = world->lights().sample(Vec2(rng.uniform32(), rng.uniform32()));
      const double size = patches[l.patch].diameter() * 0.05;
      d = l.point - x +
          size * Vec3(rng.uniform32() - 0.5, rng.uniform32() - 0.5, rng.uniform32() - 0.5);
    } else {
      const double z = 1.0 - 2.0 * rng.uniform32(), phi = 2.0 * kPi * rng.uniform32();
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      d = Vec3(r * std::cos(phi), r * std::sin(phi), z);
    }
    d.normalize();
    const Vec3 origin = caster.origin_from(x, patches[i], d);
    const bool may = bounds.may_meet(origin, d);
    const Hit h = caster.intersect(origin, d);
    ++rays;
    let_through += may;
    if (h.valid() && h.front && patches[h.patch].emitter) {
      ++met;
      ASSERT_TRUE(may) << "a ray from patch " << i << " meets light patch " << h.patch;
    }
  }
  EXPECT_GT(met, rays / 10);             // the lamps were met often
  EXPECT_LT(let_through, rays * 3 / 4);  // and the boxes do prune
  EXPECT_GT(let_through, met);
}

// The padding follows the scene, not the lamp: a lamp 0.01 wide at the origin, seen from a floor
// 10 below, where single precision puts hits up to 1e-6 outside its edges (a padding of 1e-5 of
// the lamp's own coordinates refused many of the rays below that met it). Rays toward points
// on the lamp and up to a fifth of its width beyond its edges, half of them within 2e-6 of one.
TEST(LightSampling, BoxesHoldASmallLampSeenFromAfar) {
  const double w = 0.005;
  Patch lamp = test::make_quad({-w, 0, -w}, {w, 0, -w}, {w, 0, w}, {-w, 0, w});  // facing down
  lamp.object = 1;
  lamp.emitter = true;
  const Patch floor =
      test::make_quad({-10, -10, -10}, {-10, -10, 10}, {10, -10, 10}, {10, -10, -10});  // facing up
  const PatchSet patches = test::make_patch_set({lamp, floor});
  const RayCaster caster(patches);
  const LightBounds bounds(patches);
  Rng rng(11);
  int met = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 x(20 * rng.uniform32() - 10, -10, 20 * rng.uniform32() - 10);
    const double across = k % 2 == 0 ? w + 4e-6 * (rng.uniform32() - 0.5)  // at an edge
                                     : 2.4 * w * (rng.uniform32() - 0.5);
    const Vec3 y(across, 0, 2.4 * w * (rng.uniform32() - 0.5));
    const Vec3 d = (y - x).normalized();
    const Vec3 origin = caster.origin_from(x, patches[1], d);
    const Hit h = caster.intersect(origin, d);
    if (!(h.valid() && h.front && h.patch == 0)) continue;
    ++met;
    ASSERT_TRUE(bounds.may_meet(origin, d)) << "a ray from " << x.transpose() << " meets the lamp";
  }
  EXPECT_GT(met, 8000);
}

// The boxes are padded by 1e-5 of the scene's size, as much as the ray caster lifts a ray's
// origin off a flat patch; off a bent quad it lifts the bend more, so the boxes are asked from
// the origin a ray really leaves, RayCaster::origin_from. A wall with a bend of 3e-3 (set here as
// the mesher sets a bent quad's) facing a lamp's edge across, a ray from it that meets the lamp
// a tenth of the lift inside that edge: from the point on the wall its line passes outside the
// lamp's box.
TEST(LightSampling, BoxesAreAskedFromTheOriginTheRayLeaves) {
  Patch lamp = test::make_quad({0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1});  // facing down
  lamp.object = 1;
  lamp.emitter = true;
  Patch wall = test::make_quad({2, 0, 0}, {2, 0, 1}, {2, 1, 1}, {2, 1, 0});  // facing -x
  wall.bend = 3e-3;
  const PatchSet patches = test::make_patch_set({lamp, wall});
  const RayCaster caster(patches);
  const LightBounds bounds(patches);
  const double lift = caster.lift(patches[1]);
  ASSERT_GT(lift, 3e-3);
  const Vec3 x(2, 0, 0.5);
  const Vec3 origin = caster.origin_from(x, patches[1], Vec3(-1, 1, 0));
  const Vec3 d = (Vec3(1 - 0.1 * lift, 1, 0.5) - origin).normalized();
  const Hit h = caster.intersect(origin, d);
  ASSERT_TRUE(h.valid() && h.front && h.patch == 0);
  EXPECT_TRUE(bounds.may_meet(origin, d));
  EXPECT_FALSE(bounds.may_meet(x, d));
}

// Beyond kMaxBoxes emitting objects every ray may meet a light; with none, no ray does.
TEST(LightSampling, BoxesGiveUpBeyondTheirCountAndHoldNothingWithoutLights) {
  std::vector<Patch> lamps;
  for (int k = 0; k <= static_cast<int>(LightBounds::kMaxBoxes); ++k) {
    Patch p =
        test::make_quad({k * 2.0, 0, 0}, {k * 2.0 + 1, 0, 0}, {k * 2.0 + 1, 1, 0}, {k * 2.0, 1, 0});
    p.object = k;
    p.emitter = true;
    lamps.push_back(p);
  }
  const PatchSet many = test::make_patch_set(lamps);
  const LightBounds all(many);
  EXPECT_EQ(all.boxes(), 0u);
  EXPECT_TRUE(all.may_meet(Vec3(0, 0, 5), Vec3(0, 0, 1)));  // away from every lamp
  lamps.pop_back();
  const PatchSet fewer = test::make_patch_set(lamps);
  const LightBounds some(fewer);
  EXPECT_EQ(some.boxes(), LightBounds::kMaxBoxes);
  EXPECT_FALSE(some.may_meet(Vec3(0.5, 0.5, 5), Vec3(0, 0, 1)));
  EXPECT_TRUE(some.may_meet(Vec3(0.5, 0.5, 5), Vec3(0, 0, -1)));
  EXPECT_TRUE(some.may_meet(Vec3(-3, 0.5, 0), Vec3(1, 0, 0)));  // along the lamps' plane
  for (Patch& p : lamps) p.emitter = false;
  const PatchSet dark = test::make_patch_set(lamps);
  const LightBounds none(dark);
  EXPECT_EQ(none.boxes(), 0u);
  EXPECT_FALSE(none.may_meet(Vec3(0.5, 0.5, 5), Vec3(0, 0, -1)));
}

}  // namespace
}  // namespace polyrad
