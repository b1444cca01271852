#include "polyrad/geometry/mesher.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "polyrad/geometry/convex_polygon.h"
#include "test_support.h"

namespace polyrad {
namespace {

double polygon_area(const std::vector<Vec3>& v) {
  Vec3 n = Vec3::Zero();
  for (size_t k = 0; k < v.size(); ++k) n += v[k].cross(v[(k + 1) % v.size()]);
  return 0.5 * n.norm();
}

double longest_edge(const std::vector<Vec3>& v) {
  double e = 0.0;
  for (size_t k = 0; k < v.size(); ++k) e = std::max(e, (v[(k + 1) % v.size()] - v[k]).norm());
  return e;
}

TEST(Mesher, QuadBecomesAGridOfQuads) {
  std::vector<Vec3> q{{0, 0, 0}, {1, 0, 0}, {1, 2, 0}, {0, 2, 0}};
  auto pieces = subdivide_face(q, 0.5);
  ASSERT_EQ(pieces.size(), 8u);
  double area = 0.0;
  for (const auto& p : pieces) {
    EXPECT_EQ(p.size(), 4u);
    EXPECT_LE(longest_edge(p), 0.5 + 1e-12);
    area += polygon_area(p);
  }
  EXPECT_NEAR(area, 2.0, 1e-12);
}

TEST(Mesher, TrianglesAndPolygons) {
  auto tri = subdivide_face({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, 0.3);
  EXPECT_EQ(tri.size(), 25u);  // ceil(sqrt(2) / 0.3) = 5 cells a side
  double area = 0.0;
  for (const auto& p : tri) {
    EXPECT_LE(longest_edge(p), 0.3 + 1e-12);
    area += polygon_area(p);
    Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
    EXPECT_GT(n.z(), 0.0);  // orientation kept
  }
  EXPECT_NEAR(area, 0.5, 1e-12);
  std::vector<Vec3> pentagon;
  for (int k = 0; k < 5; ++k)
    pentagon.emplace_back(std::cos(2 * kPi * k / 5), std::sin(2 * kPi * k / 5), 0.0);
  double sum = 0.0;
  for (const auto& p : subdivide_face(pentagon, 0.4)) sum += polygon_area(p);
  EXPECT_NEAR(sum, polygon_area(pentagon), 1e-12);
}

TEST(Mesher, TrianglePairsOfAnObjBecomeQuads) {
  // The measured Cornell block is stored as twelve triangles; the mesher rebuilds six quads.
  std::string mesh = std::string(POLYRAD_TEST_DATA_DIR) + "/meshes/cbox_smallbox.obj";
  Scene s = test::scene_from_json(R"({
    "camera": {"position": [0, 100, -500], "look_at": [0, 100, 0], "fov_deg": 40, "width": 8, "height": 8},
    "patch_size": 1000,
    "materials": {"w": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}},
    "objects": [{"name": "block", "material": "w", "mesh": ")" +
                                  mesh + R"("}]})");
  ASSERT_EQ(s.objects[0].faces.size(), 12u);
  PatchSet ps = mesh_scene(s);
  ASSERT_EQ(ps.size(), 6u);
  for (const auto& p : ps.patches) EXPECT_EQ(p.corners, 4);
}

TEST(Mesher, PatchesKnowTheirObjectAreaAndNormal) {
  Scene scene = load_scene(test::scene_path("cornell-box"));
  PatchSet ps = mesh_scene(scene);
  std::vector<double> area(scene.objects.size(), 0.0);
  for (const auto& p : ps.patches) {
    const SceneObject& o = scene.objects[p.object];
    EXPECT_LE(p.diameter(), std::sqrt(2.0) * o.patch_size + 1e-9);
    for (int c = 0; c < p.corners; ++c)
      EXPECT_LE((p.corner[(c + 1) % p.corners] - p.corner[c]).norm(), o.patch_size + 1e-9);
    EXPECT_NEAR(p.normal.norm(), 1.0, 1e-12);
    EXPECT_EQ(p.material, o.material);
    area[p.object] += p.area;
  }
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    double expect = 0.0;
    for (const auto& f : scene.objects[o].faces) expect += polygon_area(f.vertices);
    // The measured red wall bends by 0.8 mm: its patches follow the bilinear surface, whose area
    // exceeds the projected (Newell) area of the face by 3e-6.
    EXPECT_NEAR(area[o], expect, 1e-5 * expect) << scene.objects[o].name;
  }
  // The floor faces up, the light faces down, and the light has the finer patches.
  ObjectId floor = scene.find_object("floor"), light = scene.find_object("light");
  for (const auto& p : ps.patches) {
    if (p.object == floor) {
      EXPECT_GT(p.normal.y(), 0.99);
    }
    if (p.object == light) {
      EXPECT_LT(p.normal.y(), -0.99);
      EXPECT_TRUE(p.emitter);
      EXPECT_EQ(p.emission[0], 17.0);
    }
  }
}

TEST(Mesher, ParametrisationAndSampling) {
  Patch p = test::make_quad({0, 0, 0}, {2, 0, 0}, {1.5, 1, 0}, {0, 1, 0});  // a trapezoid
  EXPECT_TRUE((p.point(0, 0) - p.corner[0]).norm() < 1e-12);
  EXPECT_TRUE((p.point(1, 1) - p.corner[2]).norm() < 1e-12);
  auto w = p.corner_weights(0.3, 0.6);
  Vec3 x = Vec3::Zero();
  for (int c = 0; c < 4; ++c) x += w[c] * p.corner[c];
  EXPECT_TRUE((x - p.point(0.3, 0.6)).norm() < 1e-12);
  // The density-weighted mean of a linear function over the samples is its area mean.
  double sum = 0.0;
  int n = 200;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      double density;
      Vec3 y = p.sample(Vec2((a + 0.5) / n, (b + 0.5) / n), &density);
      sum += y.x() * density;
    }
  // Centroid x of the trapezoid: by triangles (0,1,2) and (0,2,3).
  double a1 = 1.0, a2 = 0.75;
  double cx = (a1 * (0 + 2 + 1.5) / 3 + a2 * (0 + 1.5 + 0) / 3) / (a1 + a2);
  EXPECT_NEAR(sum / (n * n), cx, 1e-4);
}

TEST(Mesher, SampleGivesThePointsParameters) {
  // Lights drawn by Patch::sample are shaded at the parameters it returns (camera gather).
  Patch quad = test::make_quad({0, 0, 0}, {2, 0, 0}, {1.5, 1, 0.2}, {0, 1, 0});
  Patch tri = test::make_quad({0, 0, 0}, {2, 0, 0}, {0.5, 1, 0}, {0.5, 1, 0});
  tri.corners = 3;
  for (const Patch* p : {&quad, &tri})
    for (double s0 : {0.0, 0.13, 0.5, 0.97})
      for (double s1 : {0.0, 0.31, 0.77, 1.0}) {
        double density;
        Vec2 uv;
        Vec3 y = p->sample(Vec2(s0, s1), &density, &uv);
        EXPECT_LT((p->point(uv.x(), uv.y()) - y).norm(), 1e-12)
            << p->corners << " " << s0 << " " << s1;
      }
}

// A parallelogram's bilinear map is linear: its density is 1 everywhere; a trapezoid's is not.
TEST(Mesher, ParallelogramsAreKnownByTheirCorners) {
  const Patch square = test::make_quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0});
  const Patch sheared = test::make_quad({0, 0, 0}, {2, 0, 0}, {2.5, 1, 0.3}, {0.5, 1, 0.3});
  const Patch trapezoid = test::make_quad({0, 0, 0}, {2, 0, 0}, {1.5, 1, 0}, {0, 1, 0});
  Patch tri = test::make_quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 1, 0});
  tri.corners = 3;
  EXPECT_TRUE(square.is_parallelogram());
  EXPECT_TRUE(sheared.is_parallelogram());
  EXPECT_FALSE(trapezoid.is_parallelogram());
  EXPECT_FALSE(tri.is_parallelogram());
  for (const Patch* p : {&square, &sheared, &trapezoid}) {
    double density = 0.0;
    p->sample(Vec2(0.1, 0.8), &density);
    EXPECT_EQ(std::abs(density - 1.0) < 1e-12, p->is_parallelogram());
  }
}

TEST(Mesher, UnsampleInvertsSample) {
  // Exposure grids are read at a point's unit-square coordinates (exposure.h): a trapezoid, a
  // non-planar quad and a triangle, with points off a flat patch's plane projected onto it.
  Patch trapezoid = test::make_quad({0, 0, 0}, {2, 0, 0}, {1.5, 1, 0}, {0, 1, 0});
  Patch warped = test::make_quad({0, 0, 0}, {2, 0, 0}, {1.5, 1, 0.2}, {0, 1, 0});
  Patch tri = test::make_quad({0, 0, 0}, {2, 0, 0}, {0.5, 1, 0}, {0.5, 1, 0});
  tri.corners = 3;
  for (const Patch* p : {&trapezoid, &warped, &tri})
    for (double s0 : {0.0, 0.13, 0.5, 0.97})
      for (double s1 : {0.02, 0.31, 0.77, 1.0}) {
        double density;
        const Vec3 y = p->sample(Vec2(s0, s1), &density);
        const Vec2 s = p->unsample(p == &warped ? y : y + 1e-3 * p->normal);
        EXPECT_NEAR(s.x(), s0, 1e-6) << p->corners << " " << s0 << " " << s1;
        if (s0 > 0.0) {
          EXPECT_NEAR(s.y(), s1, 1e-6) << p->corners << " " << s0 << " " << s1;
        }
      }
  // Outside the patch: clamped to the square.
  const Vec2 s = trapezoid.unsample(Vec3(-1, 3, 0));
  EXPECT_EQ(s, Vec2(0.0, 1.0));
}

}  // namespace
// The convex polygons the mirror chains' beams are made of (geometry/convex_polygon.h): a hull
// drops inner and repeated points and turns counter-clockwise; two squares overlapping by a
// quarter meet in a square of that area whichever way each turns; squares that share only an
// edge or a corner meet in nothing.
TEST(ConvexPolygon, HullIntersectionAndContainment) {
  const std::vector<Vec2> hull =
      convex_hull({{1, 1}, {0, 0}, {0.5, 0.5}, {1, 0}, {0, 1}, {1, 0}, {0.2, 0.9}});
  ASSERT_EQ(hull.size(), 4u);
  EXPECT_DOUBLE_EQ(twice_signed_area(hull), 2.0);
  EXPECT_TRUE(convex_contains(hull, Vec2(0.5, 0.5)));
  EXPECT_TRUE(convex_contains(hull, Vec2(1.0, 0.5)));  // on an edge
  EXPECT_FALSE(convex_contains(hull, Vec2(1.001, 0.5)));
  EXPECT_EQ(convex_hull({{0, 0}, {1, 1}, {2, 2}}).size(), 2u);  // on one line: no area
  const auto square = [](double x, double y, bool ccw) {
    std::vector<Vec2> s{{x, y}, {x + 1, y}, {x + 1, y + 1}, {x, y + 1}};
    if (!ccw) std::reverse(s.begin(), s.end());
    return s;
  };
  for (const bool a : {true, false})
    for (const bool b : {true, false}) {
      const std::vector<Vec2> both = intersect_convex(square(0, 0, a), square(0.5, 0.5, b));
      EXPECT_NEAR(twice_signed_area(both), 0.5, 1e-15);
      EXPECT_TRUE(convex_contains(both, Vec2(0.75, 0.75)));
      EXPECT_FALSE(convex_contains(both, Vec2(0.25, 0.75)));
      EXPECT_TRUE(intersect_convex(square(0, 0, a), square(1, 0, b)).empty());  // an edge
      EXPECT_TRUE(intersect_convex(square(0, 0, a), square(1, 1, b)).empty());  // a corner
      EXPECT_TRUE(intersect_convex(square(0, 0, a), square(3, 0, b)).empty());
    }
  // A polygon that is not convex, zigzagging across a clipping edge as rounding can make a nearly
  // flat beam: the clip crosses it at every corner, and what does not fit its buffers is dropped,
  // never written past them (the sanitizer build watches).
  std::vector<Vec2> zigzag;
  for (int k = 0; k <= 40; ++k) zigzag.emplace_back(0.025 * k, k % 2 == 0 ? -1e-3 : 1e-3);
  zigzag.emplace_back(1.0, 1.0);
  zigzag.emplace_back(0.0, 1.0);
  const std::vector<Vec2> clipped = intersect_convex(zigzag, square(0, 0, true));
  EXPECT_LE(clipped.size(), zigzag.size() + 4 + 4);
}

}  // namespace polyrad
