#include "polyrad/camera_gather.h"

#include <gtest/gtest.h>

#include "polyrad/pipeline.h"
#include "polyrad/solver.h"
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
  PipelineOptions po;
  po.specular_transport = !classic;
  r.sys = build_system(load_scene(test::scene_path(scene)), po);
  r.solution = solve(r.sys->transport, r.sys->transport.emission(), SolveOptions{});
  GatherOptions go;
  go.diffuse = mode;
  go.specular = !classic;
  Gather g = build_gather(r.sys->scene.camera, r.sys->patches, r.sys->scene.materials,
                          *r.sys->caster, r.sys->transport, go);
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
  EXPECT_GT(left[0], 3 * left[1]);   // red wall
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
  auto sys = build_system(load_scene(test::scene_path("cornell-mirror-cube")));
  Gather g = build_gather(sys->scene.camera, sys->patches, sys->scene.materials, *sys->caster,
                          sys->transport, GatherOptions{});
  Field u1 = Field::Random(sys->transport.size(), 3).cwiseAbs();
  Field u2 = Field::Random(sys->transport.size(), 3).cwiseAbs();
  Image a = apply_gather(g, u1), b = apply_gather(g, u2), ab = apply_gather(g, u1 + 2.0 * u2);
  double worst = 0.0;
  for (size_t k = 0; k < a.rgb.size(); ++k)
    worst = std::max(worst, static_cast<double>(std::abs(ab.rgb[k] - (a.rgb[k] + 2.0f * b.rgb[k]))));
  EXPECT_LT(worst, 1e-4);
}

}  // namespace
}  // namespace polyrad
