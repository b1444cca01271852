// Images encoded in memory (io/image_encoding.h).
#include "polyrad/io/image_encoding.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

#include "polyrad/io/image_codec.h"
#include "polyrad/io/image_io.h"

namespace polyrad {

namespace {

int reference_value(double x) { return to_srgb8(Rgb(x, x, x), 1.0)[0]; }

// The least non-negative double x with reference_value(x) >= v (v in 1..255), by bisection on
// the bit patterns, which order non-negative doubles as their values.
double least_input(int v) {
  std::uint64_t lo = 0, hi = 0;  // reference_value(lo) < v <= reference_value(hi)
  const double one = 1.0;
  std::memcpy(&hi, &one, sizeof hi);
  while (hi - lo > 1) {
    std::uint64_t mid = lo + (hi - lo) / 2;
    double x;
    std::memcpy(&x, &mid, sizeof x);
    (reference_value(x) >= v ? hi : lo) = mid;
  }
  double x;
  std::memcpy(&x, &hi, sizeof x);
  return x;
}

}  // namespace

Srgb8Table::Srgb8Table() {
  least_[0] = -std::numeric_limits<double>::infinity();
  for (int v = 1; v <= 255; ++v) least_[v] = least_input(v);
  least_[256] = std::numeric_limits<double>::infinity();
  int v = 0;
  for (int b = 0; b < kBuckets; ++b) {
    const double lower = static_cast<double>(b) / kBuckets;
    while (least_[v + 1] <= lower) ++v;
    start_[b] = static_cast<unsigned char>(v);
  }
}

unsigned char Srgb8Table::operator()(double x) const {
  if (!(x > 0.0)) return 0;
  if (x >= 1.0) return 255;
  int v = start_[static_cast<int>(x * kBuckets)];
  while (least_[v + 1] <= x) ++v;  // once at most: the curve rises under 1 value per bucket
  return static_cast<unsigned char>(v);
}

const Srgb8Table& srgb8_table() {
  static const Srgb8Table table;
  return table;
}

std::string tonemap_srgb8(const Image& image, double exposure) {
  const Srgb8Table& t = srgb8_table();
  std::string bytes(image.rgb.size(), '\0');
  for (std::size_t k = 0; k < image.rgb.size(); ++k)
    bytes[k] = static_cast<char>(t(image.rgb[k] * exposure));
  return bytes;
}

std::string encode_png(const Image& image, double exposure, PngEncoding encoding) {
  const std::string pixels = tonemap_srgb8(image, exposure);
  std::string bytes, error;
  if (!image_codec().encode_png(image.width, image.height,
                                reinterpret_cast<const unsigned char*>(pixels.data()),
                                encoding == PngEncoding::kFast, &bytes, &error))
    throw std::runtime_error("cannot encode the PNG: " + error);
  return bytes;
}

std::string encode_pfm(const Image& image) {
  // As write_image writes .pfm: "PF", the size, -1 for little-endian, rows from the bottom up.
  char header[64];
  const int n =
      std::snprintf(header, sizeof header, "PF\n%d %d\n-1.0\n", image.width, image.height);
  const std::size_t row = 3 * sizeof(float) * static_cast<std::size_t>(image.width);
  std::string bytes(header, static_cast<std::size_t>(n));
  bytes.resize(bytes.size() + row * image.height);
  char* p = bytes.data() + n;
  for (int y = image.height - 1; y >= 0; --y, p += row)
    std::memcpy(p, &image.rgb[3 * static_cast<std::size_t>(y) * image.width], row);
  return bytes;
}

}  // namespace polyrad
