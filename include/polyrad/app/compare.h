// Comparing an image with a reference, as one library call: the workflow behind
// `polyrad compare`. Reads both images, labels the pixels by the object they see when a scene
// is given (render/image_compare.h, object_regions), measures, and draws the error pictures
// when asked.
//
//   CompareFilesOptions o;
//   o.scene = "scenes/cornell-box.json";
//   CompareResult c = compare_files("radiosity.exr", "reference.exr", o);
//   double rmse = c.comparison.relative_rmse;
//
// Throws InputError when an image cannot be read, the sizes differ, or a pixel is not finite.
// Cost: O(pixels), plus one ray a pixel for the regions.
#pragma once

#include <string>

#include "polyrad/app/report.h"
#include "polyrad/render/image_compare.h"

namespace polyrad {

struct CompareFilesOptions {
  std::string scene;          // "": no regions
  CompareOptions compare;     // epsilon, worst pixels
  bool pictures = false;      // draw the error picture and A | B | error
  double error_scale = 0.25;  // relative error shown at full colour
  double exposure = 1.0;      // of A and B in the side-by-side picture
};

struct CompareResult {
  ImageComparison comparison;
  Image error_picture, side_by_side;  // when asked for
  Report report;
};

CompareResult compare_files(const std::string& a, const std::string& b,
                            const CompareFilesOptions& options);

}  // namespace polyrad
