// The hashes (util/hash.h).
#include "polyrad/util/hash.h"

#include <cstring>

namespace polyrad {

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed) {
  auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t h = seed;
  for (std::size_t n = 0; n < size; ++n) {
    h ^= p[n];
    h *= 0x100000001b3ull;
  }
  return h;
}

std::uint64_t checksum64(const void* data, std::size_t size) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t h = 0x9e3779b97f4a7c15ull ^ size;
  const std::size_t words = size / 8;
  for (std::size_t k = 0; k < words; ++k) {
    std::uint64_t w;
    std::memcpy(&w, p + 8 * k, 8);
    h = (h ^ w) * 0x100000001b3ull;
    h ^= h >> 29;
  }
  for (std::size_t k = 8 * words; k < size; ++k) h = (h ^ p[k]) * 0x100000001b3ull;
  return mix64(h);
}

}  // namespace polyrad
