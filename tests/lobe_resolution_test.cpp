// Coarse patches against sharp lobes (papers/glossy-radiosity.md, section 11): the lobe widths the
// check uses, the warning it raises, and the error it warns about, against an independent
// quadrature.
#include "polyrad/transport/lobe_resolution.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <utility>

#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/json.h"
#include "polyrad/util/sampling.h"
#include "test_support.h"

namespace polyrad {
namespace {

// The weighted median angle between sampled directions and the mirror direction at normal
// incidence, from the BRDF's own sampler: an estimate of lobe_half_width independent of its
// formula.
double sampled_half_width(const Material& m) {
  const Vec3 wo(0.0, 0.0, 1.0);
  std::vector<std::pair<double, double>> angle_weight;
  double total = 0.0;
  const int side = 256;
  Rng rng(3);
  for (int a = 0; a < side; ++a)
    for (int b = 0; b < side; ++b) {
      LobeSample s =
          m.lobe_sample(wo, Vec2((a + rng.uniform()) / side, (b + rng.uniform()) / side));
      if (s.weight <= 0.0) continue;
      angle_weight.emplace_back(std::acos(std::clamp(s.wi.z(), -1.0, 1.0)), s.weight);
      total += s.weight;
    }
  std::sort(angle_weight.begin(), angle_weight.end());
  double below = 0.0;
  for (const auto& [angle, weight] : angle_weight)
    if ((below += weight) >= 0.5 * total) return angle;
  return kPi;
}

TEST(LobeResolution, HalfWidthIsTheMedianAngleOfTheSampledLobe) {
  // Sharp lobes, where the check matters: the closed forms match the BRDF's own sampler.
  for (double alpha : {0.02, 0.05, 0.1, 0.15}) {
    Material m = Material::glossy("g", Rgb::Zero(), Rgb::Constant(0.8), alpha);
    EXPECT_NEAR(lobe_half_width(m), 2.0 * std::atan(alpha), 1e-12);
    EXPECT_NEAR(lobe_half_width(m) / sampled_half_width(m), 1.0, 0.03) << "alpha " << alpha;
  }
  for (double n : {20.0, 40.0, 100.0, 400.0}) {
    Material m = Material::phong("p", Rgb::Zero(), Rgb::Constant(0.8), n);
    EXPECT_NEAR(lobe_half_width(m) / sampled_half_width(m), 1.0, 0.03) << "n " << n;
  }
  // Rough lobes: masking and the cosine weigh the tail down; the formula is then the wider.
  for (double alpha : {0.3, 0.5}) {
    Material m = Material::glossy("g", Rgb::Zero(), Rgb::Constant(0.8), alpha);
    EXPECT_GT(lobe_half_width(m), sampled_half_width(m)) << "alpha " << alpha;
    EXPECT_LT(lobe_half_width(m), 1.35 * sampled_half_width(m)) << "alpha " << alpha;
  }
  EXPECT_EQ(lobe_half_width(Material::mirror("m", Rgb::Constant(0.9))), 0.0);
  EXPECT_EQ(lobe_half_width(Material::glossy("d", Rgb::Zero(), Rgb::Constant(0.9), 1e-4)), 0.0);
  EXPECT_EQ(lobe_half_width(Material::lambert("l", Rgb::Constant(0.9))), 0.0);
}

const LobeResolution* find(const std::vector<LobeResolution>& lobes, const std::string& object) {
  for (const auto& r : lobes)
    if (r.object_name == object) return &r;
  return nullptr;
}

TEST(LobeResolution, TheSharpLobeSceneWarnsForTheSharpBlockOnlyAtACoarseSize) {
  auto sys =
      build_system(World::load(test::scene_path("stability/sharp-lobe"), {.patch_size = 100}));
  const LobeResolution* sharp = find(sys->lobes, "tall_block");
  const LobeResolution* rough = find(sys->lobes, "short_block");
  ASSERT_NE(sharp, nullptr);
  ASSERT_NE(rough, nullptr);
  EXPECT_TRUE(sharp->smeared);
  EXPECT_FALSE(rough->smeared);
  EXPECT_NEAR(sharp->lobe_degrees, 4.0 * std::atan(0.05) * 180.0 / kPi, 1e-9);
  EXPECT_GT(sharp->patch_degrees, sharp->lobe_degrees);
  EXPECT_LT(sharp->resolving_patch_size, 100.0);
  EXPECT_GT(sharp->resolving_patch_size, 25.0);
  const std::string text = describe_smear(*sharp);
  for (const char* part : {"'tall_block'", "'sharp'", "alpha 0.05", "11.4 degrees"})
    EXPECT_NE(text.find(part), std::string::npos) << part << " in: " << text;
}

TEST(LobeResolution, RenderWarnsOnStderrAndInTheReport) {
  auto dir = test::temp_dir();
  const std::string report = (dir / "r.json").string();
  const std::string command = std::string(POLYRAD_CLI) + " --quiet render " +
                              test::scene_path("stability/sharp-lobe") + " --patch-size 100 -o " +
                              (dir / "i.pfm").string() + " --report " + report + " 2> " +
                              (dir / "err.txt").string();
  ASSERT_EQ(std::system(command.c_str()), 0);
  const std::string err = test::read_text(dir / "err.txt");
  const std::string line = "polyrad: warning: object 'tall_block' (material 'sharp'";
  ASSERT_NE(err.find(line), std::string::npos) << err;
  EXPECT_EQ(err.find(line, err.find(line) + 1), std::string::npos) << "one warning per object";
  EXPECT_EQ(err.find("'short_block'"), std::string::npos) << err;
  JsonValue r = parse_json(test::read_text(report), report);
  const JsonValue* warnings = r.find("warnings");
  ASSERT_NE(warnings, nullptr);
  ASSERT_EQ(warnings->array.size(), 1u);
  const JsonValue& w = warnings->array[0];
  EXPECT_EQ(w.find("object")->string, "tall_block");
  EXPECT_EQ(w.find("material")->string, "sharp");
  EXPECT_GT(w.find("patch_angle_degrees")->number, w.find("lobe_width_degrees")->number);
  EXPECT_LT(w.find("resolving_patch_size")->number, 100.0);
  // Both glossy blocks were checked.
  EXPECT_EQ(r.find("system")->find("lobe_resolution")->array.size(), 2u);
}

// A small glossy plate on the floor reflects a small lamp onto a diffuse ceiling that the lamp
// does not light directly: the ceiling's only light is the plate's caustic (plus a share below
// a percent that the plate sends from ceiling to ceiling). Units: metres. The mirror image of the
// lamp centre through the plate centre lands on the ceiling at (1, 2, 0).
constexpr double kCeilingReflectance = 0.5;  // the "white" of caustic_scene
constexpr double kPlateSpecular = 0.9;

std::string caustic_scene(const std::string& plate_material, double ceiling_patch) {
  std::ostringstream s;
  s << R"({
  "camera": {"position": [1, 1, -4], "look_at": [1, 1, 0], "fov_deg": 60, "width": 8, "height": 8},
  "patch_size": 0.1,
  "materials": {
    "white": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
    "black": {"type": "diffuse", "reflectance": [0, 0, 0]},
    "plate": )"
    << plate_material << R"(
  },
  "objects": [
    {"name": "plate", "material": "plate",
     "polygon": [[-0.1, 0, -0.1], [-0.1, 0, 0.1], [0.1, 0, 0.1], [0.1, 0, -0.1]]},
    {"name": "lamp", "material": "black", "emission": [1, 1, 1],
     "polygon": [[-0.55, 1, -0.05], [-0.45, 1, -0.05], [-0.45, 1, 0.05], [-0.55, 1, 0.05]]},
    {"name": "ceiling", "material": "white", "patch_size": )"
    << ceiling_patch << R"(,
     "polygon": [[0, 2, -1], [2, 2, -1], [2, 2, 1], [0, 2, 1]]}
  ]
})";
  return s.str();
}

std::string glossy_json(double alpha) {
  std::ostringstream s;
  const double k = kPlateSpecular;
  s << R"({"type": "glossy", "specular": [)" << k << ", " << k << ", " << k << R"(], "roughness": )"
    << alpha << "}";
  return s.str();
}

// The ceiling's radiosity at x: kCeilingReflectance / pi times the irradiance that reaches x
// from the unit-radiance lamp over the plate, a midpoint rule over both (n x n points each).
double caustic_radiosity(const Material& plate, const Vec3& x, int n_plate, int n_lamp) {
  const Vec3 up(0, 1, 0), down(0, -1, 0);
  const Frame frame = Frame::from_normal(up);
  const double dy = 0.04 / (n_plate * n_plate), dz = 0.01 / (n_lamp * n_lamp);
  double e = 0.0;
  for (int a = 0; a < n_plate * n_plate; ++a) {
    const Vec3 y(-0.1 + 0.2 * (a % n_plate + 0.5) / n_plate, 0,
                 -0.1 + 0.2 * (a / n_plate + 0.5) / n_plate);
    const Vec3 to_x = (x - y).normalized();
    const double g_out = to_x.dot(up) * (-to_x).dot(down) / (x - y).squaredNorm();
    for (int b = 0; b < n_lamp * n_lamp; ++b) {
      const Vec3 z(-0.55 + 0.1 * (b % n_lamp + 0.5) / n_lamp, 1,
                   -0.05 + 0.1 * (b / n_lamp + 0.5) / n_lamp);
      const Vec3 to_z = (z - y).normalized();
      const double g_in = to_z.dot(up) * (-to_z).dot(down) / (z - y).squaredNorm();
      const double f = kPlateSpecular * plate.lobe_eval(frame.to_local(to_z), frame.to_local(to_x));
      e += f * g_in * g_out * dz * dy;
    }
  }
  return kCeilingReflectance / kPi * e;
}

// Points on a 20 x 20 grid over the ceiling (cell centres).
std::vector<Vec3> ceiling_points() {
  std::vector<Vec3> p;
  for (int a = 0; a < 20; ++a)
    for (int b = 0; b < 20; ++b) p.emplace_back(0.05 + 0.1 * a, 2.0, -0.95 + 0.1 * b);
  return p;
}

std::vector<double> quadrature_reference(const Material& plate) {
  const std::vector<Vec3> points = ceiling_points();
  std::vector<double> b(points.size());
#pragma omp parallel for schedule(dynamic)
  for (int n = 0; n < static_cast<int>(points.size()); ++n)
    b[n] = caustic_radiosity(plate, points[n], 24, 8);
  return b;
}

struct CausticRun {
  std::vector<LobeResolution> lobes;
  std::vector<double> b;  // the ceiling's radiosity at ceiling_points(), from its patches
};

CausticRun radiosity_caustic(double alpha, double ceiling_patch) {
  SystemOptions o;
  // The caustic rests on few lamp pairs: enough samples keep its noise well below its error.
  o.specular.samples = 1024;
  auto sys = build_system(
      World::build(test::scene_from_json(caustic_scene(glossy_json(alpha), ceiling_patch))), o);
  SolveOptions so;
  so.tolerance = 1e-8;
  SolveResult r = solve(sys->transport, sys->transport.emission(), so);
  EXPECT_TRUE(r.ok()) << r.message;
  CausticRun run{sys->lobes, {}};
  const ObjectId ceiling = sys->scene().find_object("ceiling");
  for (const Vec3& x : ceiling_points()) {
    double value = -1.0;
    for (PatchId p = 0; p < static_cast<PatchId>(sys->patches().size()); ++p) {
      const Patch& q = sys->patches()[p];
      if (q.object != ceiling) continue;
      Eigen::Vector3d lo = q.corner[0], hi = q.corner[0];
      for (const Vec3& c : q.corner) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
      if (x.x() >= lo.x() && x.x() <= hi.x() && x.z() >= lo.z() && x.z() <= hi.z())
        value = r.u(p, 0);
    }
    EXPECT_GE(value, 0.0) << "no ceiling patch at " << x.transpose();
    run.b.push_back(value);
  }
  return run;
}

double relative_l1(const std::vector<double>& b, const std::vector<double>& ref) {
  double diff = 0.0, sum = 0.0;
  for (size_t n = 0; n < b.size(); ++n) {
    diff += std::abs(b[n] - ref[n]);
    sum += ref[n];
  }
  return diff / sum;
}

TEST(LobeResolution, CoarseCeilingSmearsTheSharpCausticAndIsWarnedAbout) {
  const double coarse = 1.0, fine = 0.25;
  CausticRun sharp_coarse = radiosity_caustic(0.05, coarse);
  CausticRun rough_coarse = radiosity_caustic(0.3, coarse);
  CausticRun sharp_fine = radiosity_caustic(0.05, fine);
  ASSERT_EQ(sharp_coarse.lobes.size(), 1u);
  ASSERT_EQ(rough_coarse.lobes.size(), 1u);
  ASSERT_EQ(sharp_fine.lobes.size(), 1u);
  EXPECT_TRUE(sharp_coarse.lobes[0].smeared) << sharp_coarse.lobes[0].patch_degrees;
  EXPECT_FALSE(rough_coarse.lobes[0].smeared) << rough_coarse.lobes[0].patch_degrees;
  EXPECT_FALSE(sharp_fine.lobes[0].smeared) << sharp_fine.lobes[0].patch_degrees;
  // The size it proposes at the coarse size resolves the lobe: no warning there.
  EXPECT_LE(sharp_coarse.lobes[0].resolving_patch_size, 0.6);
  EXPECT_GE(sharp_coarse.lobes[0].resolving_patch_size, fine);
}

TEST(LobeResolution, MirrorsAreNotChecked) {
  auto sys = build_system(World::build(test::scene_from_json(
      caustic_scene(R"({"type": "mirror", "reflectance": [0.9, 0.9, 0.9]})", 1.0))));
  EXPECT_GT(sys->specular.entries(), 0);
  EXPECT_TRUE(sys->lobes.empty());
}

TEST(LobeResolution, CausticErrorGrowsWithThePatchSizeWhereTheWarningSaysSo) {
  const Material sharp =
      Material::glossy("plate", Rgb::Zero(), Rgb::Constant(kPlateSpecular), 0.05);
  const Material rough = Material::glossy("plate", Rgb::Zero(), Rgb::Constant(kPlateSpecular), 0.3);
  const std::vector<double> sharp_ref = quadrature_reference(sharp);
  std::vector<double> error;
  std::vector<bool> warned;
  const std::vector<double> sizes{1.0, 0.5, 0.25, 0.125};
  for (double size : sizes) {
    CausticRun run = radiosity_caustic(0.05, size);
    ASSERT_EQ(run.lobes.size(), 1u);
    error.push_back(relative_l1(run.b, sharp_ref));
    warned.push_back(run.lobes[0].smeared);
    RecordProperty("relative_l1_at_" + std::to_string(size), std::to_string(error.back()));
    RecordProperty("warned_at_" + std::to_string(size), warned.back() ? "yes" : "no");
  }
  // The caustic is about 0.8 wide; the ceiling's patches from 1 down to 0.125.
  for (size_t n = 1; n < sizes.size(); ++n) EXPECT_GT(error[n - 1], 1.25 * error[n]) << sizes[n];
  // The warning separates the sizes: the smallest error it warns about is well above the largest
  // it lets pass (the latter is mostly the transfer's sampling noise).
  double worst_silent = 0.0, best_warned = 1e300;
  for (size_t n = 0; n < sizes.size(); ++n) {
    if (warned[n])
      best_warned = std::min(best_warned, error[n]);
    else
      worst_silent = std::max(worst_silent, error[n]);
  }
  EXPECT_TRUE(warned.front());
  EXPECT_FALSE(warned.back());
  EXPECT_GT(best_warned, 1.5 * worst_silent);
  // The same coarse ceiling serves the rough lobe's broad caustic far better.
  const double rough_error =
      relative_l1(radiosity_caustic(0.3, 1.0).b, quadrature_reference(rough));
  RecordProperty("rough_relative_l1_at_1", std::to_string(rough_error));
  EXPECT_GT(error.front(), 2.0 * rough_error);
}

}  // namespace
}  // namespace polyrad
