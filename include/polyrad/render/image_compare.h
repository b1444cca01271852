// Figures of how far an image A is from a reference B of the same size, over the whole picture
// and over named regions (the scene objects the camera sees), and pictures of the difference.
//
// Per channel c, with the floor eps_c = epsilon_fraction * (mean of B's channel c), which keeps
// black or nearly black pixels of B from dominating a relative figure:
//   relative RMSE        sqrt( mean over pixels and channels of (a - b)^2 / (b^2 + eps_c^2) )
//   mean relative error  mean over pixels and channels of |a - b| / (|b| + eps_c)
//   normalized RMSE      sqrt( mean over pixels and channels of ((a - b) / mean_c(B))^2 )
// A pixel's error (worst pixels, the error picture) is the signed relative luminance error
//   e = (lum(a) - lum(b)) / (lum(b) + epsilon_fraction * mean lum(B)).
// A region's figure is the relative difference of its means, (mean_A - mean_B) / mean_B, per
// channel and in luminance. The region of a pixel is the object its primary ray meets, if the
// rays of its 3 x 3 neighbourhood meet the same one (object_regions): edge pixels, which mix
// objects, and pixels that see nothing or a back side belong to none.
//
//   RegionMap regions = object_regions(*world);
//   ImageComparison c = compare_images(radiosity, reference, {}, &regions);
//   write_image(error_picture(radiosity, reference, 0.25, 0.01), "err.png");
//
// Cost: O(pixels) time and memory (object_regions: one ray a pixel).
#pragma once

#include <string>
#include <vector>

#include "polyrad/render/image.h"
#include "polyrad/world/world.h"

namespace polyrad {

// A label per pixel (row-major from the top-left, -1: no region) and the labels' names.
struct RegionMap {
  int width = 0, height = 0;
  std::vector<int> label;
  std::vector<std::string> names;
};

// Regions = scene objects, by the primary ray of each pixel of scene.camera, less a one-pixel
// margin along every edge between objects.
RegionMap object_regions(const World& world);

struct CompareOptions {
  double epsilon_fraction = 0.01;  // floor of relative errors, as a fraction of B's mean
  int worst_pixels = 10;           // how many of the worst pixels to list
};

struct RegionFigures {
  std::string name;
  long long pixels = 0;
  Rgb mean_a = Rgb::Zero(), mean_b = Rgb::Zero();
  Rgb relative_difference = Rgb::Zero();  // (mean_a - mean_b) / mean_b; NaN where mean_b is 0
  double luminance_difference = 0.0;      // the same for luminance
  // sum |a - b| / sum |b| over the region's pixels and channels: light moved within the region
  // (a smeared reflection) shows here even when the means agree.
  double relative_l1 = 0.0;
};

struct PixelError {
  int x = 0, y = 0;
  Rgb a = Rgb::Zero(), b = Rgb::Zero();
  double error = 0.0;  // signed relative luminance error e
};

struct ImageComparison {
  int width = 0, height = 0;
  Rgb epsilon = Rgb::Zero();  // eps_c
  double relative_rmse = 0.0;
  double mean_relative_error = 0.0;
  double normalized_rmse = 0.0;
  // sum |a - b| / sum |b| over pixels and channels (no floor: bright regions weigh by their
  // brightness, as an eye comparing totals would).
  double relative_l1 = 0.0;
  Rgb mean_a = Rgb::Zero(), mean_b = Rgb::Zero();
  std::vector<RegionFigures> regions;  // the regions that have pixels, in label order
  long long pixels_without_region = 0;
  double worst_region_difference = 0.0;  // largest |luminance_difference| over the regions
  std::vector<PixelError> worst;         // largest |e| first
};

// Throws InputError if the sizes differ (or the region map's size differs) or a pixel of either
// image is not finite.
ImageComparison compare_images(const Image& a, const Image& b, const CompareOptions& options = {},
                               const RegionMap* regions = nullptr);

// False-colour picture of e: white at 0, toward red where A is brighter and toward blue where A
// is darker, full colour at |e| >= scale; black where both pixels are 0. Linear values, so that
// write_image(..., ".png") with exposure 1 shows exactly these colours.
Image error_picture(const Image& a, const Image& b, double scale, double epsilon_fraction = 0.01);

// A | B | error side by side with a black gap: A and B multiplied by exposure, the error
// picture as it is; display-ready for a .png.
Image side_by_side(const Image& a, const Image& b, const Image& error, double exposure = 1.0,
                   int gap = 4);

}  // namespace polyrad
