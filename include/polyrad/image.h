// Linear-radiance images and the files they go to.
//
// The extension picks the format: .exr (half-float OpenEXR) and .pfm (float) keep linear
// radiance; .png gets a tonemapped sRGB picture (radiance * exposure, clamped, sRGB curve).
// Every write is all-or-nothing (files.h).
//
//   Image img(256, 256);
//   img.set(x, y, Rgb(0.5, 0.2, 0.1));
//   write_image(img, "out/cornell.png");
//
// Cost: 12 bytes per pixel.
#pragma once

#include <array>
#include <string>
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
  bool all_finite() const;
};

struct ImageWriteOptions {
  double exposure = 1.0;  // multiplies radiance before the .png tonemap
};

// Throws InputError for an unknown extension, std::runtime_error if the file cannot be written.
void write_image(const Image& image, const std::string& path, const ImageWriteOptions& options = {});
Image read_image(const std::string& path);
// True if write_image knows the extension of path.
bool is_image_path(const std::string& path);

// sRGB encoding of linear c * exposure, clamped to [0, 1], as 8-bit values.
std::array<unsigned char, 3> to_srgb8(const Rgb& c, double exposure);

}  // namespace polyrad
