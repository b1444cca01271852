// Exposure (exposure.h).
#include "polyrad/transport/exposure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "polyrad/scene/brdf.h"

namespace polyrad {

namespace {

// The probes of is_buried in a patch's frame: the normal, four at 30 degrees from it and eight
// at 60, spread in azimuth so that the rings interleave.
std::array<Vec3, 13> burial_probes() {
  std::array<Vec3, 13> d;
  d[0] = Vec3(0, 0, 1);
  for (int k = 0; k < 12; ++k) {
    const bool inner = k < 4;
    const double theta = inner ? kPi / 6.0 : kPi / 3.0;
    const double phi = inner ? (k + 0.5) * kPi / 2.0 : (k - 4) * kPi / 4.0;
    d[k + 1] = Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                    std::cos(theta));
  }
  return d;
}

// Whether any probe from x (on p) meets the back of a surface.
bool sees_a_back(const Vec3& x, const Patch& p, const RayCaster& caster) {
  static const std::array<Vec3, 13> kProbes = burial_probes();
  const Frame frame = Frame::from_normal(p.normal);
  for (const Vec3& d : kProbes) {
    Hit h = caster.intersect_from(x, p, frame.to_world(d));
    if (h.valid() && !h.front) return true;
  }
  return false;
}

// The area-density-weighted share of the cells of an n x n grid of p's unit square that lie in
// front of the plane (origin, normal) (all of them when normal is zero) and for which open(x, k)
// holds, x the cell's centre and k = a * n + b its index; 1 when no cell lies in front.
template <class Open>
double grid_fraction(const Patch& p, int n, const Vec3& origin, const Vec3& normal, Open open) {
  double exposed = 0.0, total = 0.0;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      double density;
      const Vec3 x = p.sample(Vec2((a + 0.5) / n, (b + 0.5) / n), &density);
      if ((x - origin).dot(normal) < 0.0) continue;
      total += density;
      if (open(x, a * n + b)) exposed += density;
    }
  return total > 0.0 ? exposed / total : 1.0;
}

// The exposed fraction of p on an n x n grid by probes; with `bits`, each cell's E is stored at
// bit a * n + b.
double probed_fraction(const Patch& p, const RayCaster& caster, int n, std::uint64_t* bits,
                       const Vec3& origin = Vec3::Zero(), const Vec3& normal = Vec3::Zero()) {
  return grid_fraction(p, n, origin, normal, [&](const Vec3& x, int k) {
    if (is_buried(x, p, caster)) return false;
    if (bits) bits[k / 64] |= std::uint64_t{1} << (k % 64);
    return true;
  });
}

bool bit(const std::uint64_t* bits, int k) { return (bits[k / 64] >> (k % 64)) & 1u; }

int words(int n) { return (n * n + 63) / 64; }

}  // namespace

bool is_buried(const Vec3& x, const Patch& p, const RayCaster& caster) {
  // Buried: a majority of 13 probes meet the back of a surface (x is inside a closed object),
  // or x is enclosed by fronts that all see a back themselves. A majority, not all: faces of
  // objects nested in or cutting another see each other's fronts through some probes. The second
  // test is for a space closed partly by other surfaces' fronts: inside a cupboard in a corner,
  // open at its back and side, a point near the corner sees the two walls and the floor with
  // most probes, but every wall or floor point it sees sees the cupboard's inside in turn. A
  // point under a one-sided panel (a table top) sees its back too, but also fronts far off in
  // the room that see no back, so it stays open, as does a point in free space, which sees no
  // back at all.
  static const std::array<Vec3, 13> kProbes = burial_probes();
  constexpr int kMajority = 7;
  const Frame frame = Frame::from_normal(p.normal);
  std::array<Hit, 13> fronts;
  int open = 0, back = 0;
  for (const Vec3& d : kProbes) {
    Hit h = caster.intersect_from(x, p, frame.to_world(d));
    if (!h.valid()) return false;  // x sees out of the scene: not enclosed
    if (h.front) {
      fronts[open++] = h;
    } else if (++back >= kMajority) {
      return true;
    }
  }
  if (back == 0) return false;
  for (int k = 0; k < open; ++k)
    if (!sees_a_back(fronts[k].position, caster.patches()[fronts[k].patch], caster)) return false;
  return true;
}

bool PatchExposure::exposed_at(const Patch& p, const Vec3& x, const RayCaster& caster) const {
  if (wholly()) return true;
  if (n == 0) return !is_buried(x, p, caster);
  const Vec2 s = p.unsample(x);
  const int a = std::min(n - 1, static_cast<int>(s.x() * n));
  const int b = std::min(n - 1, static_cast<int>(s.y() * n));
  const bool open = bit(cells, a * n + b);
  // A cell beside one of the other kind holds the buried boundary: probe x itself there. Read
  // from the cell, a buried point counted open adds nothing (its rays start inside) while
  // weighing in the mean, and the pairs of partly buried patches came out 0.1 percent dark on
  // average (region means of scenes/room).
  for (const auto& [da, db] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
    const int a2 = a + da, b2 = b + db;
    if (a2 < 0 || a2 >= n || b2 < 0 || b2 >= n) continue;
    if (bit(cells, a2 * n + b2) != open) return !is_buried(x, p, caster);
  }
  return open;
}

double PatchExposure::fraction_in_front(const Patch& p, const Vec3& origin, const Vec3& normal,
                                        const RayCaster& caster) const {
  if (wholly()) return 1.0;
  if (n == 0) return probed_fraction(p, caster, 16, nullptr, origin, normal);
  return grid_fraction(p, n, origin, normal, [&](const Vec3&, int k) { return bit(cells, k); });
}

ExposureMap::ExposureMap(const PatchSet& patches, const RayCaster& caster, int points,
                         int refined_points)
    : ExposureMap(patches, caster, std::vector<int>(patches.size(), points), refined_points) {}

ExposureMap::ExposureMap(const PatchSet& patches, const RayCaster& caster,
                         const std::vector<int>& points, int refined_points)
    : n_(refined_points) {
  if (points.size() != patches.size())
    throw std::invalid_argument("ExposureMap: one count of points per patch");
  const auto count = static_cast<PatchId>(patches.size());
  area_.resize(count);
  fraction_.resize(count);
  std::vector<std::vector<std::uint64_t>> grid(count);
#pragma omp parallel for schedule(dynamic, 16)
  for (PatchId i = 0; i < count; ++i) {
    // The first test (0.5, as for a partly buried patch, where it would be the refined grid).
    double f = points[i] < n_ ? probed_fraction(patches[i], caster, points[i], nullptr) : 0.5;
    if (f > 0.0 && f < 1.0) {
      grid[i].assign(words(n_), 0);
      f = probed_fraction(patches[i], caster, n_, grid[i].data());
      // Refined to wholly exposed or buried: no grid to keep, as for the coarse test.
      if (f <= 0.0 || f >= 1.0) grid[i].clear();
    }
    fraction_[i] = f;
    area_[i] = patches[i].area * f;
  }
  first_word_.assign(count, -1);
  for (PatchId i = 0; i < count; ++i) {
    if (grid[i].empty()) continue;
    first_word_[i] = static_cast<std::int64_t>(bits_.size());
    bits_.insert(bits_.end(), grid[i].begin(), grid[i].end());
  }
}

PatchExposure ExposureMap::operator[](PatchId i) const {
  PatchExposure e(fraction_[i]);
  if (first_word_[i] >= 0) {
    e.n = n_;
    e.cells = bits_.data() + first_word_[i];
  }
  return e;
}

std::size_t ExposureMap::partly_buried() const {
  std::size_t k = 0;
  for (std::int64_t w : first_word_) k += w >= 0;
  return k;
}

std::vector<double> exposed_areas(const PatchSet& patches, const RayCaster& caster, int points,
                                  int refined_points) {
  return ExposureMap(patches, caster, points, refined_points).areas();
}

}  // namespace polyrad
