#include "polyrad/render/camera_gather.h"

#include <gtest/gtest.h>

#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/sampling.h"
#include "test_support.h"

namespace polyrad {
namespace {

struct Rendered {
  std::unique_ptr<RadiositySystem> sys;
  SolveResult solution;
  Image image;
};

Rendered render(const std::string& scene, DiffuseMode mode, bool classic = false) {
  Rendered r;
  r.sys = build_system(World::load(test::scene_path(scene), {.classic = classic}));
  r.solution = solve(r.sys->transport, r.sys->transport.emission(), SolveOptions{});
  GatherOptions go;
  go.diffuse = mode;
  Gather g = build_gather(*r.sys->world, r.sys->transport.layout(), go);
  r.image = apply_gather(g, r.solution.u);
  return r;
}

Rgb mean(const Image& img, int x0, int x1, int y0, int y1) {
  Rgb s = Rgb::Zero();
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) s += img.at(x, y);
  return s / ((x1 - x0) * (y1 - y0));
}

TEST(CameraGather, CornellImageIsUprightWithTheRedWallOnTheLeft) {
  Rendered r = render("cornell-box", DiffuseMode::kSmooth);
  const Image& img = r.image;
  ASSERT_EQ(img.width, 256);
  ASSERT_TRUE(img.all_finite());
  Rgb left = mean(img, 5, 25, 80, 180), right = mean(img, 231, 251, 80, 180);
  EXPECT_GT(left[0], 3 * left[1]);    // red wall
  EXPECT_GT(right[1], 2 * right[0]);  // green wall
  // The lamp is the brightest thing and sits at the top.
  int best_y = 0;
  double best = 0.0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (luminance(img.at(x, y)) > best) {
        best = luminance(img.at(x, y));
        best_y = y;
      }
  EXPECT_LT(best_y, img.height / 5);
}

TEST(CameraGather, LampPixelsShowItsRadiance) {
  // A pixel well inside the lamp sees B = E + d * irradiance; the lamp faces down, away from
  // most light, so B is E plus a little.
  Rendered r = render("cornell-box", DiffuseMode::kFlat);
  Rgb lamp = r.image.at(128, 36);  // the lamp spans rows 32 to 40 of the 256 x 256 image
  EXPECT_GT(lamp[0], 17.0);
  EXPECT_LT(lamp[0], 17.5);
}

TEST(CameraGather, SmoothAndFlatAgreeOnAverage) {
  Rendered flat = render("cornell-box", DiffuseMode::kFlat);
  Rendered smooth = render("cornell-box", DiffuseMode::kSmooth);
  // The back wall's middle: interpolation redistributes within the wall, it does not add light.
  Rgb a = mean(flat.image, 90, 166, 60, 140), b = mean(smooth.image, 90, 166, 60, 140);
  EXPECT_NEAR(a[0], b[0], 0.03 * a[0]);
}

TEST(CameraGather, IsLinearInTheUnknowns) {
  auto sys = build_system(World::load(test::scene_path("cornell-mirror-cube")));
  Gather g = build_gather(*sys->world, sys->transport.layout(), GatherOptions{});
  Field u1 = Field::Random(sys->transport.size(), 3).cwiseAbs();
  Field u2 = Field::Random(sys->transport.size(), 3).cwiseAbs();
  Image a = apply_gather(g, u1), b = apply_gather(g, u2), ab = apply_gather(g, u1 + 2.0 * u2);
  double worst = 0.0;
  for (size_t k = 0; k < a.rgb.size(); ++k)
    worst =
        std::max(worst, static_cast<double>(std::abs(ab.rgb[k] - (a.rgb[k] + 2.0f * b.rgb[k]))));
  EXPECT_LT(worst, 1e-4);
}

// A glossy floor (no diffuse part) under a small square lamp, seen at an angle so that the lamp's
// highlight fills part of the image; the field u holds the lamp's radiance L on its patches and
// nothing else, so each floor pixel is exactly
//   s * mean over its sub-pixel points x of  integral over the lamp of lobe cos_x cos_y / d^2 L dA,
// which a 64 x 64 midpoint rule on the lamp gives to well under a percent.
struct LampOverGlossyFloor {
  std::unique_ptr<RadiositySystem> sys;
  Field u;
  Image reference;

  explicit LampOverGlossyFloor(double roughness) {
    const std::string json = R"({
      "camera": {"position": [50, 30, 0], "look_at": [50, 0, 20], "up": [0, 1, 0],
                 "fov_deg": 60, "width": 32, "height": 32},
      "patch_size": 25,
      "materials": {
        "lamp": {"type": "diffuse", "reflectance": [0, 0, 0]},
        "floor": {"type": "glossy", "diffuse": [0, 0, 0], "specular": [0.8, 0.8, 0.8],
                  "roughness": )" +
                             std::to_string(roughness) + R"(}
      },
      "objects": [
        {"name": "floor", "material": "floor",
         "polygon": [[100, 0, 0], [0, 0, 0], [0, 0, 100], [100, 0, 100]]},
        {"name": "light", "material": "lamp", "emission": [4, 4, 4], "patch_size": 5,
         "polygon": [[55, 40, 25], [55, 40, 35], [45, 40, 35], [45, 40, 25]]}
      ]})";
    sys = build_system(World::build(test::scene_from_json(json)));
    u = Field::Zero(sys->transport.size(), 3);
    for (PatchId p = 0; p < static_cast<PatchId>(sys->patches().size()); ++p)
      if (sys->patches()[p].emitter) u.row(p).setConstant(4.0);
    reference = exact_image();
  }

  Image gather(int light_samples, int lobe_samples = 16) const {
    GatherOptions go;
    go.lobe_samples = lobe_samples;
    go.diffuse = DiffuseMode::kFlat;
    go.light_samples = light_samples;
    Gather g = build_gather(*sys->world, sys->transport.layout(), go);
    return apply_gather(g, u);
  }

 private:
  Image exact_image() const {
    const Camera& cam = sys->scene().camera;
    const Vec3 corner(45, 40, 25), n(0, -1, 0);
    const int q = 64;
    const double da = 100.0 / (q * q);
    Image img(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        double sum = 0.0;
        for (int a = 0; a < 2; ++a)
          for (int b = 0; b < 2; ++b) {
            Ray ray = cam.ray(x + (a + 0.5) / 2, y + (b + 0.5) / 2);
            Hit hit = sys->world->caster().intersect(ray.origin, ray.direction);
            if (!hit.valid() || sys->patches()[hit.patch].emitter) continue;
            const Material& m = sys->scene().materials[sys->patches()[hit.patch].material];
            Frame frame = Frame::from_normal(Vec3(0, 1, 0));
            Vec3 wo = frame.to_local(-ray.direction);
            for (int i = 0; i < q; ++i)
              for (int j = 0; j < q; ++j) {
                Vec3 d =
                    corner + Vec3(10.0 * (i + 0.5) / q, 0, 10.0 * (j + 0.5) / q) - hit.position;
                double r2 = d.squaredNorm();
                Vec3 wi = d / std::sqrt(r2);
                sum += 0.25 * 0.8 * 4.0 * m.lobe_eval(frame.to_local(wi), wo) * wi.y() *
                       -wi.dot(n) / r2 * da;
              }
          }
        img.set(x, y, Rgb::Constant(sum));
      }
    return img;
  }
};

// Mean relative error over the pixels that show at least 5% of the brightest one, and the
// relative error of their total.
struct HighlightError {
  double pixel = 0.0, total = 0.0;
};
HighlightError highlight_error(const Image& img, const Image& ref) {
  double peak = 0.0;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x) peak = std::max(peak, ref.at(x, y)[1]);
  double sum_err = 0.0, sum = 0.0, sum_ref = 0.0;
  int n = 0;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x) {
      double r = ref.at(x, y)[1];
      if (r < 0.05 * peak) continue;
      sum_err += std::abs(img.at(x, y)[1] - r) / r;
      sum += img.at(x, y)[1];
      sum_ref += r;
      ++n;
    }
  EXPECT_GT(n, 40);
  return {sum_err / n, std::abs(sum - sum_ref) / sum_ref};
}

TEST(CameraGather, LightSamplesRemoveTheSpecklesOfARoughLobeUnderASmallLamp) {
  // GGX alpha 0.3: the lamp covers a small part of the lobe, so 16 lobe samples find it now and
  // then (measured: pixels 103% off on average); 4 points on the lamp besides them: 2.3%.
  LampOverGlossyFloor scene(0.3);
  HighlightError lobe_only = highlight_error(scene.gather(0), scene.reference);
  HighlightError mis = highlight_error(scene.gather(4), scene.reference);
  EXPECT_LT(mis.pixel, 0.05);
  EXPECT_LT(mis.pixel, 0.1 * lobe_only.pixel);
  EXPECT_LT(mis.total, 0.01);
}

TEST(CameraGather, LightAndLobeSamplesTogetherConvergeToTheExactHighlight) {
  // GGX alpha 0.05: lobe and lamp are of a size, so both strategies matter, and the weights
  // must sum to one over every direction for any sample counts: with 256 lobe samples and 64
  // lamp points the highlight converges. Measured: pixels 11.6% and 1.5% off, totals 1.7% and
  // 0.2%; dropping the counts from the lobe samples' weight alone (so that the two weights no
  // longer sum to one) left both totals 38% low.
  LampOverGlossyFloor scene(0.05);
  HighlightError standard = highlight_error(scene.gather(4, 16), scene.reference);
  HighlightError many = highlight_error(scene.gather(64, 256), scene.reference);
  EXPECT_LT(standard.pixel, 0.2);
  EXPECT_LT(standard.total, 0.05);
  EXPECT_LT(many.pixel, 0.03);
  EXPECT_LT(many.total, 0.01);
}

TEST(CameraGather, LightPointsReadTheSameUnknownsAsLobeSamples) {
  // A glossy triangular lamp, so that it has link unknowns S_{lamp->floor} and its patches are
  // triangles; smooth shading, and a field with B varying over the lamp and every S random. Both
  // strategies must read the same radiance B_j (interpolated at the point) + S_{j->i}: the
  // light points with 256 lobe samples against 4096 lobe samples alone, up to the latter's
  // noise (measured: pixels 3.9% apart on average, totals 0.2%; with the light points reading
  // S_{i->j} instead, 16% and 15%).
  const std::string json = R"({
    "camera": {"position": [50, 30, 0], "look_at": [50, 0, 20], "up": [0, 1, 0],
               "fov_deg": 60, "width": 20, "height": 20},
    "patch_size": 25,
    "materials": {
      "lamp": {"type": "glossy", "diffuse": [0.2, 0.2, 0.2], "specular": [0.5, 0.5, 0.5],
               "roughness": 0.3},
      "floor": {"type": "glossy", "diffuse": [0, 0, 0], "specular": [0.8, 0.8, 0.8],
                "roughness": 0.3}
    },
    "objects": [
      {"name": "floor", "material": "floor",
       "polygon": [[100, 0, 0], [0, 0, 0], [0, 0, 100], [100, 0, 100]]},
      {"name": "light", "material": "lamp", "emission": [4, 4, 4], "patch_size": 4,
       "polygon": [[56, 40, 24], [56, 40, 36], [44, 40, 30]]}
    ]})";
  auto sys = build_system(World::build(test::scene_from_json(json)));
  const UnknownLayout& layout = sys->transport.layout();
  Field u = Field::Zero(sys->transport.size(), 3);
  Rng rng(5);
  int lamp_links = 0;
  for (PatchId p = 0; p < static_cast<PatchId>(sys->patches().size()); ++p) {
    if (!sys->patches()[p].emitter) continue;
    ASSERT_TRUE(sys->patches()[p].is_triangle());
    u.row(p).setConstant(0.5 + rng.uniform());
    lamp_links += static_cast<int>(layout.link_start[p + 1] - layout.link_start[p]);
  }
  ASSERT_GT(lamp_links, 0);
  for (Eigen::Index k = layout.num_patches; k < u.rows(); ++k) u.row(k).setConstant(rng.uniform());
  auto gather = [&](int light_samples, int lobe_samples) {
    GatherOptions go;
    go.light_samples = light_samples;
    go.lobe_samples = lobe_samples;
    Gather g = build_gather(*sys->world, sys->transport.layout(), go);
    return apply_gather(g, u);
  };
  HighlightError e = highlight_error(gather(64, 256), gather(0, 4096));
  EXPECT_LT(e.pixel, 0.1);
  EXPECT_LT(e.total, 0.02);
}

}  // namespace
}  // namespace polyrad
