// Image files: the extension picks the format. .exr (half-float OpenEXR) and .pfm (float) keep
// linear radiance; .png gets a tonemapped sRGB picture (radiance * exposure, clamped, sRGB
// curve). Every write is all-or-nothing (util/files.h). .exr and .png go through the codec
// module, loaded with the first of them (io/image_codec.h); .pfm is read and written here.
//
//   write_image(img, "out/cornell.png", {.exposure = 2.0});
//   Image back = read_image("out/cornell.exr");
//
// Cost: one pass over the pixels; PNG and EXR compression dominate, and the first .exr or .png
// of a process loads the codec (0.35 to 0.8 s and 110 MiB, io/image_codec.h).
#pragma once

#include <array>
#include <string>

#include "polyrad/render/image.h"

namespace polyrad {

struct ImageWriteOptions {
  double exposure = 1.0;  // multiplies radiance before the .png tonemap
};

// Throws InputError for an unknown extension, std::runtime_error if the file cannot be written.
void write_image(const Image& image, const std::string& path,
                 const ImageWriteOptions& options = {});
Image read_image(const std::string& path);
// True if write_image knows the extension of path.
bool is_image_path(const std::string& path);
// True if writing path loads the codec module (.exr, .png; io/image_codec.h): a workflow's
// memory estimate counts the module's 110 MiB only then.
bool image_needs_codec(const std::string& path);

// sRGB encoding of linear c * exposure, clamped to [0, 1], as 8-bit values.
std::array<unsigned char, 3> to_srgb8(const Rgb& c, double exposure);

}  // namespace polyrad
