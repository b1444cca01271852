// The plain iterative solver: furnace answers, agreement of the two methods, statuses.
#include "polyrad/solve/solver.h"

#include <gtest/gtest.h>

#include "polyrad/transport/system.h"
#include "test_support.h"

namespace polyrad {
namespace {

std::unique_ptr<RadiositySystem> furnace(double albedo, double patch_size = 0.25,
                                         bool unsafe = false) {
  std::string m = R"({"type": "diffuse", "reflectance": [)" + std::to_string(albedo) + ", " +
                  std::to_string(albedo) + ", " + std::to_string(albedo) + "]}";
  auto dir = test::temp_dir();
  std::string path = test::write_file(dir, "furnace.json",
                                      test::closed_box_json(Vec3(1, 1, 1), patch_size, m, 1.0));
  SceneOptions options;
  options.allow_unsafe_albedo = unsafe;
  return build_system(World::load(path, {}, options));
}

class Furnace : public ::testing::TestWithParam<std::tuple<double, SolveMethod>> {};

TEST_P(Furnace, RadiosityIsEmissionOverOneMinusAlbedo) {
  auto [albedo, method] = GetParam();
  auto sys = furnace(albedo);
  SolveOptions o;
  o.method = method;
  o.tolerance = 1e-7;
  SolveResult r = solve(sys->transport, sys->transport.emission(), o);
  ASSERT_TRUE(r.ok()) << r.message;
  double expect = 1.0 / (1.0 - albedo);
  for (Eigen::Index i = 0; i < r.u.rows(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.u(i, c), expect, 5e-3 * expect) << "patch " << i;
}

INSTANTIATE_TEST_SUITE_P(AlbedoAndMethod, Furnace,
                         ::testing::Combine(::testing::Values(0.5, 0.9),
                                            ::testing::Values(SolveMethod::kJacobi,
                                                              SolveMethod::kGaussSeidel)));

TEST(Solver, JacobiAndGaussSeidelAgreeOnTheCornellBox) {
  auto sys = build_system(World::load(test::scene_path("cornell-box")));
  for (double tol : {1e-3, 1e-6}) {
    SolveOptions o;
    o.tolerance = tol;
    o.method = SolveMethod::kJacobi;
    SolveResult j = solve(sys->transport, sys->transport.emission(), o);
    o.method = SolveMethod::kGaussSeidel;
    SolveResult g = solve(sys->transport, sys->transport.emission(), o);
    ASSERT_TRUE(j.ok() && g.ok());
    EXPECT_LT(g.iterations, j.iterations);
    // Each is within (residual / (1 - a_max)) of the solution; so they are within twice that.
    double bound = 2.0 * tol / (1.0 - sys->transport.max_albedo());
    double diff = sys->transport.flux_norm(j.u - g.u) / sys->transport.flux_norm(g.u);
    EXPECT_LT(diff, bound) << "tolerance " << tol;
    EXPECT_LT(j.residual, tol);
    EXPECT_LT(g.residual, tol);
  }
}

TEST(Solver, JacobiSweepsAreThePowerSeries) {
  auto sys = build_system(World::load(test::scene_path("cornell-box")));
  const auto& t = sys->transport;
  Field e = t.emission();
  Field term = e, sum = e, next;
  for (int k = 1; k <= 12; ++k) {
    t.apply(term, next);
    term = next;
    sum += term;
  }
  SolveOptions o;
  o.method = SolveMethod::kJacobi;
  o.fixed_sweeps = 12;
  SolveResult r = solve(t, e, o);
  EXPECT_EQ(r.iterations, 12);
  EXPECT_LT((r.u - sum).cwiseAbs().maxCoeff(), 1e-12 * sum.cwiseAbs().maxCoeff());
}

TEST(Solver, EnergyOfEachSweepShrinksGeometrically) {
  auto sys = build_system(World::load(test::scene_path("cornell-box")));
  SolveOptions o;
  o.method = SolveMethod::kJacobi;
  o.tolerance = 1e-8;
  SolveResult r = solve(sys->transport, sys->transport.emission(), o);
  ASSERT_TRUE(r.ok());
  // ||T^n e|| in the flux norm shrinks by at most the largest albedo per sweep (section 5).
  for (size_t k = 1; k < r.sweep_residual.size(); ++k)
    EXPECT_LE(r.sweep_residual[k],
              sys->transport.max_albedo() * r.sweep_residual[k - 1] * (1 + 1e-6));
}

TEST(Solver, DivergenceIsAStatusNotNaN) {
  auto sys = furnace(1.2, 0.5, /*unsafe=*/true);
  SolveResult r = solve(sys->transport, sys->transport.emission(), SolveOptions{});
  EXPECT_EQ(r.status, SolveStatus::kDiverged);
  EXPECT_NE(r.message.find("material 'm0'"), std::string::npos) << r.message;  // names the culprit
  EXPECT_TRUE(r.u.allFinite());
}

TEST(Solver, SweepLimitIsNotConvergence) {
  auto sys = furnace(0.9, 0.5);
  SolveOptions o;
  o.max_iterations = 3;
  o.tolerance = 1e-9;
  SolveResult r = solve(sys->transport, sys->transport.emission(), o);
  EXPECT_EQ(r.status, SolveStatus::kNotConverged);
  EXPECT_EQ(r.iterations, 3);
  EXPECT_GT(r.residual, 1e-9);
  EXPECT_FALSE(r.message.empty());
}

TEST(Solver, NoEmissionGivesBlack) {
  auto sys = furnace(0.5, 0.5);
  Field e = Field::Zero(sys->transport.size(), 3);
  SolveResult r = solve(sys->transport, e, SolveOptions{});
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.u.cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace polyrad
