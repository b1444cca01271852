// The path tracer against exact answers (papers/glossy-radiosity.md, section 10). Every tolerance
// is a multiple of the estimator's own standard error, estimated from the same samples.
#include "polyrad/render/path_tracer.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "polyrad/app/report.h"
#include "polyrad/io/image_io.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/util/files.h"
#include "polyrad/util/json.h"
#include "test_support.h"

namespace polyrad {
namespace {

// A world and its tracer; the camera may be resized first (width, height > 0).
struct Traced {
  std::shared_ptr<const World> world;
  std::unique_ptr<PathTracer> tracer;
  explicit Traced(Scene s, int width = 0, int height = 0) {
    if (width > 0) s.camera.width = width;
    if (height > 0) s.camera.height = height;
    world = World::build(std::move(s));
    tracer = std::make_unique<PathTracer>(*world);
  }
  const Camera& camera() const { return world->camera(); }
};

struct Estimate {
  Rgb mean = Rgb::Zero();
  Rgb se = Rgb::Zero();  // standard error of the mean
};

// n independent samples of the radiance leaving the first surface along the ray, toward origin.
Estimate estimate(const PathTracer& pt, const Vec3& origin, const Vec3& dir, int n,
                  std::uint64_t seed, PathTraceOptions o = {}) {
  Rgb mean = Rgb::Zero(), m2 = Rgb::Zero();
  for (int s = 0; s < n; ++s) {
    Rng rng(seed, static_cast<std::uint64_t>(s));
    Rgb l = pt.radiance(origin, dir.normalized(), rng, o);
    Rgb d = l - mean;
    mean += d / (s + 1);
    m2 += d * (l - mean);
  }
  return {mean, (m2 / (static_cast<double>(n) - 1.0) / n).sqrt()};
}

// Mean of an image and the standard error of that mean from the per-pixel standard errors
// (pixels are independent).
Estimate image_mean(const PathTraceResult& r) {
  Estimate e;
  Rgb var = Rgb::Zero();
  double n = static_cast<double>(r.image.width) * r.image.height;
  for (int y = 0; y < r.image.height; ++y)
    for (int x = 0; x < r.image.width; ++x) {
      e.mean += r.image.at(x, y);
      var += r.standard_error.at(x, y).square();
    }
  e.mean /= n;
  e.se = var.sqrt() / n;
  return e;
}

std::string material_json(double a) {
  std::ostringstream s;
  s << "{\"type\": \"diffuse\", \"reflectance\": [" << a << ", " << a << ", " << a << "]}";
  return s.str();
}

// ---- furnace: radiance E / (1 - a) everywhere ----------------------------------------------

void expect_furnace(const std::string& material, double albedo, double emission) {
  Traced t(test::scene_from_json(test::closed_box_json(Vec3(1, 1, 1), 0.25, material, emission)));
  PathTraceOptions o;
  o.spp = 16;
  o.standard_error = true;
  o.progress = false;
  PathTraceResult r = t.tracer->render(t.camera(), o);
  Estimate e = image_mean(r);
  double exact = emission / (1.0 - albedo);
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(e.se[c], 0.0);
    EXPECT_NEAR(e.mean[c], exact, 4.0 * e.se[c]) << material << " channel " << c;
  }
  EXPECT_EQ(r.stats.truncated, 0);
  std::printf("furnace %s: %.5f +- %.5f (exact %.5f), %lld rays\n", material.c_str(), e.mean[0],
              e.se[0], exact, r.stats.rays);
}

TEST(PathTracer, FurnaceLambertian) { expect_furnace(material_json(0.5), 0.5, 1.0); }

TEST(PathTracer, FurnaceLambertianHighAlbedo) { expect_furnace(material_json(0.8), 0.8, 0.5); }

TEST(PathTracer, FurnaceMirrorWalls) {
  expect_furnace("{\"type\": \"mirror\", \"reflectance\": [0.6, 0.6, 0.6]}", 0.6, 1.0);
}

// Lambert plus a delta lobe (GGX below the delta roughness): albedo 0.3 + 0.4 for every
// direction; exercises the mixture of a delta and a non-delta strategy under MIS.
TEST(PathTracer, FurnaceLambertPlusMirror) {
  expect_furnace(
      "{\"type\": \"glossy\", \"diffuse\": [0.3, 0.3, 0.3], \"specular\": [0.4, 0.4, 0.4], "
      "\"roughness\": 0}",
      0.7, 1.0);
}

// ---- direct light of the Cornell lamp at floor points ----------------------------------------

// Differential area to a parallel rectangle with the normal through one corner
// (papers/glossy-radiosity.md, section 10), with signed sides: odd in A and in B, so that
// rectangles not containing the foot of the normal come out of the same four-term sum.
double corner_ff(double a, double b, double c) {
  double A = a / c, B = b / c;
  double sa = std::sqrt(1 + A * A), sb = std::sqrt(1 + B * B);
  return (A / sa * std::atan(B / sa) + B / sb * std::atan(A / sb)) / (2.0 * kPi);
}

// Form factor from a differential area at foot (px, pz) to the rectangle [x0,x1] x [z0,z1] of a
// parallel plane at distance c: four corner rectangles.
double rectangle_ff(double px, double pz, double x0, double x1, double z0, double z1, double c) {
  return corner_ff(x1 - px, z1 - pz, c) - corner_ff(x0 - px, z1 - pz, c) -
         corner_ff(x1 - px, z0 - pz, c) + corner_ff(x0 - px, z0 - pz, c);
}

// The Cornell room without blocks; every reflectance 0 but the floor's, so that the floor shows
// exactly its direct light: L = rho / pi * E = rho * L_e * F(dA -> lamp).
const char* kCornellDirect = R"({
  "camera": {"position": [278, 273, -800], "look_at": [278, 273, 0], "fov_deg": 39.3077,
             "width": 16, "height": 16},
  "patch_size": 100,
  "materials": {
    "floor": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
    "black": {"type": "diffuse", "reflectance": [0, 0, 0]}
  },
  "objects": [
    {"name": "floor", "material": "floor",
     "polygon": [[552.8, 0, 0], [0, 0, 0], [0, 0, 559.2], [549.6, 0, 559.2]]},
    {"name": "ceiling", "material": "black",
     "polygon": [[556, 548.8, 0], [556, 548.8, 559.2], [0, 548.8, 559.2], [0, 548.8, 0]]},
    {"name": "back_wall", "material": "black",
     "polygon": [[549.6, 0, 559.2], [0, 0, 559.2], [0, 548.8, 559.2], [556, 548.8, 559.2]]},
    {"name": "green_wall", "material": "black",
     "polygon": [[0, 0, 559.2], [0, 0, 0], [0, 548.8, 0], [0, 548.8, 559.2]]},
    {"name": "red_wall", "material": "black",
     "polygon": [[552.8, 0, 0], [549.6, 0, 559.2], [556, 548.8, 559.2], [556, 548.8, 0]]},
    {"name": "light", "material": "black", "emission": [17, 12, 4], "patch_size": 20,
     "polygon": [[343, 548.3, 227], [343, 548.3, 332], [213, 548.3, 332], [213, 548.3, 227]]}
  ]
})";

void expect_cornell_direct(bool next_event, int samples) {
  Traced t(test::scene_from_json(kCornellDirect));
  PathTraceOptions o;
  o.next_event = next_event;
  const Rgb le(17, 12, 4);
  const double rho = 0.5, c = 548.3;
  int k = 0;
  for (Vec2 p : {Vec2(278, 279.5), Vec2(100, 100), Vec2(450, 500), Vec2(278, 40), Vec2(30, 300)}) {
    double f = rectangle_ff(p.x(), p.y(), 213, 343, 227, 332, c);
    Rgb exact = rho * le * f;
    Estimate e =
        estimate(*t.tracer, Vec3(p.x(), 1.0, p.y()), Vec3(0, -1, 0), samples, 100 + k++, o);
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(e.mean[ch], exact[ch], 4.0 * e.se[ch])
          << "floor point (" << p.x() << ", " << p.y() << ") channel " << ch;
    std::printf("floor (%g, %g): %.6f +- %.6f, exact %.6f (%s)\n", p.x(), p.y(), e.mean[0], e.se[0],
                exact[0], next_event ? "NEE + MIS" : "BSDF only");
  }
}

TEST(PathTracer, CornellLampDirectLightAtFloorPoints) { expect_cornell_direct(true, 4000); }

// The same by BSDF sampling alone: an independent check of the light sampler's density.
TEST(PathTracer, CornellLampDirectLightBsdfSamplingOnly) { expect_cornell_direct(false, 40000); }

// ---- the mirror image -----------------------------------------------------------------------

// A 100 x 100 lamp at height H facing down, a mirror plate below it, and a small receiver in the
// lamp's plane beside it, facing down. The receiver sees the lamp only through the mirror, and
// exactly as it would see the lamp's mirror image (at depth H below the mirror, facing up) times
// the reflectance: L = rho_r * r * L_e * F(dA -> image), F by the parallel-plate formula at the
// image distance 2H. (The receiver's own light returning through the mirror adds
// rho_r * r * F(receiver -> its image) < 3e-5 of that, far below the tolerance.)
TEST(PathTracer, MirrorImageOfTheLamp) {
  const char* json = R"({
    "camera": {"position": [0, 50, -400], "look_at": [0, 50, 0], "fov_deg": 60,
               "width": 8, "height": 8},
    "patch_size": 1000,
    "materials": {
      "mirror": {"type": "mirror", "reflectance": [0.8, 0.8, 0.8]},
      "black": {"type": "diffuse", "reflectance": [0, 0, 0]},
      "receiver": {"type": "diffuse", "reflectance": [0.9, 0.9, 0.9]}
    },
    "objects": [
      {"name": "mirror", "material": "mirror",
       "polygon": [[-500, 0, -500], [-500, 0, 500], [500, 0, 500], [500, 0, -500]]},
      {"name": "lamp", "material": "black", "emission": [10, 10, 10],
       "polygon": [[-50, 100, -50], [50, 100, -50], [50, 100, 50], [-50, 100, 50]]},
      {"name": "receiver", "material": "receiver",
       "polygon": [[149, 100, -1], [151, 100, -1], [151, 100, 1], [149, 100, 1]]}
    ]
  })";
  Traced t(test::scene_from_json(json));
  const double h = 100.0;
  double f = rectangle_ff(150, 0, -50, 50, -50, 50, 2 * h);
  double exact = 0.9 * 0.8 * 10.0 * f;
  Estimate e = estimate(*t.tracer, Vec3(150, h - 1, 0), Vec3(0, 1, 0), 400000, 7);
  EXPECT_NEAR(e.mean[0], exact, 4.0 * e.se[0]);
  EXPECT_LT(e.se[0], 0.02 * exact);  // the test has power: a 10 % error would be 5 sigma
  std::printf("mirror image: %.6f +- %.6f, exact %.6f\n", e.mean[0], e.se[0], exact);
}

// ---- the Monte Carlo rate -------------------------------------------------------------------

// The mean of N independent renders of the furnace: its squared error, measured against the
// exact E / (1 - a) and divided by the variance the estimator itself predicts (its per-pixel
// standard error squared over N), must average 1 over the pixels for every N. That is the
// 1/sqrt(N) rate, and no bias shows up as N grows.
TEST(PathTracer, MeanOverSeedsConvergesAtTheMonteCarloRate) {
  Traced t(
      test::scene_from_json(test::closed_box_json(Vec3(1, 1, 1), 0.25, material_json(0.5), 1.0)),
      32, 32);
  const int runs = 64;
  const double exact = 2.0;
  const size_t pixels = 32 * 32;
  const std::vector<int> checkpoints{1, 4, 16, 64};
  std::vector<double> sum(pixels, 0.0), var(pixels, 0.0);
  std::vector<std::vector<double>> means;  // per checkpoint N: the mean of the first N runs
  for (int run = 1; run <= runs; ++run) {
    PathTraceOptions o;
    o.spp = 8;
    o.seed = 1000 + run;
    o.standard_error = true;
    o.progress = false;
    PathTraceResult r = t.tracer->render(t.camera(), o);
    for (size_t p = 0; p < pixels; ++p) {
      sum[p] += r.image.rgb[3 * p];
      var[p] += std::pow(r.standard_error.rgb[3 * p], 2);
    }
    if (std::find(checkpoints.begin(), checkpoints.end(), run) != checkpoints.end()) {
      means.push_back(sum);
      for (double& m : means.back()) m /= run;
    }
  }
  // The variance of one run's pixel, pooled over all runs (64 x 7 degrees of freedom).
  for (double& v : var) v /= runs;
  std::vector<std::pair<int, double>> errors;  // N, RMS error of the mean of N runs
  for (size_t k = 0; k < checkpoints.size(); ++k) {
    int n = checkpoints[k];
    double se2 = 0.0, zz = 0.0;
    for (size_t p = 0; p < pixels; ++p) {
      double d = means[k][p] - exact;
      se2 += d * d;
      zz += d * d / (var[p] / n);
    }
    errors.push_back({n, std::sqrt(se2 / pixels)});
    zz /= pixels;
    // For normal errors the mean of z^2 over P pixels has standard deviation sqrt(2 / P).
    EXPECT_NEAR(zz, 1.0, 5.0 * std::sqrt(2.0 / pixels)) << "mean of " << n << " runs";
    std::printf("mean of %2d runs: RMS error %.5f, mean z^2 %.3f\n", n, errors.back().second, zz);
  }
  // The fitted slope of log(error) against log(N).
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (auto [n, e] : errors) {
    double x = std::log(n), y = std::log(e);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
  }
  double m = static_cast<double>(errors.size());
  double slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
  std::printf("slope of log RMS error against log N: %.3f (Monte Carlo: -0.5)\n", slope);
}

// ---- determinism ----------------------------------------------------------------------------

TEST(PathTracer, SameImageOnOneAndTwoThreads) {
  Traced t(load_scene(test::scene_path("cornell-mirror-cube")), 40, 30);
  PathTraceOptions o;
  o.spp = 4;
  o.seed = 99;
  o.tile = 8;
  o.progress = false;
  int before = omp_get_max_threads();
  omp_set_num_threads(1);
  PathTraceResult one = t.tracer->render(t.camera(), o);
  omp_set_num_threads(2);
  PathTraceResult two = t.tracer->render(t.camera(), o);
  omp_set_num_threads(before);
  ASSERT_EQ(one.image.rgb.size(), two.image.rgb.size());
  EXPECT_TRUE(one.image.rgb == two.image.rgb);
  EXPECT_EQ(one.stats.rays, two.stats.rays);
  o.seed = 100;
  PathTraceResult other = t.tracer->render(t.camera(), o);
  EXPECT_FALSE(one.image.rgb == other.image.rgb);  // the seed matters
}

// ---- glossy lobes: light sampling + MIS against BSDF sampling alone --------------------------

// Both estimators are unbiased, so over each object of cornell-glossy (the GGX block, the Phong
// block, the walls) their region means agree within their combined standard error. A wrong
// MIS weight or light density for a glossy lobe shows up as a difference.
TEST(PathTracer, GlossyMisAgreesWithBsdfSampling) {
  Traced t(load_scene(test::scene_path("cornell-glossy")), 48, 48);
  RegionMap regions = object_regions(*t.world);
  PathTraceOptions o;
  o.spp = 128;
  o.standard_error = true;
  o.progress = false;
  PathTraceResult mis = t.tracer->render(t.camera(), o);
  o.next_event = false;
  o.seed = 2;
  PathTraceResult bsdf = t.tracer->render(t.camera(), o);
  size_t n = regions.names.size();
  std::vector<Rgb> da(n, Rgb::Zero()), va(n, Rgb::Zero());
  std::vector<long long> count(n, 0);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 48; ++x) {
      int r = regions.label[static_cast<size_t>(y) * 48 + x];
      if (r < 0) continue;
      da[r] += mis.image.at(x, y) - bsdf.image.at(x, y);
      va[r] += mis.standard_error.at(x, y).square() + bsdf.standard_error.at(x, y).square();
      ++count[r];
    }
  for (size_t r = 0; r < n; ++r) {
    if (count[r] < 20) continue;
    Rgb diff = da[r] / count[r], se = va[r].sqrt() / count[r];
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(diff[c], 0.0, 4.5 * se[c]) << regions.names[r] << " channel " << c;
    std::printf("%-12s MIS - BSDF-only: %+.5f +- %.5f\n", regions.names[r].c_str(), diff[0], se[0]);
  }
}
// Albedo 0.99: a path survives each bounce with probability 0.99, so max_depth 64 cuts more
// than half of them still carrying light, and the image is E (1 - a^64) / (1 - a), about half
// of E / (1 - a); with max_depth 4096 none is cut and the furnace holds. The summary says so.
TEST(PathTracer, AlbedoNearOneNeedsTheDepthToHoldTheFurnace) {
  const double a = 0.99, exact = 1.0 / (1.0 - a);
  Traced t(test::scene_from_json(test::closed_box_json(Vec3(1, 1, 1), 0.25, material_json(a), 1)));
  PathTraceOptions o;
  o.spp = 2;
  o.standard_error = true;
  o.progress = false;
  o.max_depth = 4096;
  const PathTraceResult deep = t.tracer->render(t.camera(), o);
  const Estimate d = image_mean(deep);
  EXPECT_NEAR(d.mean[0], exact, 4.0 * d.se[0]);
  EXPECT_EQ(deep.stats.truncated, 0);
  EXPECT_EQ(describe_truncation(summarize(deep, o)), "");
  o.max_depth = 64;
  const PathTraceResult cut = t.tracer->render(t.camera(), o);
  const Estimate c = image_mean(cut);
  std::printf("albedo 0.99: %.2f (depth 4096), %.2f (64), exact %.2f; %lld of %lld paths cut\n",
              d.mean[0], c.mean[0], exact, cut.stats.truncated, cut.stats.paths);
  EXPECT_LT(c.mean[0], 0.6 * exact);
  EXPECT_GT(cut.stats.truncated, cut.stats.paths / 3);
  EXPECT_NE(describe_truncation(summarize(cut, o)).find("raise --max-depth"), std::string::npos);
}

// A path cut where it met a black surface had nothing more to gather: it is not counted as cut
// (the warning would otherwise blame the depth for a dark image the scene made). One segment
// only: every camera ray ends on a wall of the closed box.
TEST(PathTracer, PathsEndingOnABlackSurfaceAreNotCountedAsCut) {
  PathTraceOptions o;
  o.spp = 1;
  o.progress = false;
  o.max_depth = 1;
  for (double albedo : {0.0, 0.5}) {
    Traced t(test::scene_from_json(
        test::closed_box_json(Vec3(1, 1, 1), 0.25, material_json(albedo), 1)));
    const PathTraceResult r = t.tracer->render(t.camera(), o);
    EXPECT_EQ(r.stats.truncated, albedo > 0.0 ? r.stats.paths : 0) << "albedo " << albedo;
  }
}

// ---- the command line ------------------------------------------------------------------------

TEST(PathTracer, CommandWritesImageAndReport) {
  auto dir = test::temp_dir();
  std::string img = (dir / "f.pfm").string(), rep = (dir / "f.json").string();
  test::CommandRun run =
      test::run_cli("render " + test::scene_path("furnace") +
                    " --method pathtrace --spp 2 --seed 3 -o " + img + " --report " + rep);
  ASSERT_EQ(run.code, 0) << run.err;
  const JsonValue report = test::read_json(rep);
  for (const char* key : {"pathtrace", "seconds", "peak_memory_bytes", "machine"})
    ASSERT_NE(report.find(key), nullptr) << key;
  const JsonValue& r = *report.find("pathtrace");
  for (const char* key : {"spp", "seed", "rays", "seconds", "mean_relative_standard_error"})
    EXPECT_NE(r.find(key), nullptr) << key;
  EXPECT_EQ(r.find("spp")->number, 2.0);
  Image i = read_image(img);
  EXPECT_EQ(i.width, 64);
  // --patches has nothing to write for a path tracer: bad input, and no image.
  std::string img2 = (dir / "g.exr").string();
  EXPECT_EQ(test::run_cli("render " + test::scene_path("furnace") + " --method pathtrace -o " +
                          img2 + " --patches " + (dir / "p.csv").string())
                .code,
            2);
  EXPECT_FALSE(std::filesystem::exists(img2));
}

// --max-depth reaches the path tracer and its report; paths it cuts are a warning on stderr and
// in the report; a depth below 1 is bad input.
TEST(PathTracer, CommandWarnsOfPathsCutAtMaxDepth) {
  auto dir = test::temp_dir();
  const std::string img = (dir / "f.pfm").string(), rep = (dir / "f.json").string();
  const std::string render = "render " + test::scene_path("furnace") + " --method pathtrace -o ";
  test::CommandRun run = test::run_cli(render + img + " --spp 2 --max-depth 2 --report " + rep);
  ASSERT_EQ(run.code, 0) << run.err;
  EXPECT_NE(run.err.find("polyrad: warning: "), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("raise --max-depth"), std::string::npos) << run.err;
  const JsonValue report = test::read_json(rep);
  EXPECT_EQ(report.find("pathtrace")->find("max_depth")->number, 2.0);
  const JsonValue* warnings = report.find("warnings");
  ASSERT_NE(warnings, nullptr);
  ASSERT_EQ(warnings->array.size(), 1u);
  EXPECT_EQ(warnings->array[0].find("kind")->string, "paths_truncated");
  EXPECT_GT(warnings->array[0].find("paths_truncated")->number, 0.0);
  // The default depth cuts none in the grey furnace: no warning.
  run = test::run_cli(render + img + " --spp 2 --report " + rep);
  ASSERT_EQ(run.code, 0) << run.err;
  EXPECT_EQ(run.err.find("warning"), std::string::npos) << run.err;
  EXPECT_TRUE(test::read_json(rep).find("warnings")->array.empty());
  const std::string img2 = (dir / "g.pfm").string();
  EXPECT_EQ(test::run_cli(render + img2 + " --max-depth 0").code, 2);
  EXPECT_FALSE(std::filesystem::exists(img2));
}

}  // namespace
}  // namespace polyrad
