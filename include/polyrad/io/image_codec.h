// The codecs behind .exr and .png (io/image_io.h, io/image_encoding.h): OpenImageIO, in a module
// of its own, libpolyrad_image_codec.so, which polyrad loads the first time an .exr or a .png
// is read, written or encoded. Why a module: OpenImageIO brings some 260 shared libraries, and
// linked into the program they cost every process 0.35 s at its start (0.8 s from a cold cache)
// and about 110 MiB of resident memory from then on: in runs that write no image or only .pfm
// too (`precompute`, `serve` before its first PNG), and under the work's peak in those that do,
// where it now loads once the work is done. .pfm needs no module.
//
//   const ImageCodec& codec = image_codec();  // loads the module once; throws if it is missing
//   std::string error;
//   if (!codec.write(path.c_str(), w, h, /*png=*/false, rgb.data(), &error)) ...
//
// Where the module is looked for, first found wins: the file $POLYRAD_IMAGE_CODEC names; beside
// the running executable; ../lib/polyrad from it (the installed layout); the build tree polyrad
// was built in; the configured install prefix. The error lists every place it looked.
//
// Cost: the first call loads the libraries (0.35 to 0.8 s and 110 MiB here); later calls nothing.
#pragma once

#include <string>
#include <vector>

namespace polyrad {

// The module's table of entry points. Every call returns false and sets *error on failure;
// none throws across the module's boundary.
struct ImageCodec {
  int abi;  // kImageCodecAbi of the module's build; a mismatch is refused at load
  // Three channels a pixel, row-major from the top-left: `png` true takes 8-bit sRGB values and
  // writes a PNG, false takes linear floats and writes a half-float OpenEXR file.
  bool (*write)(const char* path, int width, int height, bool png, const void* pixels,
                std::string* error);
  // Any format OpenImageIO reads, as floats, with its channel count (at least 1).
  bool (*read)(const char* path, int* width, int* height, int* channels, std::vector<float>* data,
               std::string* error);
  // A PNG of 8-bit sRGB values in memory; `fast`: zlib level 1 and the "up" filter.
  bool (*encode_png)(int width, int height, const unsigned char* srgb8, bool fast,
                     std::string* bytes, std::string* error);
};

inline constexpr int kImageCodecAbi = 1;

// What loading the module adds to the resident memory of a process (its libraries' pages and
// their start-up allocations): 114 MB measured here, on Debian 12's OpenImageIO 2.4. Workflows
// that write an .exr or a .png count it in their memory estimate (transport/memory_estimate.h).
inline constexpr double kImageCodecBytes = 110.0 * (1 << 20);
// And what writing an image through it holds beside the image, a pixel: the encoded copy
// (cornell-box at 2048 x 2048 to .exr peaked 149 MiB above .pfm: the module and 9.7 bytes a
// pixel).
inline constexpr double kImageCodecPixelBytes = 12.0;
// Both, for an image of `pixels` pixels.
inline double image_codec_memory(double pixels) {
  return kImageCodecBytes + kImageCodecPixelBytes * pixels;
}

// The module's one exported symbol, extern "C" so that dlsym finds it by this name.
inline constexpr const char* kImageCodecEntry = "polyrad_image_codec";

// The loaded module's table. Throws std::runtime_error naming every place looked in if the
// module cannot be found or loaded (an installation fault, not bad input).
const ImageCodec& image_codec();

}  // namespace polyrad
