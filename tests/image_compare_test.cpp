// Image comparison figures on synthetic images with known answers, and `polyrad compare`.
#include "polyrad/render/image_compare.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "polyrad/io/image_io.h"
#include "polyrad/util/files.h"
#include "polyrad/util/json.h"
#include "test_support.h"

namespace polyrad {
namespace {

Image constant(int w, int h, const Rgb& c) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.set(x, y, c);
  return img;
}

TEST(ImageCompare, IdenticalImagesHaveNoError) {
  Image a = constant(8, 6, Rgb(0.3, 0.2, 0.1));
  ImageComparison c = compare_images(a, a);
  EXPECT_EQ(c.relative_rmse, 0.0);
  EXPECT_EQ(c.mean_relative_error, 0.0);
  EXPECT_EQ(c.normalized_rmse, 0.0);
  ASSERT_EQ(c.worst.size(), 10u);
  EXPECT_EQ(c.worst[0].error, 0.0);
}

TEST(ImageCompare, UniformScaleGivesThatRelativeError) {
  // A = 1.1 B everywhere: every relative figure is 0.1 / (1 + epsilon_fraction), the normalized
  // RMSE exactly 0.1.
  Image b = constant(10, 10, Rgb(2.0, 1.0, 0.5));
  Image a = constant(10, 10, Rgb(2.2, 1.1, 0.55));
  CompareOptions o;
  o.epsilon_fraction = 0.0;
  ImageComparison c = compare_images(a, b, o);
  EXPECT_NEAR(c.relative_rmse, 0.1, 1e-6);
  EXPECT_NEAR(c.mean_relative_error, 0.1, 1e-6);
  EXPECT_NEAR(c.normalized_rmse, 0.1, 1e-6);
  EXPECT_NEAR(c.worst[0].error, 0.1, 1e-6);
  o.epsilon_fraction = 0.01;
  c = compare_images(a, b, o);
  EXPECT_NEAR(c.mean_relative_error, 0.1 / 1.01, 1e-6);
  EXPECT_NEAR(c.relative_rmse, 0.1 / std::sqrt(1.0 + 1e-4), 1e-6);
}

TEST(ImageCompare, KnownFiguresOfATwoValuedImage) {
  // B = 1 everywhere; A = 1 except one pixel in four, which is 3 (relative error 2).
  // relative RMSE = sqrt(4 / 4) = 1, mean relative error = 2 / 4 = 0.5.
  Image b = constant(4, 4, Rgb(1, 1, 1));
  Image a = b;
  for (int y = 0; y < 4; y += 2)
    for (int x = 0; x < 4; x += 2) a.set(x, y, Rgb(3, 3, 3));
  CompareOptions o;
  o.epsilon_fraction = 0.0;
  o.worst_pixels = 3;
  ImageComparison c = compare_images(a, b, o);
  EXPECT_NEAR(c.relative_rmse, 1.0, 1e-12);
  EXPECT_NEAR(c.mean_relative_error, 0.5, 1e-12);
  EXPECT_NEAR(c.normalized_rmse, 1.0, 1e-12);
  ASSERT_EQ(c.worst.size(), 3u);
  EXPECT_EQ(c.worst[0].x, 0);
  EXPECT_EQ(c.worst[0].y, 0);
  EXPECT_EQ(c.worst[1].x, 2);  // ties in reading order
  EXPECT_NEAR(c.worst[0].error, 2.0, 1e-12);
  EXPECT_NEAR(c.mean_a[0], 1.5, 1e-12);
}

TEST(ImageCompare, EpsilonKeepsBlackPixelsFromDominating) {
  // One black pixel of B where A is 0.01: with the floor it weighs 0.01 / (0.01 * mean).
  Image b = constant(10, 10, Rgb(1, 1, 1));
  b.set(0, 0, Rgb(0, 0, 0));
  Image a = b;
  a.set(0, 0, Rgb(0.01, 0.01, 0.01));
  ImageComparison c = compare_images(a, b);
  double eps = 0.01 * 0.99;
  EXPECT_NEAR(c.epsilon[0], eps, 1e-12);
  EXPECT_NEAR(c.mean_relative_error, 0.01 / eps / 100.0, 1e-9);
  EXPECT_TRUE(std::isfinite(c.relative_rmse));
}

TEST(ImageCompare, RegionMeansAndDifferences) {
  Image b = constant(4, 2, Rgb(1, 1, 1));
  Image a = b;
  for (int y = 0; y < 2; ++y) a.set(2, y, Rgb(1.5, 1.5, 1.5)), a.set(3, y, Rgb(0.5, 1.0, 1.0));
  RegionMap map;
  map.width = 4;
  map.height = 2;
  map.names = {"left", "right", "unseen"};
  map.label = {0, 0, 1, 1, 0, 0, 1, -1};
  ImageComparison c = compare_images(a, b, {}, &map);
  ASSERT_EQ(c.regions.size(), 2u);  // "unseen" has no pixel
  EXPECT_EQ(c.regions[0].name, "left");
  EXPECT_EQ(c.regions[0].pixels, 4);
  EXPECT_NEAR(c.regions[0].luminance_difference, 0.0, 1e-12);
  EXPECT_EQ(c.regions[1].pixels, 3);
  // right: pixels (2,0) 1.5, (3,0) (0.5,1,1), (2,1) 1.5 -> mean red (1.5+0.5+1.5)/3.
  EXPECT_NEAR(c.regions[1].mean_a[0], 3.5 / 3.0, 1e-7);
  EXPECT_NEAR(c.regions[1].relative_difference[0], 0.5 / 3.0, 1e-7);
  EXPECT_NEAR(c.regions[1].relative_difference[1], 1.0 / 3.0, 1e-7);
  EXPECT_EQ(c.pixels_without_region, 1);
  EXPECT_NEAR(c.worst_region_difference, std::abs(c.regions[1].luminance_difference), 1e-15);
  // Relative L1 per region: left is exact; in right, the two pixels at 1.5 are 0.5 off in three
  // channels each and (3,0) 0.5 off in red: 3.5 over nine values of 1.
  EXPECT_EQ(c.regions[0].relative_l1, 0.0);
  EXPECT_NEAR(c.regions[1].relative_l1, (1.5 + 0.5 + 1.5) / 9.0, 1e-7);
}

TEST(ImageCompare, DifferentSizesAreAnInputError) {
  EXPECT_THROW(compare_images(Image(4, 4), Image(4, 5)), InputError);
  EXPECT_THROW(error_picture(Image(4, 4), Image(5, 4), 0.25), InputError);
  Image nan = constant(2, 2, Rgb(1, 1, 1));
  nan.rgb[0] = std::nanf("");
  EXPECT_THROW(compare_images(nan, constant(2, 2, Rgb(1, 1, 1))), InputError);
}

TEST(ImageCompare, ErrorPictureColours) {
  Image b = constant(3, 1, Rgb(1, 1, 1));
  Image a = b;
  a.set(0, 0, Rgb(2, 2, 2));        // brighter: red
  a.set(1, 0, Rgb(0.5, 0.5, 0.5));  // darker: blue
  Image e = error_picture(a, b, 0.25, 0.0);
  EXPECT_GT(e.at(0, 0)[0], 3 * e.at(0, 0)[2]);
  EXPECT_GT(e.at(1, 0)[2], 3 * e.at(1, 0)[0]);
  EXPECT_NEAR(e.at(2, 0)[0], 1.0, 1e-6);  // no error: white
  EXPECT_NEAR(e.at(2, 0)[2], 1.0, 1e-6);
  Image s = side_by_side(a, b, e, 2.0, 1);
  EXPECT_EQ(s.width, 3 * 3 + 2);
  EXPECT_NEAR(s.at(0, 0)[0], 4.0, 1e-6);
  EXPECT_NEAR(s.at(4, 0)[0], 2.0, 1e-6);
  EXPECT_EQ(s.at(3, 0)[0], 0.0f);  // the gap
  EXPECT_NEAR(s.at(8, 0)[0], e.at(0, 0)[0], 1e-6);
}

TEST(ImageCompare, ObjectRegionsOfTheCornellBox) {
  Scene scene = load_scene(test::scene_path("cornell-box"));
  scene.camera.width = scene.camera.height = 32;
  RegionMap map = object_regions(*World::build(std::move(scene)));
  ASSERT_EQ(map.label.size(), 32u * 32u);
  auto name_at = [&](int x, int y) {
    int l = map.label[static_cast<size_t>(y) * 32 + x];
    return l < 0 ? std::string("-") : map.names[l];
  };
  EXPECT_EQ(name_at(3, 16), "red_wall");  // the red wall is on the left
  EXPECT_EQ(name_at(28, 16), "green_wall");
  EXPECT_EQ(name_at(4, 29), "floor");
  EXPECT_EQ(name_at(16, 2), "ceiling");
  EXPECT_EQ(name_at(16, 10), "back_wall");
  // Along row 10 the red wall gives way to the back wall only through unlabelled edge pixels.
  std::string last;
  for (int x = 3; x <= 16; ++x) {
    std::string here = name_at(x, 10);
    if (here != "-" && !last.empty() && last != "-") {
      EXPECT_EQ(here, last) << "x " << x;
    }
    last = here;
  }
}

// ---- the command line ------------------------------------------------------------------------

TEST(ImageCompare, CommandLineWritesReportAndPictures) {
  auto dir = test::temp_dir();
  Scene scene = load_scene(test::scene_path("furnace"));
  const int w = scene.camera.width, h = scene.camera.height;
  std::string a = (dir / "a.pfm").string(), b = (dir / "b.pfm").string();
  write_image(constant(w, h, Rgb(2.2, 2.2, 2.2)), a);
  write_image(constant(w, h, Rgb(2, 2, 2)), b);
  std::string rep = (dir / "r.json").string(), heat = (dir / "h.png").string(),
              sbs = (dir / "s.png").string();
  const test::CommandRun run =
      test::run_cli("compare " + a + " " + b + " --scene " + test::scene_path("furnace") +
                    " --report " + rep + " --heatmap " + heat + " --side-by-side " + sbs);
  ASSERT_EQ(run.code, 0) << run.err;
  EXPECT_TRUE(std::filesystem::exists(heat));
  EXPECT_TRUE(std::filesystem::exists(sbs));
  Image s = read_image(sbs);
  EXPECT_EQ(s.width, 3 * w + 8);
  const JsonValue report = test::read_json(rep);
  EXPECT_EQ(report.find("inputs")->find("a")->string, a);
  ASSERT_NE(report.find("comparison"), nullptr);
  const JsonValue& r = *report.find("comparison");
  EXPECT_NEAR(r.find("normalized_rmse")->number, 0.1, 1e-6);
  ASSERT_NE(r.find("regions"), nullptr);
  EXPECT_GE(r.find("regions")->array.size(), 4u);  // the walls the camera sees
  for (const auto& region : r.find("regions")->array)
    EXPECT_NEAR(region.find("luminance_difference")->number, 0.1, 1e-6);
  EXPECT_NE(r.find("worst_pixels"), nullptr);
}

TEST(ImageCompare, CommandLineRefusesImagesOfDifferentSizes) {
  auto dir = test::temp_dir();
  std::string a = (dir / "a.pfm").string(), b = (dir / "b.pfm").string();
  write_image(constant(8, 8, Rgb(1, 1, 1)), a);
  write_image(constant(8, 9, Rgb(1, 1, 1)), b);
  std::string rep = (dir / "r.json").string();
  test::CommandRun run = test::run_cli("compare " + a + " " + b + " --report " + rep);
  EXPECT_EQ(run.code, 2) << run.err;
  std::string out = run.out + run.err;
  EXPECT_FALSE(std::filesystem::exists(rep));
  EXPECT_NE(out.find("differ in size"), std::string::npos) << out;
  // A scene whose camera does not match the images is bad input too.
  run = test::run_cli("compare " + a + " " + a + " --scene " + test::scene_path("furnace"));
  EXPECT_EQ(run.code, 2) << run.err;
}

}  // namespace
}  // namespace polyrad
