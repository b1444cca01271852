#include "polyrad/io/image_io.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "polyrad/util/error.h"
#include "test_support.h"

namespace polyrad {
namespace {

Image gradient() {
  Image img(7, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) img.set(x, y, Rgb(0.1 * x, 0.2 * y, 3.5));
  return img;
}

TEST(ImageIo, PfmRoundTripsExactlyAndKeepsTheTopRowOnTop) {
  auto dir = test::temp_dir();
  Image img = gradient();
  write_image(img, (dir / "a.pfm").string());
  Image back = read_image((dir / "a.pfm").string());
  ASSERT_EQ(back.width, 7);
  ASSERT_EQ(back.height, 5);
  EXPECT_EQ(back.rgb, img.rgb);
}

TEST(ImageIo, ExrRoundTripsAtHalfPrecision) {
  auto dir = test::temp_dir();
  Image img = gradient();
  write_image(img, (dir / "a.exr").string());
  Image back = read_image((dir / "a.exr").string());
  ASSERT_EQ(back.rgb.size(), img.rgb.size());
  for (size_t k = 0; k < img.rgb.size(); ++k)
    EXPECT_NEAR(back.rgb[k], img.rgb[k], 1e-3 * (1 + img.rgb[k]));
  EXPECT_NEAR(back.at(6, 0)[0], 0.6, 1e-3);  // orientation
}

TEST(ImageIo, PngIsTonemappedSrgb) {
  auto dir = test::temp_dir();
  Image img(2, 1);
  img.set(0, 0, Rgb(0.0, 0.5, 2.0));
  img.set(1, 0, Rgb(0.0031308, 0.214, 1.0));
  write_image(img, (dir / "a.png").string());
  Image back = read_image((dir / "a.png").string());
  EXPECT_NEAR(back.at(0, 0)[0], 0.0, 1e-6);
  EXPECT_NEAR(back.at(0, 0)[1], 188.0 / 255.0, 1.0 / 255.0);  // sRGB(0.5)
  EXPECT_NEAR(back.at(0, 0)[2], 1.0, 1e-6);                   // clamped
  EXPECT_NEAR(back.at(1, 0)[1], 128.0 / 255.0, 1.0 / 255.0);  // sRGB(0.214) ~ 0.5
}

TEST(ImageIo, BadPathsFailCleanlyAndLeaveNothing) {
  auto dir = test::temp_dir();
  Image img = gradient();
  EXPECT_THROW(write_image(img, (dir / "a.bmp").string()), InputError);
  EXPECT_ANY_THROW(write_image(img, (dir / "missing" / "a.exr").string()));
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  EXPECT_THROW(read_image((dir / "none.pfm").string()), InputError);
  test::write_file(dir, "short.pfm", "PF\n4 4\n-1.0\nabc");
  EXPECT_THROW(read_image((dir / "short.pfm").string()), InputError);
}

}  // namespace
}  // namespace polyrad
