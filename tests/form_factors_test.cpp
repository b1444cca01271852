// Form factors against the closed forms of papers/glossy-radiosity.md, section 10.
#include "polyrad/transport/form_factors.h"

#include <gtest/gtest.h>
#include <omp.h>

#include "polyrad/solve/solver.h"
#include "polyrad/util/sampling.h"
#include "polyrad/transport/system.h"
#include "test_support.h"

namespace polyrad {
namespace {

using test::make_quad;

// Two directly opposed a x b rectangles, distance c, facing each other.
PatchSet opposed(double a, double b, double c) {
  return test::make_patch_set({make_quad({0, 0, 0}, {a, 0, 0}, {a, b, 0}, {0, b, 0}),
                               make_quad({0, 0, c}, {0, b, c}, {a, b, c}, {a, 0, c})});
}

// Rectangle w x l on the floor (z = 0) and h x l standing on the shared edge x = 0.
PatchSet perpendicular(double l, double w, double h) {
  return test::make_patch_set({make_quad({0, 0, 0}, {w, 0, 0}, {w, l, 0}, {0, l, 0}),
                               make_quad({0, 0, 0}, {0, l, 0}, {0, l, h}, {0, 0, h})});
}

double ff01(const PatchSet& ps) {
  RayCaster caster(ps);
  FormFactors ff = compute_form_factors(ps, caster);
  return ff.at(0, 1);
}

TEST(FormFactors, ParallelUnitSquaresAtDistanceOne) {
  EXPECT_NEAR(test::parallel_rectangles_ff(1, 1, 1), 0.199825, 1e-6);  // the formula itself
  EXPECT_NEAR(ff01(opposed(1, 1, 1)), 0.199825, 1e-3);
}

TEST(FormFactors, PerpendicularUnitSquaresSharingAnEdge) {
  EXPECT_NEAR(test::perpendicular_rectangles_ff(1, 1, 1), 0.200044, 1e-6);
  EXPECT_NEAR(ff01(perpendicular(1, 1, 1)), 0.200044, 1e-3);
}

TEST(FormFactors, ClosedFormsOverShapes) {
  for (double c : {0.25, 0.5, 2.0, 5.0})
    for (double b : {0.5, 1.0, 3.0})
      EXPECT_NEAR(ff01(opposed(1.0, b, c)), test::parallel_rectangles_ff(1.0, b, c),
                  2e-3 * test::parallel_rectangles_ff(1.0, b, c))
          << "b " << b << " c " << c;
  for (double w : {0.2, 1.0, 4.0})
    for (double h : {0.3, 1.0, 2.5})
      EXPECT_NEAR(ff01(perpendicular(1.0, w, h)), test::perpendicular_rectangles_ff(1.0, w, h),
                  2e-3 * test::perpendicular_rectangles_ff(1.0, w, h))
          << "w " << w << " h " << h;
}

TEST(FormFactors, EitherPatchAsOuterGivesTheSameAreaFormFactor) {
  // The estimator integrates over one patch; integrating over the other must give the same
  // A_a F_ab, the exact one (floor 1 x 2, wall 0.5 x 2 on the shared edge of length 2).
  FormFactorOptions o;
  Patch a = make_quad({0, 0, 0}, {1, 0, 0}, {1, 2, 0}, {0, 2, 0});
  Patch b = make_quad({0, 0, 0}, {0, 2, 0}, {0, 2, 0.5}, {0, 0, 0.5});
  double exact = a.area * test::perpendicular_rectangles_ff(2.0, 1.0, 0.5);
  EXPECT_NEAR(pair_area_form_factor(a, b, nullptr, o, 0), exact, 5e-4 * exact);
  EXPECT_NEAR(pair_area_form_factor(b, a, nullptr, o, 0), exact, 5e-4 * exact);
}

TEST(FormFactors, BackToBackAndCoplanarPatchesSeeNothing) {
  FormFactorOptions o;
  Patch up = make_quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0});
  Patch beside = make_quad({1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0});
  Patch below_facing_down = make_quad({0, 0, -1}, {0, 1, -1}, {1, 1, -1}, {1, 0, -1});
  EXPECT_EQ(pair_area_form_factor(up, beside, nullptr, o, 0), 0.0);
  EXPECT_EQ(pair_area_form_factor(up, below_facing_down, nullptr, o, 0), 0.0);
}

TEST(FormFactors, OccluderHalvesTheView) {
  // A large blocker between two small opposed squares hides them from each other entirely;
  // one that covers half of the upper square's x-range removes about half the exchange.
  PatchSet open = opposed(1, 1, 1);
  auto with = [&](Patch blocker) {
    auto patches = open.patches;
    patches.push_back(blocker);
    return test::make_patch_set(patches);
  };
  Patch full = make_quad({-5, -5, 0.5}, {5, -5, 0.5}, {5, 5, 0.5}, {-5, 5, 0.5});
  EXPECT_EQ(ff01(with(full)), 0.0);
  Patch half = make_quad({-5, -5, 0.99}, {0.5, -5, 0.99}, {0.5, 5, 0.99}, {-5, 5, 0.99});
  double f = ff01(with(half));
  EXPECT_GT(f, 0.35 * 0.199825);
  EXPECT_LT(f, 0.65 * 0.199825);
}

TEST(FormFactors, ClosedBoxRowsSumToOne) {
  Scene s = test::scene_from_json(test::closed_box_json(
      Vec3(1.0, 0.8, 1.3), 0.2, R"({"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]})", 1.0));
  auto sys = build_system(World::build(std::move(s)));
  double worst = 0.0;
  for (PatchId i = 0; i < static_cast<PatchId>(sys->patches().size()); ++i)
    worst = std::max(worst, std::abs(sys->form_factors.row_sum(i) - 1.0));
  EXPECT_LT(worst, 2e-3);
}

TEST(FormFactors, ReciprocityOnTheCornellBox) {
  auto sys = build_system(World::load(test::scene_path("cornell-box")));
  const auto& f = sys->form_factors.f;
  const auto& area = sys->form_factors.area;  // exposed areas A'_i: A'_i F_ij = A'_j F_ji
  long long checked = 0;
  for (PatchId i = 0; i < static_cast<PatchId>(area.size()); ++i)
    for (auto k = f.start[i]; k < f.start[i + 1]; ++k) {
      PatchId j = f.column[k];
      double fji = sys->form_factors.at(j, i);
      ASSERT_GT(fji, 0.0) << i << " sees " << j << " but not the reverse";
      EXPECT_NEAR(area[i] * f.value[k], area[j] * fji, 1e-6 * area[i] * f.value[k]);
      ++checked;
    }
  EXPECT_GT(checked, 100000);
}

// The Cornell box meshed with every patch_size set to `size`.
PatchSet cornell_box_patches(double size) {
  Scene scene = load_scene(test::scene_path("cornell-box"));
  for (auto& object : scene.objects) object.patch_size = size;
  return mesh_scene(scene);
}

TEST(FormFactors, EachStoredValueIsItsPairsOwnFormFactor) {
  // compute_form_factors takes whole quads' rules from a per-patch cache; pair_area_form_factor
  // builds each pair's rule itself. With the same pair key they must agree to the bit.
  const PatchSet ps = cornell_box_patches(100);
  RayCaster caster(ps);
  const FormFactorOptions o;
  FormFactors ff = compute_form_factors(ps, caster, o);
  const ExposureMap exposure(ps, caster, o.exposure_points, o.exposure_refined);
  const auto n = static_cast<PatchId>(ps.size());
  long long checked = 0;
  for (PatchId i = 0; i < n; ++i)
    for (PatchId j = i + 1; j < n; ++j) {
      const double stored = ff.at(i, j);
      if (stored <= 0.0) continue;
      const PatchId a = ps[i].area <= ps[j].area ? i : j, b = a == i ? j : i;
      const std::uint64_t key = static_cast<std::uint64_t>(i) * static_cast<std::uint64_t>(n) + j;
      const double g =
          pair_area_form_factor(ps[a], ps[b], &caster, o, key, nullptr, exposure[a]);
      EXPECT_EQ(static_cast<float>(g / exposure.area(i)), static_cast<float>(stored))
          << i << ", " << j;
      ++checked;
    }
  EXPECT_GT(checked, 1000);
}

// A partly buried patch keeps the grid its exposed area was measured on, and the pair integrals
// read it instead of probing (exposure.h). On the Cornell box's floor patches under the blocks:
// at random points the grid says what the probes say (cells beside the boundary probe), and the
// pair form factors agree with probing every point within 0.2 percent in sum (4e-5 measured),
// the difference being the clipped regions' exposure, now on the 32 x 32 grid where probing
// used 16 x 16. Read with the grid's axes swapped, 72 percent of the points agree and the sum is
// 23 percent low.
TEST(FormFactors, ExposureGridReadsWhatTheProbesSee) {
  const PatchSet ps = cornell_box_patches(50);
  RayCaster caster(ps);
  const FormFactorOptions o;
  const ExposureMap exposure(ps, caster, o.exposure_points, o.exposure_refined);
  ASSERT_GE(exposure.partly_buried(), 8u);
  Rng rng(5, 0);
  long long points = 0, agree = 0;
  double grid_sum = 0.0, probe_sum = 0.0;
  for (PatchId a = 0; a < static_cast<PatchId>(ps.size()); ++a) {
    const PatchExposure e = exposure[a];
    if (e.n == 0) continue;
    for (int k = 0; k < 200; ++k) {
      double density;
      const Vec3 x = ps[a].sample(rng.uniform2(), &density);
      ++points;
      agree += e.exposed_at(ps[a], x, caster) == !is_buried(x, ps[a], caster);
    }
    for (PatchId b = 0; b < static_cast<PatchId>(ps.size()); ++b) {
      if (b == a) continue;  // a as the outer patch, also where the build would take b
      const std::uint64_t key = static_cast<std::uint64_t>(a) * ps.size() + b;
      grid_sum += pair_area_form_factor(ps[a], ps[b], &caster, o, key, nullptr, e);
      probe_sum += pair_area_form_factor(ps[a], ps[b], &caster, o, key, nullptr, e.fraction);
    }
  }
  EXPECT_GE(static_cast<double>(agree), 0.99 * points) << agree << " of " << points;
  ASSERT_GT(probe_sum, 0.0);
  EXPECT_NEAR(grid_sum / probe_sum, 1.0, 2e-3);
}

TEST(FormFactors, SameNumbersOnOneOrTwoThreads) {
  auto build = [](int threads) {
    omp_set_num_threads(threads);
    auto sys = build_system(World::load(test::scene_path("cornell-box")));
    omp_set_num_threads(omp_get_num_procs());
    return sys->form_factors.f.value;
  };
  auto one = build(1);
  auto two = build(2);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_TRUE(one == two);
}

}  // namespace
}  // namespace polyrad

namespace polyrad {
namespace {

// A closed 1 x 1 x 1 box with a closed 0.3-cube standing on its floor, every face of
// reflectance a and emission 1: a furnace, so B = 1 / (1 - a) on every surface light can reach.
// The floor's 0.25 patches do not follow the cube's footprint, so some are partly buried.
// Adds objects (JSON, each after a comma) to a scene's object list.
std::string with_objects(const std::string& scene, const std::string& objects) {
  auto end = scene.rfind(']');
  return scene.substr(0, end - 1) + objects + scene.substr(end + 1);
}

std::string box_with_block(double a, double cube_patch_size = 0.0) {
  std::string m = R"({"type": "diffuse", "reflectance": [)" + std::to_string(a) + ", " +
                  std::to_string(a) + ", " + std::to_string(a) + "]}";
  std::string box = test::closed_box_json(Vec3(1, 1, 1), 0.25, m, 1.0);
  // The cube [0.3, 0.6] x [0, 0.3] x [0.3, 0.6], outward faces (the bottom one lies on the floor).
  std::string cube = R"(,
    {"name": "cube_top", "material": "m0", "emission": [1, 1, 1],
     "polygon": [[0.3, 0.3, 0.3], [0.3, 0.3, 0.6], [0.6, 0.3, 0.6], [0.6, 0.3, 0.3]]},
    {"name": "cube_bottom", "material": "m0", "emission": [1, 1, 1],
     "polygon": [[0.3, 0, 0.3], [0.6, 0, 0.3], [0.6, 0, 0.6], [0.3, 0, 0.6]]},
    {"name": "cube_left", "material": "m0", "emission": [1, 1, 1],
     "polygon": [[0.3, 0, 0.3], [0.3, 0, 0.6], [0.3, 0.3, 0.6], [0.3, 0.3, 0.3]]},
    {"name": "cube_right", "material": "m0", "emission": [1, 1, 1],
     "polygon": [[0.6, 0, 0.3], [0.6, 0.3, 0.3], [0.6, 0.3, 0.6], [0.6, 0, 0.6]]},
    {"name": "cube_front", "material": "m0", "emission": [1, 1, 1],
     "polygon": [[0.3, 0, 0.3], [0.3, 0.3, 0.3], [0.6, 0.3, 0.3], [0.6, 0, 0.3]]},
    {"name": "cube_back", "material": "m0", "emission": [1, 1, 1],
     "polygon": [[0.3, 0, 0.6], [0.6, 0, 0.6], [0.6, 0.3, 0.6], [0.3, 0.3, 0.6]]}
  ])";
  if (cube_patch_size > 0.0) {
    const std::string tag = R"("material": "m0",)";
    const std::string sized = tag + R"( "patch_size": )" + std::to_string(cube_patch_size) + ",";
    for (auto at = cube.find(tag); at != std::string::npos; at = cube.find(tag, at + sized.size()))
      cube.replace(at, tag.size(), sized);
  }
  return with_objects(box, cube);
}

TEST(FormFactors, BuriedPartsOfPatchesAreLeftOut) {
  auto sys = build_system(World::build(test::scene_from_json(box_with_block(0.5))));
  const auto& ps = sys->patches();
  ObjectId floor = sys->scene().find_object("floor");
  for (PatchId i = 0; i < static_cast<PatchId>(ps.size()); ++i) {
    const double exposed = sys->form_factors.area[i];
    if (ps[i].object == floor) {
      // Exact: the floor patch minus its overlap with the footprint [0.3, 0.6]^2.
      Vec3 lo = ps[i].corner[0].cwiseMin(ps[i].corner[2]),
           hi = ps[i].corner[0].cwiseMax(ps[i].corner[2]);
      double ox = std::max(0.0, std::min(hi.x(), 0.6) - std::max(lo.x(), 0.3));
      double oz = std::max(0.0, std::min(hi.z(), 0.6) - std::max(lo.z(), 0.3));
      // 32 x 32 test points on a patch crossed by two footprint edges: 2 / 32 of its area.
      EXPECT_NEAR(exposed, ps[i].area - ox * oz, ps[i].area * 2.0 / 32.0) << "floor patch " << i;
    }
    // Every surface light reaches sees a closed world: rows sum to 1. Fully exposed rows carry
    // the noise of 4 shadow rays per point where the cube hides part of a patch (0.6 percent
    // seen); rows of partly buried patches also the resolution at which the quadrature points
    // see the buried edge (3 percent seen; 18 percent before the per-pair normalisation).
    if (exposed >= ps[i].area) {
      EXPECT_NEAR(sys->form_factors.row_sum(i), 1.0, 0.01) << "patch " << i;
    } else if (exposed > 0.0) {
      EXPECT_NEAR(sys->form_factors.row_sum(i), 1.0, 0.04) << "partly buried patch " << i;
    }
  }
}

// A partly buried floor patch integrated as the outer patch of a pair whose partner's plane cuts
// it: the block's faces are single patches larger than the floor's, so the floor patches are
// the smaller, outer ones. The block's side cuts off exactly the buried part, so that pair's
// region is wholly exposed; scaling it by the whole patch's exposed fraction, as polyrad once
// did, took rows down to 0.7.
TEST(FormFactors, PartlyBuriedRowsSumToOneWhereABlocksSideCutsThem) {
  auto sys = build_system(World::build(test::scene_from_json(box_with_block(0.5, 1.0))));
  const auto& ps = sys->patches();
  ASSERT_GT(ps[ps.size() - 1].area, ps[0].area);  // the block's faces are the larger patches
  int partly = 0;
  for (PatchId i = 0; i < static_cast<PatchId>(ps.size()); ++i) {
    const double exposed = sys->form_factors.area[i];
    if (exposed <= 0.0 || exposed >= ps[i].area) continue;
    ++partly;
    EXPECT_NEAR(sys->form_factors.row_sum(i), 1.0, 0.04) << "partly buried patch " << i;
  }
  EXPECT_EQ(partly, 4);  // the floor patches the footprint lies across
}

// A block in a corner, open toward the two walls and the floor it stands against: the space it
// closes holds only fronts (the walls', the floor's) and its own inside, and all of it is
// buried. Near the corner a point sees the walls with most probes, so a majority of back faces
// alone called it open.
TEST(FormFactors, ABlockInACornerBuriesTheWallsAndFloorBehindIt) {
  const std::string m = R"({"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]})";
  // [0, 0.4] x [0, 0.5] x [0, 0.4]: its top, and its sides facing +x and +z.
  const std::string block = R"(,
    {"name": "block_top", "material": "m0", "patch_size": 1,
     "polygon": [[0, 0.5, 0], [0, 0.5, 0.4], [0.4, 0.5, 0.4], [0.4, 0.5, 0]]},
    {"name": "block_x", "material": "m0", "patch_size": 1,
     "polygon": [[0.4, 0, 0], [0.4, 0.5, 0], [0.4, 0.5, 0.4], [0.4, 0, 0.4]]},
    {"name": "block_z", "material": "m0", "patch_size": 1,
     "polygon": [[0, 0, 0.4], [0.4, 0, 0.4], [0.4, 0.5, 0.4], [0, 0.5, 0.4]]}
  ])";
  auto sys = build_system(
      World::build(test::scene_from_json(with_objects(test::closed_box_json(Vec3(1, 1, 1), 0.25, m, 1.0), block))));
  const auto& ps = sys->patches();
  // The part of an axis-aligned patch inside the block, from its bounding box.
  auto hidden = [](const Patch& p) {
    Vec3 lo = p.corner[0].cwiseMin(p.corner[2]), hi = p.corner[0].cwiseMax(p.corner[2]);
    const Vec3 block_hi(0.4, 0.5, 0.4);
    double area = 1.0;
    for (int k = 0; k < 3; ++k) {
      if (hi[k] - lo[k] < 1e-12) continue;  // the patch's normal axis
      area *= std::max(0.0, std::min(hi[k], block_hi[k]) - std::max(lo[k], 0.0));
    }
    return area;
  };
  int checked = 0;
  for (const char* name : {"floor", "left", "front"}) {
    const ObjectId wall = sys->scene().find_object(name);
    for (PatchId i = 0; i < static_cast<PatchId>(ps.size()); ++i) {
      if (ps[i].object != wall) continue;
      // 32 x 32 test points, at most two buried edges across the patch: 2 / 32 of its area.
      EXPECT_NEAR(sys->form_factors.area[i], ps[i].area - hidden(ps[i]), ps[i].area * 2.0 / 32.0)
          << name << " patch " << i;
      checked += hidden(ps[i]) > 0.0;
    }
  }
  EXPECT_EQ(checked, 3 * 4);  // 2 x 2 patches of each behind the block
}

TEST(FormFactors, FurnaceWithABlockIsUniformWhereLightReaches) {
  auto sys = build_system(World::build(test::scene_from_json(box_with_block(0.5))));
  SolveOptions o;
  o.tolerance = 1e-8;
  SolveResult r = solve(sys->transport, sys->transport.emission(), o);
  ASSERT_TRUE(r.ok());
  for (PatchId i = 0; i < static_cast<PatchId>(sys->patches().size()); ++i)
    // B = E + a F B: a row-sum error e moves B by a e / (1 - a)^2 = 2 e here.
    if (sys->form_factors.area[i] >= sys->patches()[i].area) {
      EXPECT_NEAR(r.u(i, 0), 2.0, 0.02) << "patch " << i;
    } else if (sys->form_factors.area[i] > 0.0) {
      EXPECT_NEAR(r.u(i, 0), 2.0, 0.08) << "partly buried patch " << i;
    }
}

}  // namespace
}  // namespace polyrad
