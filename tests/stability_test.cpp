// Where methods fail (papers/glossy-radiosity.md, section 11): albedo near 1, albedo above 1,
// leaks, long sums.
#include <gtest/gtest.h>

#include <cmath>

#include "polyrad/solve/series_precompute.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "test_support.h"

namespace polyrad {
namespace {

std::string stability_scene(const std::string& name) {
  return std::string(POLYRAD_SCENES_DIR) + "/stability/" + name + ".json";
}

std::unique_ptr<RadiositySystem> system_of(const std::string& name, bool unsafe = false) {
  SceneOptions o;
  o.allow_unsafe_albedo = unsafe;
  return build_system(World::load(stability_scene(name), {}, o));
}

Field reference(const RadiositySystem& sys) {
  SolveOptions o;
  o.method = SolveMethod::kGmres;
  o.tolerance = 1e-12;
  SolveResult r = solve(sys.transport, sys.transport.emission(), o);
  EXPECT_TRUE(r.ok()) << r.message;
  return r.u;
}

// Products needed to reach relative error 1e-3 against the reference.
long long products_to(const RadiositySystem& sys, SolveMethod method, const Field& ref) {
  return measure_convergence(sys.transport, sys.transport.emission(), ref, method, 1e-3, 1, 20000)
      .products;
}

TEST(Stability, SweepsGrowAsTheAlbedoNearsOneAndTheAcceleratedMethodsDoNot) {
  for (const char* a : {"0.9", "0.99", "0.999"}) {
    auto sys = system_of(std::string("furnace-") + a);
    const double albedo = std::stod(a);
    Field ref = reference(*sys);
    long long jacobi = products_to(*sys, SolveMethod::kJacobi, ref);
    long long gs = products_to(*sys, SolveMethod::kGaussSeidel, ref);
    long long cheb = products_to(*sys, SolveMethod::kChebyshev, ref);
    // Jacobi (and the power series) needs about ln(1e-3) / ln(a) sweeps: the error after K is
    // a^(K+1) / (1 - a) times a modest factor for a furnace lit by one face.
    double predicted = std::log(1e-3) / std::log(albedo);
    EXPECT_GT(jacobi, 0.8 * predicted) << a;
    EXPECT_LT(jacobi, 1.6 * predicted) << a;
    EXPECT_LE(gs, jacobi * 0.6) << a;
    // Chebyshev: about ln(1e-3) / ln(r), r = a / (1 + sqrt(1 - a^2)), plus its radius estimate.
    double r = albedo / (1.0 + std::sqrt(1.0 - albedo * albedo));
    EXPECT_LT(cheb, 2.0 * std::log(1e-3) / std::log(r) + 12) << a;
    EXPECT_LT(cheb, jacobi) << a;
    // GMRES: a few dozen products whatever the albedo.
    SolveOptions o;
    o.method = SolveMethod::kGmres;
    o.tolerance = 1e-4;
    SolveResult g = solve(sys->transport, sys->transport.emission(), o);
    ASSERT_TRUE(g.ok()) << g.message;
    EXPECT_LT(g.iterations, 120) << a;
    EXPECT_LT(sys->transport.flux_norm(g.u - ref) / sys->transport.flux_norm(ref), 1e-3) << a;
  }
}

TEST(Stability, ChebyshevSeriesKeepsOneProductAndMeetsItsTolerance) {
  auto sys = system_of("furnace-0.99");
  const auto& t = sys->transport;
  Field ref = reference(*sys);
  SeriesOptions plain, cheb;
  plain.tolerance = cheb.tolerance = 1e-3;
  plain.output = cheb.output = SeriesOutput::kSolution;
  plain.basis = cheb.basis = SeriesBasis::kObject;
  plain.progress = cheb.progress = false;
  cheb.acceleration = SeriesAcceleration::kChebyshev;
  SeriesOperator p = precompute_series(t, *sys->world, plain);
  SeriesOperator c = precompute_series(t, *sys->world, cheb);
  auto error = [&](const SeriesOperator& q) {
    std::vector<float> e = q.column_emission(), out(3 * q.rows());
    q.apply(e.data(), out.data());
    return t.flux_norm(series_field(q, out) - ref) / t.flux_norm(ref);
  };
  EXPECT_LT(error(c), 1e-3);
  EXPECT_LT(error(p), 1e-3);
  EXPECT_LT(c.report.order * 4, p.report.order);  // 0.99: hundreds of terms against dozens
  EXPECT_EQ(c.nnz(), p.nnz());                    // the same single product at run time
}

TEST(Stability, ChebyshevFailsLoudlyOnFacingMirrors) {
  // The link operator of two mirrors is not similar to a symmetric one: its spectrum leaves the
  // real interval Chebyshev assumes, and the iteration grows. That must be a status, not NaN.
  auto sys = system_of("facing-mirrors-0.99");
  SolveOptions o;
  o.method = SolveMethod::kChebyshev;
  o.max_iterations = 400;
  SolveResult r = solve(sys->transport, sys->transport.emission(), o);
  EXPECT_NE(r.status, SolveStatus::kConverged);
  EXPECT_TRUE(r.u.allFinite());
  o.method = SolveMethod::kGaussSeidel;
  o.tolerance = 1e-6;
  EXPECT_TRUE(solve(sys->transport, sys->transport.emission(), o).ok());  // the fallback works
}

TEST(Stability, AlbedoAboveOneIsDetectedAndNamed) {
  for (const char* scene : {"unsafe-albedo", "unnormalised-lobe"}) {
    auto sys = system_of(scene, /*unsafe=*/true);
    const std::string culprit = scene == std::string("unsafe-albedo") ? "'hot'" : "'overbright'";
    for (SolveMethod m : {SolveMethod::kJacobi, SolveMethod::kGaussSeidel, SolveMethod::kGmres}) {
      SolveOptions o;
      o.method = m;
      SolveResult r = solve(sys->transport, sys->transport.emission(), o);
      EXPECT_EQ(r.status, SolveStatus::kDiverged) << scene << " " << enum_name(m);
      EXPECT_NE(r.message.find(culprit), std::string::npos) << r.message;
      EXPECT_TRUE(r.u.allFinite());
    }
    SeriesOptions so;
    so.output = SeriesOutput::kSolution;
    so.progress = false;
    try {
      precompute_series(sys->transport, *sys->world, so);
      ADD_FAILURE() << "the series of " << scene << " did not diverge";
    } catch (const NumericalError& e) {
      EXPECT_NE(std::string(e.what()).find(culprit), std::string::npos) << e.what();
    }
  }
}

TEST(Stability, TouchingAndIntersectingBoxesDoNotLeak) {
  auto sys = system_of("touching-boxes");
  const auto& t = sys->transport;
  SolveOptions o;
  o.tolerance = 1e-8;
  SolveResult r = solve(t, t.emission(), o);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(r.u.allFinite());
  double total = 0.0, inside = 0.0;
  for (PatchId i = 0; i < t.num_patches(); ++i) {
    double flux = t.flux_weight()[i] * r.u.row(i).sum();
    total += flux;
    const std::string& name = sys->scene().objects[sys->patches()[i].object].name;
    if (name.rfind("sealed_in_", 0) == 0) inside += flux;
  }
  // The sealed box's inside receives no light at all: no ray may pass its walls.
  EXPECT_EQ(inside, 0.0);
  // Where box C cuts into box A, A's faces are buried: their exposed area is (nearly) nothing.
  for (PatchId i = 0; i < t.num_patches(); ++i) {
    const Patch& p = sys->patches()[i];
    const std::string& name = sys->scene().objects[p.object].name;
    bool in_c = p.centroid.x() > 0.62 && p.centroid.x() < 0.98 && p.centroid.z() > 0.62 &&
                p.centroid.z() < 0.98 && p.centroid.y() < 0.68;
    if (name.rfind("box_a_", 0) == 0 && in_c) {
      EXPECT_LT(sys->form_factors.area[i], 0.1 * p.area) << name;
    }
  }
  EXPECT_GT(total, 0.0);
}

TEST(Stability, SliversSharingEdgesStayFiniteAndAgreeWithTheirNeighbours) {
  auto sys = system_of("slivers");
  const auto& t = sys->transport;
  SolveResult r = solve(t, t.emission(), SolveOptions{});
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(r.u.allFinite());
  for (PatchId i = 0; i < t.num_patches(); ++i) EXPECT_LE(sys->form_factors.row_sum(i), 1.01);
  // The strips 0.5 mm wide at z = 0..0.01 see what the floor next to them sees.
  double sliver = 0.0, floor = 0.0;
  int ns = 0, nf = 0;
  for (PatchId i = 0; i < t.num_patches(); ++i) {
    const std::string& name = sys->scene().objects[sys->patches()[i].object].name;
    if (name.rfind("sliver_", 0) == 0) {
      sliver += r.u(i, 0);
      ++ns;
    } else if (name == "floor_rest" && sys->patches()[i].centroid.z() < 0.2) {
      floor += r.u(i, 0);
      ++nf;
    }
  }
  ASSERT_GT(ns, 0);
  ASSERT_GT(nf, 0);
  EXPECT_NEAR(sliver / ns, floor / nf, 0.1 * floor / nf);
}

TEST(Stability, LongSumsNeedDoubleAccumulation) {
  // K = 200 terms of a furnace at albedo 0.9: the terms are computed in double; only the running
  // sum differs. Float keeps 24 bits, so 200 additions leave a relative error of about 1e-6.
  auto sys = system_of("furnace-0.9");
  const auto& t = sys->transport;
  Field ref = reference(*sys);
  Field term = t.emission(), next, sum_d = term;
  Eigen::MatrixXf sum_f = term.cast<float>();
  for (int n = 1; n <= 200; ++n) {
    t.apply(term, next);
    term.swap(next);
    sum_d += term;
    sum_f += term.cast<float>();
  }
  double err_d = t.flux_norm(sum_d - ref) / t.flux_norm(ref);
  double err_f = t.flux_norm(Field(sum_f.cast<double>()) - ref) / t.flux_norm(ref);
  EXPECT_LT(err_d, 1e-9);        // 0.9^201 / 0.1 = 6e-9 truncation, less on this furnace
  EXPECT_GT(err_f, 10 * err_d);  // float accumulation is what limits it
  EXPECT_LT(err_f, 1e-5);
  RecordProperty("relative_error_double", std::to_string(err_d));
  RecordProperty("relative_error_float", std::to_string(err_f));
}

TEST(Stability, MemoryBudgetRefusesHugeScenesUpFront) {
  // The Cornell box in half-millimetre patches: millions of them.
  try {
    build_system(load_scene(test::scene_path("cornell-box")), {.patch_size = 0.5});
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("estimated"), std::string::npos) << e.what();
  }
  SystemOptions o;
  o.max_memory_bytes = 1e6;  // 1 MB: too little even for the default mesh
  EXPECT_THROW(build_system(World::load(test::scene_path("cornell-box")), o), InputError);
}

}  // namespace
}  // namespace polyrad
