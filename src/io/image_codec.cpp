// Loading the image codec module (io/image_codec.h).
#include "polyrad/io/image_codec.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace polyrad {

namespace {

namespace fs = std::filesystem;

// Where the build put the module, where an install puts it, and the install's path to it from
// the executable's folder: set by src/CMakeLists.txt.
#ifndef POLYRAD_IMAGE_CODEC_BUILD_PATH
#error "src/CMakeLists.txt defines POLYRAD_IMAGE_CODEC_BUILD_PATH"
#endif

std::vector<fs::path> candidates() {
  if (const char* named = std::getenv("POLYRAD_IMAGE_CODEC"); named && *named) return {named};
  std::vector<fs::path> paths;
  const fs::path file = fs::path(POLYRAD_IMAGE_CODEC_BUILD_PATH).filename();
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    paths.push_back(exe.parent_path() / file);
    paths.push_back((exe.parent_path() / POLYRAD_IMAGE_CODEC_FROM_BIN).lexically_normal());
  }
  paths.push_back(POLYRAD_IMAGE_CODEC_BUILD_PATH);
  paths.push_back(POLYRAD_IMAGE_CODEC_INSTALL_PATH);
  std::vector<fs::path> distinct;  // the program in the build tree is beside the module
  for (const fs::path& p : paths)
    if (std::find(distinct.begin(), distinct.end(), p) == distinct.end()) distinct.push_back(p);
  return distinct;
}

// The first candidate that loads and speaks this build's table; never unloaded.
const ImageCodec* load() {
  std::string tried;
  for (const fs::path& path : candidates()) {
    tried += "\n  " + path.string() + ": ";
    std::error_code ec;
    if (!fs::exists(path, ec)) {
      tried += "not there";
      continue;
    }
    void* module = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!module) {
      tried += dlerror();
      continue;
    }
    using Entry = const ImageCodec* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(module, kImageCodecEntry));
    const ImageCodec* codec = entry ? entry() : nullptr;
    if (codec && codec->abi == kImageCodecAbi) return codec;
    tried += codec ? "built for another polyrad" : "no entry point";
    dlclose(module);
  }
  throw std::runtime_error(
      "cannot read or write .exr and .png: the image codec module did not load "
      "(set POLYRAD_IMAGE_CODEC to its path; .pfm needs no module). Looked in:" +
      tried);
}

}  // namespace

const ImageCodec& image_codec() {
  static const ImageCodec* codec = load();  // a throw leaves it unset, to try again next call
  return *codec;
}

}  // namespace polyrad
