// The link transport operator against answers known exactly (papers/glossy-radiosity.md,
// section 10).
#include "polyrad/transport/transport.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include "polyrad/render/camera_gather.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/form_factors.h"
#include "polyrad/transport/mirror_chains.h"
#include "polyrad/transport/mirror_planes.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/sampling.h"
#include "test_support.h"

namespace polyrad {
namespace {

std::string grey(const char* type, double a) {
  std::ostringstream s;
  s << R"({"type": ")" << type << R"(", "reflectance": [)" << a << ", " << a << ", " << a << "]}";
  return s.str();
}

std::string half_and_half(double a) {  // diffuse a/2 plus a perfect mirror lobe a/2
  std::ostringstream s;
  double h = a / 2;
  s << R"({"type": "glossy", "diffuse": [)" << h << ", " << h << ", " << h << R"(], "specular": [)"
    << h << ", " << h << ", " << h << R"(], "roughness": 0})";
  return s.str();
}

TEST(Transport, ADiffuseSceneBuildsTheClassicSystem) {
  auto a = build_system(World::load(test::scene_path("cornell-box")));
  auto b = build_system(World::load(test::scene_path("cornell-box"), {.classic = true}));
  EXPECT_EQ(a->transport.num_links(), 0);
  EXPECT_EQ(a->transport.size(), static_cast<Eigen::Index>(a->patches().size()));
  EXPECT_EQ(a->transport.weights().value, b->transport.weights().value);
  // Against a dense direct solve of B = E + diag(d) F B.
  const auto n = static_cast<Eigen::Index>(a->patches().size());
  Eigen::MatrixXd f = Eigen::MatrixXd::Zero(n, n);
  const auto& ff = a->form_factors.f;
  for (Eigen::Index i = 0; i < n; ++i)
    for (auto k = ff.start[i]; k < ff.start[i + 1]; ++k) f(i, ff.column[k]) = ff.value[k];
  SolveOptions o;
  o.tolerance = 1e-10;
  SolveResult r = solve(a->transport, a->transport.emission(), o);
  ASSERT_TRUE(r.ok());
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd d(n), e(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      d[i] = a->scene().materials[a->patches()[i].material].diffuse[c];
      e[i] = a->patches()[i].emission[c];
    }
    Eigen::MatrixXd m = Eigen::MatrixXd::Identity(n, n) - d.asDiagonal() * f;
    Eigen::VectorXd exact = m.partialPivLu().solve(e);
    EXPECT_LT((r.u.col(c) - exact).cwiseAbs().maxCoeff(), 1e-6) << "channel " << c;
  }
}

class MixedFurnace : public ::testing::TestWithParam<double> {};

TEST_P(MixedFurnace, RadianceIsEmissionOverOneMinusAlbedoEverywhere) {
  const double a = GetParam();
  auto dir = test::temp_dir();
  std::string path = test::write_file(
      dir, "box.json",
      test::closed_box_json(Vec3(1, 1.2, 0.9), 0.3,
                            {grey("diffuse", a), grey("mirror", a), half_and_half(a),
                             grey("mirror", a), grey("diffuse", a), half_and_half(a)},
                            1.0));
  auto sys = build_system(World::load(path));
  const auto& t = sys->transport;
  ASSERT_GT(t.num_links(), 0);
  SolveOptions o;
  o.tolerance = 1e-8;
  SolveResult r = solve(t, t.emission(), o);
  ASSERT_TRUE(r.ok()) << r.message;
  const double expect = 1.0 / (1.0 - a);
  // Radiance leaving i toward k: L_{i->k} = B_i + S_{i->k} on every stored link ...
  for (LinkId l = 0; l < t.num_links(); ++l) {
    const Link& link = t.links()[l];
    double radiance = r.u(link.from, 0) + r.u(t.num_patches() + l, 0);
    ASSERT_NEAR(radiance, expect, 5e-3 * expect)
        << "link " << link.from << "->" << link.to << " B " << r.u(link.from, 0) << " objects "
        << sys->patches()[link.from].object << "->" << sys->patches()[link.to].object;
  }
  // ... and B on every patch without a lobe.
  for (PatchId i = 0; i < t.num_patches(); ++i) {
    if (!sys->scene().materials[sys->patches()[i].material].has_lobe()) {
      ASSERT_NEAR(r.u(i, 0), expect, 5e-3 * expect) << "patch " << i;
    }
  }
  // The camera, inside the box, sees the same radiance in every pixel.
  Gather g = build_gather(*sys->world, t.layout());
  Image img = apply_gather(g, r.u);
  for (float v : img.rgb) ASSERT_NEAR(v, expect, 5e-3 * expect);
}

INSTANTIATE_TEST_SUITE_P(Albedo, MixedFurnace, ::testing::Values(0.5, 0.9));

// B of the receiver after two sweeps (lamp -> mirror -> receiver, nothing more).
double receiver_first_bounce(const std::string& json, int samples) {
  SystemOptions so;
  so.specular.samples = samples;
  auto sys = build_system(World::build(test::scene_from_json(json)), so);
  SolveOptions o;
  o.method = SolveMethod::kJacobi;
  o.fixed_sweeps = 2;
  SolveResult r = solve(sys->transport, sys->transport.emission(), o);
  ObjectId rec = sys->scene().find_object("receiver");
  for (PatchId i = 0; i < static_cast<PatchId>(sys->patches().size()); ++i)
    if (sys->patches()[i].object == rec) return r.u(i, 0);
  return -1.0;
}

TEST(Transport, MirrorImageOfTheLamp) {
  // Receiver [0.8, 1.2] x [-0.2, 0.2] at y = 1 sees the lamp's image [-1.2, -0.8] x [-0.2, 0.2]
  // at y = -1 across the gap of 2: B = d * rho * E * F(receiver -> image).
  double f = test::parallel_offset_rectangles_ff(0.8, 1.2, -0.2, 0.2, -1.2, -0.8, -0.2, 0.2, 2.0);
  double expect = 0.5 * 0.8 * 1.0 * f;
  double b = receiver_first_bounce(test::mirror_floor_json(0.8, 1.2, -2, 2, -1, 1), 64);
  EXPECT_NEAR(b, expect, 0.01 * expect);
}

// Monte Carlo of d * rho * E * F through a mirror aperture, independent of polyrad's code:
// point pairs between the receiver and the lamp's image; a pair counts if the segment crosses
// y = 0 inside the mirror rectangle.
double aperture_reference(double rx0, double rx1, double mx0, double mx1, double mz0, double mz1) {
  const int n = 48;
  double sum = 0.0;
  for (int a = 0; a < n * n; ++a)
    for (int b = 0; b < n * n; ++b) {
      Vec3 x(rx0 + (rx1 - rx0) * (a % n + 0.5) / n, 1.0, -0.2 + 0.4 * (a / n + 0.5) / n);
      Vec3 y(-1.2 + 0.4 * (b % n + 0.5) / n, -1.0, -0.2 + 0.4 * (b / n + 0.5) / n);
      Vec3 d = y - x;
      Vec3 m = 0.5 * (x + y);  // where the segment crosses y = 0
      if (m.x() < mx0 || m.x() > mx1 || m.z() < mz0 || m.z() > mz1) continue;
      double r2 = d.squaredNorm();
      sum += (d.y() * d.y() / r2) / (kPi * r2);
    }
  double area_image = 0.16;
  return 0.5 * 0.8 * sum * area_image / (n * n * static_cast<double>(n * n));
}

TEST(Transport, AsymmetricMirrorSendsLightOneWayOnly) {
  // A small mirror at the origin sends the lamp's light to the right (x > 0) and nowhere else:
  // a wrong j/i/k order in the transfer would light the receiver on the lamp's side instead.
  double right = receiver_first_bounce(test::mirror_floor_json(0.8, 1.2, -0.3, 0.1, -0.3, 0.3), 64);
  double left =
      receiver_first_bounce(test::mirror_floor_json(-2.2, -1.8, -0.3, 0.1, -0.3, 0.3), 64);
  double expect = aperture_reference(0.8, 1.2, -0.3, 0.1, -0.3, 0.3);
  EXPECT_GT(expect, 0.0);
  EXPECT_NEAR(right, expect, 0.03 * expect);
  EXPECT_EQ(left, 0.0);
}

TEST(Transport, EnergyShrinksGeometricallyWithMirrors) {
  auto sys = build_system(World::load(test::scene_path("cornell-mirror-cube")));
  SolveOptions o;
  o.method = SolveMethod::kJacobi;
  o.tolerance = 1e-8;
  SolveResult r = solve(sys->transport, sys->transport.emission(), o);
  ASSERT_TRUE(r.ok());
  ASSERT_GT(r.sweep_residual.size(), 5u);
  for (size_t k = 1; k < r.sweep_residual.size(); ++k)
    EXPECT_LE(r.sweep_residual[k],
              sys->transport.max_albedo() * r.sweep_residual[k - 1] * (1 + 1e-3));
}

// Eq. 9 on the mirror cube: every row of every reflector's balanced transfer meets its
// stationarity condition within the balance's tolerance (1e-9), and no source sends a reflector
// more than all its flux (sum_k R_jik <= 1). Most of the cube's reflectors take Newton steps
// (their coordinate ascent has not settled after 30 sweeps): this checks where those land. The
// ascent alone, stopped at 3,000 sweeps, left 1.5e-9 here.
TEST(Transport, MirrorCubeTransferIsSettledAndConservesEnergy) {
  auto sys = build_system(World::load(test::scene_path("cornell-mirror-cube")));
  const SpecularTransfer& st = sys->specular;
  EXPECT_LT(st.stats.balance_mismatch, 1e-9);
  const auto n = static_cast<PatchId>(sys->patches().size());
  long long rows = 0;
  for (PatchId i = 0; i < n; ++i) {
    std::map<PatchId, double> sent;  // j -> sum_k R_jik
    for (auto e = st.start[i]; e < st.start[i + 1]; ++e) sent[st.from[e]] += st.fraction[e];
    for (const auto& [j, sum] : sent) {
      ASSERT_LE(sum, 1.0 + 1e-5) << "reflector " << i << ", source " << j;
      ++rows;
    }
  }
  EXPECT_GT(rows, 1000);
}

TEST(Transport, MirrorCubeLinksOnlyWhereSpecularLightGoes) {
  auto sys = build_system(World::load(test::scene_path("cornell-mirror-cube")));
  const auto& t = sys->transport;
  ObjectId cube = sys->scene().find_object("short_block");
  for (const Link& l : t.links()) ASSERT_EQ(sys->patches()[l.from].object, cube);
  // The cube's patches link to at most the patches they see.
  EXPECT_LE(t.num_links(), static_cast<int>(sys->form_factors.f.nnz()));
  EXPECT_GT(t.num_links(), 1000);
}

}  // namespace
}  // namespace polyrad

namespace polyrad {
namespace {

TEST(Transport, OnTheFlySpecularGivesTheStoredAnswerWithLessMemory) {
  SystemOptions fly_options;
  fly_options.specular_on_the_fly = true;
  // Patch size 100 (240 patches): the answer is the same at any size, and the solve on the fly
  // at the scene's own size took 100 s under the sanitizers.
  const auto world = World::load(test::scene_path("cornell-mirror-cube"), {.patch_size = 100});
  auto stored = build_system(world);
  auto fly = build_system(world, fly_options);
  ASSERT_TRUE(fly->transport.on_the_fly());
  EXPECT_EQ(fly->transport.num_links(), stored->transport.num_links());
  EXPECT_EQ(fly->transport.nnz_specular(), 0);
  EXPECT_LT(fly->transport.bytes() + fly->specular.bytes(),
            stored->transport.bytes() + stored->specular.bytes());
  // One Jacobi application and a Gauss-Seidel solve agree with the stored operator.
  Field e = stored->transport.emission(), a, b;
  stored->transport.apply(e, a);
  fly->transport.apply(e, b);
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9 * a.cwiseAbs().maxCoeff());
  SolveResult rs = solve(stored->transport, e, SolveOptions{});
  SolveResult rf = solve(fly->transport, e, SolveOptions{});
  ASSERT_TRUE(rs.ok() && rf.ok());
  EXPECT_EQ(rs.iterations, rf.iterations);
  EXPECT_LT((rs.u - rf.u).cwiseAbs().maxCoeff(), 1e-9 * rs.u.cwiseAbs().maxCoeff());
}

// ---- mirror planes: which face which ---------------------------------------------------------

// The planes a chain of mirror images may go between (MirrorPlanes::Plane::facing): a room's
// four mirror walls each face the other three, two mirrors back to back face neither, and no
// two faces of a convex mirror face each other, even where the faces are not along the axes
// (their boxes reach past them: a test of the boxes' corners listed each face of this prism as
// facing one or two of its neighbours).
TEST(MirrorPlanes, FacingPlanesAreThoseAPathCanGoBetween) {
  const std::vector<Material> mirror{Material::mirror("mirror", Rgb(0.9, 0.9, 0.9))};
  // A quad from a to b (corners at heights 0 and 1) facing toward `inside` or away from it.
  const auto wall = [](const Vec3& a, const Vec3& b, const Vec3& inside, bool inward) {
    Patch p = test::make_quad(a, b, b + Vec3(0, 1, 0), a + Vec3(0, 1, 0));
    if ((p.normal.dot(inside - p.centroid) > 0.0) != inward)
      p = test::make_quad(b, a, a + Vec3(0, 1, 0), b + Vec3(0, 1, 0));
    return p;
  };
  const auto facing_counts = [&](std::vector<Patch> patches) {
    const MirrorPlanes m = mirror_planes(test::make_patch_set(std::move(patches)), mirror, true);
    std::vector<std::size_t> counts;
    for (const auto& plane : m.planes) counts.push_back(plane.facing.size());
    return counts;
  };
  const Vec3 centre(0.5, 0.5, 0.5);
  const std::vector<Vec3> square{{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}};
  std::vector<Patch> room, box;
  for (int k = 0; k < 4; ++k) {
    room.push_back(wall(square[k], square[(k + 1) % 4], centre, true));
    box.push_back(wall(square[k], square[(k + 1) % 4], centre, false));
  }
  EXPECT_EQ(facing_counts(room), (std::vector<std::size_t>{3, 3, 3, 3}));
  EXPECT_EQ(facing_counts(box), (std::vector<std::size_t>{0, 0, 0, 0}));
  const std::vector<Patch> back_to_back{wall({0, 0, 0}, {0, 0, 1}, {-1, 0, 0.5}, true),
                                        wall({0.01, 0, 0}, {0.01, 0, 1}, {1, 0, 0.5}, true)};
  EXPECT_EQ(facing_counts(back_to_back), (std::vector<std::size_t>{0, 0}));
  std::vector<Patch> prism;  // 24 faces turned a quarter of a face off the axes
  for (int k = 0; k < 24; ++k) {
    const auto at = [](double t) { return Vec3(std::cos(t), 0.0, std::sin(t)); };
    const double step = 2.0 * kPi / 24;
    prism.push_back(wall(at((k + 0.25) * step), at((k + 1.25) * step), Vec3::Zero(), false));
  }
  EXPECT_EQ(facing_counts(prism), std::vector<std::size_t>(24, 0));
}

// The chains of mirror planes from a point (transport/mirror_chains.h), in a room of four mirror
// walls 0.4 wide and 1 high, its floor and ceiling not mirrors. Every sequence of walls that a
// ray from the point meets, traced here on its own, must be a chain kept: the beams may only
// prune sequences that no line can take. And they must prune: a straight line crosses the
// unfolded walls of one axis in turn (west, east, west ... going west), so of the 4 x 3 x 3
// sequences of three walls only those that alternate on each axis are paths.
TEST(MirrorChains, EveryPathARayTakesIsAChainKeptAndNoOther) {
  const std::vector<Material> mirror{Material::mirror("mirror", Rgb(0.9, 0.9, 0.9))};
  const auto wall = [](const Vec3& a, const Vec3& b) {  // facing the room's centre
    Patch p = test::make_quad(a, b, b + Vec3(0, 1, 0), a + Vec3(0, 1, 0));
    if (p.normal.dot(Vec3(0.2, 0.5, 0.2) - p.centroid) < 0.0)
      p = test::make_quad(b, a, a + Vec3(0, 1, 0), b + Vec3(0, 1, 0));
    return p;
  };
  const std::vector<Vec3> square{{0, 0, 0}, {0.4, 0, 0}, {0.4, 0, 0.4}, {0, 0, 0.4}};
  std::vector<Patch> walls;
  for (int k = 0; k < 4; ++k) walls.push_back(wall(square[k], square[(k + 1) % 4]));
  const MirrorPlanes m = mirror_planes(test::make_patch_set(std::move(walls)), mirror, true);
  ASSERT_EQ(m.planes.size(), 4u);
  // The walls a ray from x along d meets, up to `length` of them, before it leaves by the floor
  // or the ceiling.
  const auto trace = [&](Vec3 x, Vec3 d, int length) {
    std::vector<std::int32_t> met;
    while (static_cast<int>(met.size()) < length) {
      double t_min = 1e300;
      std::int32_t hit = -1;
      for (std::int32_t q = 0; q < 4; ++q) {
        const auto& plane = m.planes[static_cast<std::size_t>(q)];
        const double toward = -plane.normal.dot(d);
        if (!(toward > 0.0)) continue;
        const double t = plane.height(x) / toward;
        if (t < t_min) t_min = t, hit = q;
      }
      x += t_min * d;
      if (x.y() < 0.0 || x.y() > 1.0) break;
      met.push_back(hit);
      d = reflect_in_plane(d, m.planes[static_cast<std::size_t>(hit)].normal);
    }
    return met;
  };
  Rng rng(7);
  int compared = 0;
  for (int point = 0; point < 8; ++point) {
    const Vec3 x(0.02 + 0.36 * rng.uniform(), 0.1 + 0.8 * rng.uniform(),
                 0.02 + 0.36 * rng.uniform());
    const MirrorChains chains = mirror_chains(m, x, 4, 100000);
    ASSERT_EQ(chains.depth, 4);
    std::vector<int> kept(5, 0), seen_count(5, 0);
    for (const auto& c : chains.chains) ++kept[static_cast<std::size_t>(c.length)];
    EXPECT_EQ(kept[1], 4);
    EXPECT_EQ(kept[2], 12);  // through any wall to any other
    std::set<std::vector<std::int32_t>> seen;
    for (int r = 0; r < 20000; ++r) {
      const double phi = 2.0 * kPi * rng.uniform(), cos_t = 2.0 * rng.uniform() - 1.0;
      const double sin_t = std::sqrt(1.0 - cos_t * cos_t);
      const std::vector<std::int32_t> met =
          trace(x, Vec3(sin_t * std::cos(phi), cos_t, sin_t * std::sin(phi)), 4);
      std::int32_t at = -1;
      for (std::size_t k = 0; k < met.size(); ++k) {
        at = chains.next(at, met[k]);
        ASSERT_GE(at, 0) << "a path through " << k + 1 << " walls is no chain kept";
        if (seen.insert(std::vector<std::int32_t>(met.begin(), met.begin() + k + 1)).second)
          ++seen_count[k + 1];
      }
    }
    std::printf("chains from point %d: kept %d %d %d %d, met by rays %d %d %d %d\n", point, kept[1],
                kept[2], kept[3], kept[4], seen_count[1], seen_count[2], seen_count[3],
                seen_count[4]);
    EXPECT_LT(kept[3], 36);
    for (int n = 1; n <= 4; ++n)  // no chain kept that no ray takes (4, 12, 24, 40)
      EXPECT_EQ(kept[static_cast<std::size_t>(n)], seen_count[static_cast<std::size_t>(n)]) << n;
    compared += seen_count[4];
  }
  EXPECT_GT(compared, 8 * 20);
}

// The budget keeps whole levels: every chain up to the depth kept, none beyond, and no more
// chains of two or more than the budget; two facing mirrors alone give one chain a plane and
// length, back and forth.
TEST(MirrorChains, BudgetKeepsWholeLevels) {
  const std::vector<Material> mirror{Material::mirror("mirror", Rgb(0.9, 0.9, 0.9))};
  const auto room = [&](int walls) {
    const std::vector<Vec3> square{{0, 0, 0}, {0.4, 0, 0}, {0.4, 0, 0.4}, {0, 0, 0.4}};
    std::vector<Patch> patches;
    for (const int k : walls == 2 ? std::vector<int>{0, 2} : std::vector<int>{0, 1, 2, 3}) {
      const Vec3 a = square[static_cast<std::size_t>(k)],
                 b = square[static_cast<std::size_t>((k + 1) % 4)];
      Patch p = test::make_quad(a, b, b + Vec3(0, 1, 0), a + Vec3(0, 1, 0));
      if (p.normal.dot(Vec3(0.2, 0.5, 0.2) - p.centroid) < 0.0)
        p = test::make_quad(b, a, a + Vec3(0, 1, 0), b + Vec3(0, 1, 0));
      patches.push_back(p);
    }
    return mirror_planes(test::make_patch_set(std::move(patches)), mirror, true);
  };
  const Vec3 x(0.13, 0.3, 0.21);
  const MirrorPlanes four = room(4);
  const MirrorChains all = mirror_chains(four, x, 8, 1000000);
  ASSERT_EQ(all.depth, 8);
  const auto count = [](const MirrorChains& c, int up_to) {
    return std::count_if(c.chains.begin(), c.chains.end(),
                         [&](const auto& k) { return k.length >= 2 && k.length <= up_to; });
  };
  for (std::size_t budget : {10u, 40u, 100u, 400u}) {
    const MirrorChains some = mirror_chains(four, x, 8, budget);
    EXPECT_LE(count(some, 8), static_cast<long>(budget));
    EXPECT_EQ(count(some, 8), count(all, some.depth));  // whole levels
    if (some.depth < 8) {
      EXPECT_GT(count(all, some.depth + 1), static_cast<long>(budget));  // the next did not fit
    }
  }
  // Two facing walls: 2 (n - 1) chains of 2 to n, each alternating.
  const MirrorChains two = mirror_chains(room(2), x, 16, 256);
  EXPECT_EQ(two.depth, 16);
  EXPECT_EQ(count(two, 16), 2 * 15);
  std::array<std::int32_t, 16> planes{};
  for (std::int32_t at = 0; at < static_cast<std::int32_t>(two.chains.size()); ++at) {
    two.planes_of(at, planes.data());
    for (int k = 1; k < two.chains[static_cast<std::size_t>(at)].length; ++k)
      EXPECT_NE(planes[static_cast<std::size_t>(k)], planes[static_cast<std::size_t>(k - 1)]);
  }
}

// ---- facing mirrors: the floor's light is the sum over the lamp's images ---------------------

// The corridor of test::facing_mirrors_black(), whose floor's light is exactly a sum over the
// lamp's images.
// Links between patches forget where on a patch a ray met the mirror: each bounce spreads the
// light over the directions between the two patches, so what meets many mirrors strays to the
// black faces and the floor is dark, by less as the patches shrink (5.6 percent at 0.1, 3.1 at
// 0.05, 1.0 at 0.025, measured). One mirror alone is exact (MirrorImageOfTheLamp).
TEST(Transport, FacingMirrorsLightTheFloorAsTheLampsImagesAsPatchesShrink) {
  const double exact = test::facing_mirrors_floor_mean();
  const Scene scene = test::facing_mirrors_black();
  double previous = 1.0;
  for (double size : test::refinement_steps(std::vector<double>{0.1, 0.05})) {
    auto sys = build_system(World::build(scene, {.patch_size = size}));
    const SolveResult r = solve(sys->transport, sys->transport.emission(), SolveOptions{});
    ASSERT_TRUE(r.ok()) << r.message;
    const ObjectId floor = scene.find_object("floor");
    double flux = 0.0, area = 0.0;
    for (PatchId i = 0; i < static_cast<PatchId>(sys->patches().size()); ++i)
      if (sys->patches()[i].object == floor) {
        flux += sys->patches()[i].area * r.u(i, 1);
        area += sys->patches()[i].area;
      }
    EXPECT_LT(flux / area, exact);  // light strays from the floor, none is made
    const double error = std::abs(flux / area / exact - 1.0);
    std::printf("patches %g: floor %.6g, exact %.6g, %.2f%% off\n", size, flux / area, exact,
                100.0 * error);
    EXPECT_LT(error, 0.07);
    EXPECT_LT(error, 0.65 * previous);  // it falls as the patches shrink
    previous = error;
  }
}

}  // namespace
}  // namespace polyrad
