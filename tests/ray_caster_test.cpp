#include "polyrad/raycast/ray_caster.h"

#include <gtest/gtest.h>

#include "polyrad/util/sampling.h"
#include "polyrad/world/world.h"
#include "test_support.h"

namespace polyrad {
namespace {

PatchSet two_patches() {
  Patch floor = test::make_quad({0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0});  // faces +y
  Patch tri;
  tri.corners = 3;
  tri.corner = {Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(0, 1, 1), Vec3(0, 1, 1)};  // faces -y
  tri.normal = Vec3(0, -1, 0);
  tri.area = 0.5;
  tri.centroid = Vec3(1.0 / 3, 1, 1.0 / 3);
  return test::make_patch_set({floor, tri});
}

TEST(RayCaster, HitsTheNearestPatchWithItsParameters) {
  PatchSet ps = two_patches();
  RayCaster rc(ps);
  Hit down = rc.intersect(Vec3(0.25, 0.5, 0.6), Vec3(0, -1, 0));
  ASSERT_TRUE(down.valid());
  EXPECT_EQ(down.patch, 0);
  EXPECT_NEAR(down.t, 0.5, 1e-6);
  EXPECT_TRUE(down.front);
  EXPECT_TRUE((ps[0].point(down.u, down.v) - Vec3(0.25, 0, 0.6)).norm() < 1e-5);

  Hit up = rc.intersect(Vec3(0.2, 0.5, 0.3), Vec3(0, 1, 0));
  ASSERT_TRUE(up.valid());
  EXPECT_EQ(up.patch, 1);
  EXPECT_TRUE(up.front);
  EXPECT_TRUE((ps[1].point(up.u, up.v) - Vec3(0.2, 1, 0.3)).norm() < 1e-5);

  Hit back = rc.intersect(Vec3(0.5, -1, 0.5), Vec3(0, 1, 0));
  ASSERT_TRUE(back.valid());
  EXPECT_EQ(back.patch, 0);
  EXPECT_FALSE(back.front);

  EXPECT_FALSE(rc.intersect(Vec3(0.9, 0.5, 0.9), Vec3(0, 1, 0)).valid());  // beside the triangle
  EXPECT_FALSE(rc.intersect(Vec3(0.5, 0.5, 0.5), Vec3(1, 0, 0)).valid());
}

TEST(RayCaster, OcclusionRespectsTheSegment) {
  PatchSet ps = two_patches();
  RayCaster rc(ps);
  EXPECT_TRUE(rc.segment_occluded(Vec3(0.2, -1, 0.2), Vec3(0.2, 0.5, 0.2)));
  EXPECT_FALSE(rc.segment_occluded(Vec3(0.2, 0.1, 0.2), Vec3(0.2, 0.9, 0.2)));
  // From a point on the floor to a point on the triangle: the end points do not block.
  EXPECT_FALSE(rc.segment_occluded(Vec3(0.2, 0, 0.2), Vec3(0.2, 1, 0.2)));
  EXPECT_TRUE(rc.occluded(Vec3(0.2, 2, 0.2), Vec3(0, -1, 0)));
  EXPECT_FALSE(rc.occluded(Vec3(0.2, 2, 0.2), Vec3(0, -1, 0), 0.0, 0.5));
}

TEST(RayCaster, FacingSegmentsCastTheSameRayAsSegmentOccluded) {
  // A floor facing up, a ceiling facing down and a blocker between: the form factors' fast path
  // (origin lifted once, no side tests) must block exactly the segments segment_occluded does.
  PatchSet ps = test::make_patch_set(
      {test::make_quad({0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}),
       test::make_quad({0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}),
       test::make_quad({0.3, 0.5, 0.3}, {0.3, 0.5, 0.7}, {0.7, 0.5, 0.7}, {0.7, 0.5, 0.3})});
  RayCaster rc(ps);
  Rng rng(7);
  int blocked = 0, open = 0;
  for (int s = 0; s < 2000; ++s) {
    const Vec3 x(rng.uniform(), 0.0, rng.uniform()), y(rng.uniform(), 1.0, rng.uniform());
    const bool expected = rc.segment_occluded(x, ps[0], y, ps[1]);
    EXPECT_EQ(rc.facing_segment_occluded(rc.lifted_front(x, ps[0]), ps[0], y, ps[1],
                                         (y - x).squaredNorm()),
              expected)
        << s;
    (expected ? blocked : open) += 1;
  }
  EXPECT_GT(blocked, 100);
  EXPECT_GT(open, 100);
}

TEST(RayCaster, PacketsAnswerAsOneSegmentAtATime) {
  // The room's patches (furniture, thin shelves, a mirror): segments between random points of
  // random patch pairs, in packets of every fill from 1 to 16, each lane against the one-ray
  // answer; some segments too short to be cast, which read unblocked as segment_occluded says.
  auto world = World::load(test::scene_path("room"));
  const RayCaster& rc = world->caster();
  const PatchSet& ps = world->patches();
  Rng rng(11);
  auto patch = [&] { return static_cast<PatchId>(rng.uniform() * static_cast<double>(ps.size())); };
  auto point = [&](const Patch& p) { return p.point(rng.uniform(), rng.uniform()); };
  int blocked = 0, open = 0, short_ones = 0, facing = 0;
  for (int round = 0; round < 400; ++round) {
    RayCaster::SegmentPacket packet, facing_packet;
    std::array<bool, RayCaster::SegmentPacket::kSize> expected{}, expected_facing{};
    const int fill = 1 + round % RayCaster::SegmentPacket::kSize;
    for (int k = 0; k < fill; ++k) {
      const PatchId a = patch(), b = patch();
      const Vec3 x = point(ps[a]);
      const Vec3 y = k % 5 == 4 ? Vec3(x + rc.epsilon() * ps[a].normal) : point(ps[b]);
      expected[k] = rc.segment_occluded(x, ps[a], y, ps[b]);
      rc.add_segment(packet, x, ps[a], y, ps[b]);
      short_ones += packet.active[k] ? 0 : 1;
      (expected[k] ? blocked : open) += 1;
      // The form factors' kind: from a's front to b's front.
      const Vec3 x_lifted = rc.lifted_front(x, ps[a]);
      const double length2 = (y - x).squaredNorm();
      expected_facing[k] = rc.facing_segment_occluded(x_lifted, ps[a], y, ps[b], length2);
      rc.add_facing_segment(facing_packet, x_lifted, ps[a], y, ps[b], length2);
      facing += expected_facing[k] ? 1 : 0;
    }
    rc.cast(packet);
    rc.cast(facing_packet);
    ASSERT_EQ(packet.count, fill);
    ASSERT_EQ(facing_packet.count, fill);
    for (int k = 0; k < fill; ++k) {
      EXPECT_EQ(packet.blocked[k], expected[k]) << round << " " << k;
      EXPECT_EQ(facing_packet.blocked[k], expected_facing[k]) << round << " " << k;
    }
  }
  EXPECT_GT(blocked, 300);
  EXPECT_GT(open, 300);
  EXPECT_GT(short_ones, 100);
  EXPECT_GT(facing, 100);
}

}  // namespace
}  // namespace polyrad
