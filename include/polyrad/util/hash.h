// The hashes polyrad uses, in one place:
//   fnv1a64     byte-wise FNV-1a: scene texts and meshes (Scene::hash, the staleness check);
//   mix64       the splitmix64 finaliser: keys of random streams (util/sampling.h);
//   checksum64  word-wise multiply-xorshift ending in mix64: the .prt checksum, fast enough to
//               verify gigabytes at memory speed (FNV-1a goes a byte at a time).
//
//   std::uint64_t h = fnv1a64(text.data(), text.size());
//   h = fnv1a64(mesh.data(), mesh.size(), h);        // chained
//
// Cost: fnv1a64 one multiply a byte; checksum64 one multiply per 8 bytes; mix64 O(1).
#pragma once

#include <cstddef>
#include <cstdint>

namespace polyrad {

inline constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325ull;

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed = kFnvOffset);

// splitmix64's finaliser: a bijection with good avalanche.
inline std::uint64_t mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

std::uint64_t checksum64(const void* data, std::size_t size);

}  // namespace polyrad
