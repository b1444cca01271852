// Images encoded in memory, for answers that never touch the disk (`polyrad serve`,
// serve/relight_server.h).
//
// encode_pfm gives the bytes `write_image(img, "x.pfm")` writes; encode_png the pixels
// `write_image(img, "x.png", {exposure})` writes (the same tonemap, value for value: radiance x
// exposure, clamped, sRGB curve, rounded to 8 bits), by default compressed faster than the file
// writer does. In memory, because a temporary file written and read back took 1.3 times as long.
//
//   std::string png = encode_png(relit.image, 1.5);
//   std::string pfm = encode_pfm(relit.image);
//
// Cost: encode_pfm one copy (12 bytes a pixel); encode_png the tonemap by table (no pow per
// value, 0.7 ms at 256 x 256 here) and libpng through OpenImageIO in the codec module
// (io/image_codec.h; 1.5 ms, see PngEncoding).
#pragma once

#include <array>
#include <string>

#include "polyrad/render/image.h"

namespace polyrad {

// The tonemap of write_image's PNG, exactly, without a pow per value: for each 8-bit value the
// least linear input that reaches it, found once by bisection against to_srgb8 (io/image_io.h).
class Srgb8Table {
 public:
  Srgb8Table();
  // to_srgb8(Rgb(x, x, x), 1.0)[0], for x = radiance * exposure.
  unsigned char operator()(double x) const;

 private:
  static constexpr int kBuckets = 4096;  // over [0, 1); at most one step of 8 bits per bucket
  std::array<double, 257> least_{};      // least_[v]: least x giving v (least_[0] = -inf)
  std::array<unsigned char, kBuckets> start_{};  // the value at each bucket's lower end
};

const Srgb8Table& srgb8_table();

// The tonemapped 8-bit RGB values, row-major from the top-left pixel.
std::string tonemap_srgb8(const Image& image, double exposure);

// How hard the PNG is compressed. kFast: each row predicted from the one above ("up" filter)
// and zlib level 1, about 1.5 ms at 256 x 256 here and 1.4 times the bytes; kCompact: as
// write_image does (libpng's adaptive filters, level 6), about 10 ms. On a loopback connection
// the bytes cost far less than the time.
enum class PngEncoding { kFast, kCompact };

std::string encode_png(const Image& image, double exposure,
                       PngEncoding encoding = PngEncoding::kFast);
std::string encode_pfm(const Image& image);

}  // namespace polyrad
