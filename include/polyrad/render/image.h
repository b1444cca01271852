// A linear-radiance image: what every renderer of polyrad returns (files: io/image_io.h).
//
//   Image img(256, 256);
//   img.set(x, y, Rgb(0.5, 0.2, 0.1));
//   if (!img.all_finite()) ...
//
// Cost: 12 bytes per pixel.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "polyrad/types.h"

namespace polyrad {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // row-major from the top-left pixel, 3 floats a pixel

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgb(3 * static_cast<size_t>(w) * h, 0.0f) {}
  Rgb at(int x, int y) const {
    const float* p = &rgb[3 * (static_cast<size_t>(y) * width + x)];
    return Rgb(p[0], p[1], p[2]);
  }
  void set(int x, int y, const Rgb& c) {
    float* p = &rgb[3 * (static_cast<size_t>(y) * width + x)];
    p[0] = static_cast<float>(c[0]);
    p[1] = static_cast<float>(c[1]);
    p[2] = static_cast<float>(c[2]);
  }
  bool all_finite() const {
    return std::all_of(rgb.begin(), rgb.end(), [](float v) { return std::isfinite(v); });
  }
};

}  // namespace polyrad
