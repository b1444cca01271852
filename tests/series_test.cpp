// The precomputed power series against the iterative solver and the bounds of
// papers/glossy-radiosity.md, section 5.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>

#include "polyrad/io/prt_file.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "test_support.h"

namespace polyrad {
namespace {

std::unique_ptr<RadiositySystem> system_of(const std::string& name) {
  return build_system(World::load(test::scene_path(name)));
}

SeriesOperator solution_series(const RadiositySystem& sys, int order,
                               SeriesBasis basis = SeriesBasis::kPatch,
                               ValuePrecision precision = ValuePrecision::kFloat,
                               double drop = 0.0) {
  SeriesOptions o;
  o.order = order;
  o.output = SeriesOutput::kSolution;
  o.basis = basis;
  o.precision = precision;
  o.drop = drop;
  o.progress = false;
  return precompute_series(sys.transport, *sys.world, o);
}

Field product(const SeriesOperator& q, const std::map<std::string, Rgb>& lights = {}) {
  std::vector<float> e = q.column_emission(lights), out(3 * q.rows());
  q.apply(e.data(), out.data());
  return series_field(q, out);
}

Field converged(const RadiositySystem& sys) {
  SolveOptions o;
  o.tolerance = 1e-12;
  SolveResult r = solve(sys.transport, sys.transport.emission(), o);
  EXPECT_TRUE(r.ok());
  return r.u;
}

TEST(Series, OrderKProductIsKJacobiSweeps) {
  for (const char* scene : {"cornell-box", "cornell-mirror-cube"}) {
    auto sys = system_of(scene);
    for (int k : {0, 1, 7}) {
      Field u = product(solution_series(*sys, k));
      SolveOptions o;
      o.method = SolveMethod::kJacobi;
      o.fixed_sweeps = k;
      Field jacobi = solve(sys->transport, sys->transport.emission(), o).u;
      // The operator is stored in float: rounding of 2^-24 per entry, summed over a row.
      double scale = jacobi.cwiseAbs().maxCoeff();
      EXPECT_LT((u - jacobi).cwiseAbs().maxCoeff(), 1e-6 * scale) << scene << " K " << k;
    }
  }
}

TEST(Series, ErrorFallsWithOrderUnderTheAprioriBound) {
  for (const char* scene : {"cornell-box", "cornell-mirror-cube"}) {
    auto sys = system_of(scene);
    const auto& t = sys->transport;
    Field exact = converged(*sys);
    const double e_norm = t.flux_norm(t.emission()), a = t.max_albedo();
    double previous = INFINITY;
    // Order 40 in Release; the sanitizers stop at 10 (test::refinement_steps says why).
    const int last = test::kUnderAddressSanitizer ? 10 : 40;
    for (int k = 0; k <= last; ++k) {
      SeriesOperator q = solution_series(*sys, k, SeriesBasis::kObject);
      double error = t.flux_norm(product(q) - exact) / e_norm;
      double bound = std::pow(a, k + 1) / (1.0 - a);
      EXPECT_LE(error, bound) << scene << " K " << k;
      EXPECT_DOUBLE_EQ(q.report.apriori_bound, bound);
      // Falls with K until float rounding of the stored operator (about 1e-7) is reached.
      if (previous > 1e-6) {
        EXPECT_LT(error, previous) << scene << " K " << k;
      }
      previous = error;
    }
  }
}

TEST(Series, ToleranceIsMet) {
  for (const char* scene : {"cornell-box", "cornell-mirror-cube"}) {
    auto sys = system_of(scene);
    const auto& t = sys->transport;
    Field exact = converged(*sys);
    for (double tol : {3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4}) {
      SeriesOptions o;
      o.tolerance = tol;
      o.output = SeriesOutput::kSolution;
      o.basis = SeriesBasis::kObject;
      o.progress = false;
      SeriesOperator q = precompute_series(t, *sys->world, o);
      double error = t.flux_norm(product(q) - exact) / t.flux_norm(exact);
      EXPECT_LT(error, tol) << scene << " tolerance " << tol << " K " << q.report.order;
      EXPECT_GT(q.report.order, 0);
    }
  }
}

// The Cornell box with its lamp split in two lights, so that lights can be set apart.
Scene two_lights() {
  std::ifstream in(test::scene_path("cornell-box"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto at = text.find(R"({"name": "light")");
  text.replace(
      at, std::string::npos,
      R"({"name": "left_lamp", "material": "lamp", "emission": [17, 12, 4], "patch_size": 20,
     "polygon": [[343, 548.3, 227], [343, 548.3, 332], [278, 548.3, 332], [278, 548.3, 227]]},
    {"name": "right_lamp", "material": "lamp", "emission": [4, 12, 17], "patch_size": 20,
     "polygon": [[278, 548.3, 227], [278, 548.3, 332], [213, 548.3, 332], [213, 548.3, 227]]}
  ]
})");
  auto dir = test::temp_dir();
  test::write_file(
      dir, "meshes/short_block.obj",
      std::string(
          std::istreambuf_iterator<char>(
              std::ifstream(std::string(POLYRAD_SCENES_DIR) + "/meshes/short_block.obj").rdbuf()),
          {}));
  test::write_file(
      dir, "meshes/tall_block.obj",
      std::string(
          std::istreambuf_iterator<char>(
              std::ifstream(std::string(POLYRAD_SCENES_DIR) + "/meshes/tall_block.obj").rdbuf()),
          {}));
  return test::scene_from_json(text, dir);
}

TEST(Series, RelightingIsLinear) {
  auto sys = build_system(World::build(two_lights()));
  SeriesOperator q = solution_series(*sys, 12);
  const Rgb a(3, 2, 1), b(0.5, 4, 2), off(0, 0, 0);
  Field left = product(q, {{"left_lamp", a}, {"right_lamp", off}});
  Field right = product(q, {{"left_lamp", off}, {"right_lamp", b}});
  Field both = product(q, {{"left_lamp", a}, {"right_lamp", b}});
  double scale = both.cwiseAbs().maxCoeff();
  EXPECT_LT((both - left - right).cwiseAbs().maxCoeff(), 1e-5 * scale);
  Field doubled = product(q, {{"left_lamp", 2.0 * a}, {"right_lamp", off}});
  EXPECT_LT((doubled - 2.0 * left).cwiseAbs().maxCoeff(), 1e-5 * scale);
  Field dark = product(q, {{"left_lamp", off}, {"right_lamp", off}});
  EXPECT_EQ(dark.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(left.col(0).sum(), left.col(2).sum());  // the warm lamp alone is red-heavy
  EXPECT_THROW(q.column_emission({{"nonexistent", a}}), InputError);
}

TEST(Series, DroppedEnergyBoundsTheChange) {
  auto sys = system_of("cornell-mirror-cube");
  const auto& w = sys->transport.flux_weight();
  Field full = product(solution_series(*sys, 10));
  for (double drop : {1e-4, 1e-3, 1e-2}) {
    SeriesOperator q = solution_series(*sys, 10, SeriesBasis::kPatch, ValuePrecision::kFloat, drop);
    Field dropped = product(q);
    double change = 0.0, total = 0.0;
    for (Eigen::Index r = 0; r < full.rows(); ++r) {
      change += w[r] * (full.row(r) - dropped.row(r)).cwiseAbs().sum();
      total += w[r] * full.row(r).cwiseAbs().sum();
    }
    EXPECT_GT(q.report.dropped_energy, 0.0);
    // Q and e are non-negative: the change is the dropped energy, up to the products' float
    // rounding: a row of n non-negative products sums within (n + 3) 2^-24 of itself, twice.
    double rounding = 2.0 * (static_cast<double>(q.cols()) + 3.0) * std::ldexp(1.0, -24) * total;
    EXPECT_LE(change, q.report.dropped_energy * (1 + 1e-6) + rounding);
    EXPECT_GE(change, q.report.dropped_energy * (1 - 1e-6) - rounding);
    EXPECT_LT(rounding, 0.2 * q.report.dropped_energy);  // the check still bites
  }
}

TEST(Series, HalfPrecisionStaysWithinItsRounding) {
  auto sys = system_of("cornell-mirror-cube");
  Field f = product(solution_series(*sys, 10));
  Field h = product(solution_series(*sys, 10, SeriesBasis::kPatch, ValuePrecision::kHalf));
  // Half rounds a normal value within 2^-11 relative, a subnormal one (below 2^-14) within
  // 2^-25 absolute; a row's sum of value x emission stays within the sum of those bounds.
  SeriesOperator q = solution_series(*sys, 10);
  const double e_max = 17.0;  // the lamp's largest channel
  for (Eigen::Index r = 0; r < f.rows(); ++r) {
    double entries = q.dense() ? static_cast<double>(q.cols())
                               : static_cast<double>(q.start()[r + 1] - q.start()[r]);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(h(r, c), f(r, c),
                  std::ldexp(1.0, -11) * std::abs(f(r, c)) + entries * std::ldexp(1.0, -25) * e_max)
          << "row " << r;
  }
}

TEST(Series, ViewModeIsTheGatherOfTheSolution) {
  auto sys = system_of("cornell-mirror-cube");
  Gather g = build_gather(*sys->world, sys->transport.layout());
  SeriesOptions o;
  o.order = 9;
  o.progress = false;
  SeriesOperator view = precompute_series(sys->transport, *sys->world, o, &g);
  std::vector<float> e = view.column_emission(), out(3 * view.rows());
  view.apply(e.data(), out.data());
  Image a = series_image(view, out);
  Image b = apply_gather(g, product(solution_series(*sys, 9)));
  double worst = 0.0;
  for (size_t k = 0; k < a.rgb.size(); ++k)
    worst = std::max(worst, static_cast<double>(std::abs(a.rgb[k] - b.rgb[k])));
  EXPECT_LT(worst, 1e-4);
}

// The width of a batch only bounds the memory: each column's products and gather are its own, so
// batches narrowed by batch_bytes give the same operator to the bit, in view and solution rows,
// on the uniform mesh and on a hierarchy with specular links (the case the bound is for).
TEST(Series, NarrowBatchesGiveTheSameOperator) {
  SeriesOptions o;
  o.batch_bytes = 84.0 * 1000.0 * 10.0;         // ten columns of 1,000 unknowns
  EXPECT_EQ(series_batch(o, 1000.0, 25.0), 9);  // three batches: 9, 9, 7
  EXPECT_EQ(series_batch(o, 1000.0, 10.0), 10);
  EXPECT_EQ(series_batch(o, 1e9, 25.0), 1);  // at least one column
  o.batch_bytes = 1e30;
  EXPECT_EQ(series_batch(o, 1e9, 200.0), 50);  // at most column_batch (64): 4 batches of 50
  SceneOverrides coarse;
  coarse.patch_size = 100;
  SystemOptions hierarchical;
  hierarchical.mesh = MeshKind::kHierarchical;
  hierarchical.hierarchy.link_tolerance = 0.2;
  for (const SystemOptions& system : {SystemOptions{}, hierarchical}) {
    auto sys = build_system(load_scene(test::scene_path("cornell-mirror-cube")), coarse, system);
    for (SeriesOutput output : {SeriesOutput::kView, SeriesOutput::kSolution}) {
      if (output == SeriesOutput::kSolution && sys->hierarchy) continue;  // view rows only
      SeriesOptions wide;
      wide.order = 5;
      wide.output = output;
      wide.progress = false;
      // A final gather, so that view rows have their emission term E too, with few samples.
      wide.gather = GatherOptions::final_gather();
      wide.gather.gather_samples = wide.gather.light_samples = 4;
      wide.gather.reflector_samples = 4;
      wide.gather.emission_grid = 2;
      wide.gather.pixel_grid = 1;
      SeriesOptions narrow = wide;
      narrow.batch_bytes = 84.0 * static_cast<double>(sys->transport.size()) * 3.0;
      const SeriesOperator a = precompute_series(sys->transport, *sys->world, wide);
      const SeriesOperator b = precompute_series(sys->transport, *sys->world, narrow);
      ASSERT_GT(a.cols(), 3);  // the narrow run took several batches
      ASSERT_EQ(a.rows(), b.rows());
      std::vector<float> e = a.column_emission(), ya(3 * a.rows()), yb(3 * b.rows());
      a.apply(e.data(), ya.data());
      b.apply(e.data(), yb.data());
      EXPECT_EQ(ya, yb) << (sys->hierarchy ? "hierarchical" : "uniform");
    }
  }
}

// ---- the file ---------------------------------------------------------------------------------

TEST(Series, FileRoundTripsAndIsRefusedWhenDamaged) {
  auto sys = system_of("cornell-box");
  SeriesOperator q = solution_series(*sys, 6, SeriesBasis::kPatch, ValuePrecision::kHalf);
  q.gather.lobe_samples = 9;  // the gather a solution-mode relight will build
  q.gather.light_samples = 7;
  auto dir = test::temp_dir();
  std::string path = (dir / "a.prt").string();
  write_prt(q, path);
  SeriesOperator back = read_prt(path);
  EXPECT_EQ(back.gather.lobe_samples, 9);
  EXPECT_EQ(back.gather.light_samples, 7);
  EXPECT_EQ(back.rows(), q.rows());
  EXPECT_EQ(back.report.order, 6);
  EXPECT_EQ(back.scene_hash, sys->scene().hash);
  EXPECT_EQ(back.layout.size(), q.layout.size());
  EXPECT_EQ((product(back) - product(q)).cwiseAbs().maxCoeff(), 0.0);

  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto expect_refused = [&](std::string damaged, const std::string& words) {
    std::string p = test::write_file(dir, "bad.prt", damaged);
    try {
      read_prt(p);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_refused(bytes.substr(0, bytes.size() / 2), "checksum");  // truncated
  expect_refused(bytes.substr(0, 10), "too short");
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  expect_refused(flipped, "checksum");
  std::string version = bytes;
  version[8] = 9;
  expect_refused(version, "version");
  std::string foreign = bytes;
  std::memcpy(&foreign[0], "GLTFDATA", 8);
  expect_refused(foreign, "magic");
  expect_refused("", "empty");
}

}  // namespace
}  // namespace polyrad

namespace polyrad {
namespace {

TEST(Series, DenseAndSparseLayoutsGiveTheSameProduct) {
  auto sys = build_system(World::load(test::scene_path("cornell-mirror-cube")));
  // Dropping half of each column's energy leaves a sparse operator.
  SeriesOperator sparse =
      solution_series(*sys, 8, SeriesBasis::kPatch, ValuePrecision::kFloat, 0.5);
  ASSERT_FALSE(sparse.dense());
  Field a = product(sparse);
  auto dir = test::temp_dir();
  write_prt(sparse, (dir / "s.prt").string());
  sparse.densify_if(0.0);
  ASSERT_TRUE(sparse.dense());
  EXPECT_EQ(sparse.bytes(), static_cast<std::size_t>(sparse.rows() * sparse.cols()) * 12);
  EXPECT_EQ((product(sparse) - a).cwiseAbs().maxCoeff(), 0.0);
  write_prt(sparse, (dir / "d.prt").string());
  EXPECT_EQ((product(read_prt((dir / "s.prt").string())) - a).cwiseAbs().maxCoeff(), 0.0);
  SeriesOperator back = read_prt((dir / "d.prt").string());
  EXPECT_TRUE(back.dense());
  EXPECT_EQ((product(back) - a).cwiseAbs().maxCoeff(), 0.0);
  // A view operator is dense: every pixel sees some light of every lamp patch.
  Gather g = build_gather(*sys->world, sys->transport.layout());
  SeriesOptions o;
  o.order = 4;
  o.progress = false;
  EXPECT_TRUE(precompute_series(sys->transport, *sys->world, o, &g).dense());
}

}  // namespace
}  // namespace polyrad
