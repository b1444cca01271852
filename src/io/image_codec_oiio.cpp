// The image codec module (io/image_codec.h): OpenEXR and PNG through OpenImageIO. Built as
// libpolyrad_image_codec.so, loaded by polyrad on first use; it exports one symbol and links
// nothing of polyrad's.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <string>
#include <vector>

#include "polyrad/io/image_codec.h"

namespace polyrad {
namespace {

constexpr int kPngFilterUp = 0x20;  // libpng's PNG_FILTER_UP, which OpenImageIO passes on

bool fail(std::string* error, const std::string& what) {
  *error = what;
  return false;
}

bool write(const char* path, int width, int height, bool png, const void* pixels,
           std::string* error) {
  auto out = OIIO::ImageOutput::create(path);
  if (!out) return fail(error, OIIO::geterror());
  OIIO::ImageSpec spec(width, height, 3, png ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::HALF);
  if (!out->open(path, spec)) return fail(error, out->geterror());
  const OIIO::TypeDesc given = png ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT;
  if (!out->write_image(given, pixels) || !out->close()) return fail(error, out->geterror());
  return true;
}

bool read(const char* path, int* width, int* height, int* channels, std::vector<float>* data,
          std::string* error) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) return fail(error, OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    return fail(error, "the image is empty");
  data->resize(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, data->data()))
    return fail(error, in->geterror());
  *width = spec.width;
  *height = spec.height;
  *channels = spec.nchannels;
  return true;
}

bool encode_png(int width, int height, const unsigned char* srgb8, bool fast, std::string* bytes,
                std::string* error) {
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput proxy(buffer);
  auto out = OIIO::ImageOutput::create("png");
  if (!out || !out->supports("ioproxy"))
    return fail(error, "OpenImageIO cannot write PNG to memory: " + OIIO::geterror());
  OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
  if (fast) {
    spec.attribute("png:compressionLevel", 1);
    spec.attribute("png:filter", kPngFilterUp);
  }
  if (!out->set_ioproxy(&proxy) || !out->open("memory.png", spec) ||
      !out->write_image(OIIO::TypeDesc::UINT8, srgb8) || !out->close())
    return fail(error, out->geterror());
  bytes->assign(buffer.begin(), buffer.end());
  return true;
}

constexpr ImageCodec kCodec{kImageCodecAbi, write, read, encode_png};

}  // namespace
}  // namespace polyrad

extern "C" __attribute__((visibility("default"))) const polyrad::ImageCodec* polyrad_image_codec() {
  // No thread pools of OpenImageIO's or OpenEXR's: polyrad's images are small, and their idle
  // workers were still alive when the process exited, where LeakSanitizer's check of the whole
  // process crashed now and then (a sanitizer build's test that had passed then failed).
  static const bool single = OIIO::attribute("threads", 1) && OIIO::attribute("exr_threads", -1);
  (void)single;
  return &polyrad::kCodec;
}
