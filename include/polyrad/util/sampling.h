// Deterministic random numbers and quadrature rules.
//
// Random streams are keyed by what they sample (a patch pair, a pixel, a sample index), never
// by thread, so every result is the same on 1 or 16 threads.
//
//   Rng rng(seed, pair_index, point_index);
//   double u = rng.uniform();          // in [0, 1)
#pragma once

#include <cstdint>
#include <vector>

#include "polyrad/types.h"
#include "polyrad/util/hash.h"

namespace polyrad {

// PCG32 (O'Neill): small state, statistically sound, seeded from a hash of the keys.
class Rng {
 public:
  explicit Rng(std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0, std::uint64_t d = 0) {
    std::uint64_t h = mix64(a ^ mix64(b ^ mix64(c ^ mix64(d))));
    state_ = 0;
    inc_ = (mix64(h + 1) << 1) | 1u;
    next();
    state_ += h;
    next();
  }
  std::uint32_t next() {
    std::uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    auto rot = static_cast<std::uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32 - rot) & 31));
  }
  // Uniform in [0, 1), 53 random bits.
  double uniform() {
    std::uint64_t hi = next(), lo = next();
    return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
  }
  // Uniform in [0, 1) on a grid of 2^-32, from one step instead of two: for coordinates that
  // are stratified or feed a ray, where 32 bits are far below every other error.
  double uniform32() { return static_cast<double>(next()) * 0x1.0p-32; }
  Vec2 uniform2() {
    double x = uniform();
    return Vec2(x, uniform());
  }

 private:
  std::uint64_t state_ = 0, inc_ = 1;
};

// Gauss-Legendre rule on [0, 1]: n nodes, weights summing to 1, exact for degree 2n - 1.
struct GaussRule {
  std::vector<double> node, weight;
};
const GaussRule& gauss_legendre(int n);  // n in [1, 16]; cached

}  // namespace polyrad
