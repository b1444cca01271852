// Image files (io/image_io.h): OpenEXR and PNG through the codec module (io/image_codec.h), PFM
// written and read here.
#include "polyrad/io/image_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "polyrad/io/image_codec.h"
#include "polyrad/io/image_encoding.h"
#include "polyrad/util/error.h"
#include "polyrad/util/files.h"

namespace polyrad {

namespace {

std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

double srgb_encode(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}

void write_pfm(const Image& image, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot create " + path);
  // PFM: "PF", size, negative scale for little-endian, then rows from the bottom up.
  bool ok = std::fprintf(f, "PF\n%d %d\n-1.0\n", image.width, image.height) > 0;
  for (int y = image.height - 1; y >= 0 && ok; --y)
    ok = std::fwrite(&image.rgb[3 * static_cast<size_t>(y) * image.width], sizeof(float),
                     3 * static_cast<size_t>(image.width),
                     f) == 3 * static_cast<size_t>(image.width);
  ok = (std::fclose(f) == 0) && ok;
  if (!ok) throw std::runtime_error("cannot write " + path);
}

Image read_pfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(SourceLocation{path}, "cannot open the image");
  std::string magic;
  int w = 0, h = 0;
  double scale = 0.0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (magic != "PF" || w <= 0 || h <= 0 || w > 65536 || h > 65536 || scale == 0.0)
    throw InputError(SourceLocation{path}, "not a colour PFM image");
  if (scale > 0.0) throw InputError(SourceLocation{path}, "big-endian PFM is not supported");
  Image img(w, h);
  for (int y = h - 1; y >= 0; --y)
    if (!in.read(reinterpret_cast<char*>(&img.rgb[3 * static_cast<size_t>(y) * w]),
                 static_cast<std::streamsize>(3 * sizeof(float) * w)))
      throw InputError(SourceLocation{path}, "the PFM image is truncated");
  return img;
}

void write_coded(const Image& image, const std::string& path, bool png, double exposure) {
  // A .png holds 8-bit sRGB, by the same table the relighting page encodes with (its values
  // are to_srgb8's, below).
  const std::string bytes = png ? tonemap_srgb8(image, exposure) : std::string();
  const void* pixels = png ? static_cast<const void*>(bytes.data()) : image.rgb.data();
  std::string error;
  if (!image_codec().write(path.c_str(), image.width, image.height, png, pixels, &error))
    throw std::runtime_error("cannot write " + path + ": " + error);
}

}  // namespace

std::array<unsigned char, 3> to_srgb8(const Rgb& c, double exposure) {
  std::array<unsigned char, 3> out;
  for (int k = 0; k < 3; ++k)
    out[k] = static_cast<unsigned char>(std::lround(255.0 * srgb_encode(c[k] * exposure)));
  return out;
}

bool is_image_path(const std::string& path) {
  std::string ext = extension_of(path);
  return ext == ".exr" || ext == ".pfm" || ext == ".png";
}

bool image_needs_codec(const std::string& path) {
  const std::string ext = extension_of(path);
  return ext == ".exr" || ext == ".png";
}

void write_image(const Image& image, const std::string& path, const ImageWriteOptions& options) {
  std::string ext = extension_of(path);
  if (!is_image_path(path))
    throw InputError(SourceLocation{path},
                     "unknown image format '" + ext + "' (use .exr, .pfm or .png)");
  AtomicFile file(path);
  if (ext == ".pfm")
    write_pfm(image, file.temp_path());
  else
    write_coded(image, file.temp_path(), ext == ".png", options.exposure);
  file.commit();
}

Image read_image(const std::string& path) {
  if (extension_of(path) == ".pfm") return read_pfm(path);
  int width = 0, height = 0, channels = 0;
  std::vector<float> all;
  std::string error;
  if (!image_codec().read(path.c_str(), &width, &height, &channels, &all, &error))
    throw InputError(SourceLocation{path}, "cannot read the image: " + error);
  if (channels < 3) throw InputError(SourceLocation{path}, "the image has fewer than 3 channels");
  Image img(width, height);
  for (size_t p = 0; p < static_cast<size_t>(width) * height; ++p)
    for (int c = 0; c < 3; ++c) img.rgb[3 * p + c] = all[p * channels + c];
  return img;
}

}  // namespace polyrad
