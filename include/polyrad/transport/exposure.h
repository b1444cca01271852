// Exposure: which part of each patch lies in the open rather than inside closed geometry.
//
//   A'_i = int_{P_i} E(x) dA,   E(x) = 0 where x is buried, 1 elsewhere
//
// The part of a patch buried inside other geometry (a floor under a block, a ceiling behind a
// lamp mounted flush with it) can neither receive nor send light, and no camera sees it. Form
// factors leave it out, F_ij = G_ij / A'_i (form_factors.h), so that B_i is the radiosity of the
// part light reaches rather than an average that mixes in the dark part and shows as a dark halo.
//
// A point is buried when most of 13 probe rays (along the normal, and tilted 30 and 60 degrees
// around it) meet the back of a surface, i.e. it lies inside a closed object (also one nested in
// or cutting another) or sandwiched under a one-sided panel; or when every front its probes meet
// sees a back in turn (a space closed partly by walls and floor). E is measured on 4 x 4 points of
// the patch's unit square (Patch::sample; more where a caller asks, as the hierarchy does for
// roots much larger than their smallest elements), refined to 32 x 32 where the buried boundary
// crosses the patch. For such a partly buried patch the refined grid is kept (one bit a cell, 128
// bytes), so that the form factors (and the hierarchy's elements, on grids of their own) read E
// at their quadrature points, and the exposed part of a region a partner's plane cuts off, from
// the same grid: probes are cast per pair only for points in the cells beside the buried boundary.
// Deterministic (fixed points and probes).
//
//   ExposureMap map(patches, caster, 4, 32);
//   double a = map.area(i);                    // A'_i
//   bool open = map[i].exposed_at(patches[i], x);
//
// Cost: 16 points x up to 13 probes (and their fronts' probes) per patch, 1024 points more per
// partly buried patch; a point's lookup is a few Newton steps, a region's 1024 point evaluations.
#pragma once

#include <cstdint>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"

namespace polyrad {

// True if x (on patch p) lies inside closed geometry, as above. Casts 13 to 182 rays.
bool is_buried(const Vec3& x, const Patch& p, const RayCaster& caster);

// One patch's exposure. With a grid (n > 0), E is read from it; without one (a fraction alone,
// as for the hierarchy's elements), a partly exposed patch's points are probed with is_buried.
struct PatchExposure {
  double fraction = 1.0;  // A'_i / A_i
  int n = 0;              // grid cells per side, 0 without a grid
  const std::uint64_t* cells = nullptr;  // n * n bits, cell (a, b) at bit a * n + b

  PatchExposure() = default;
  PatchExposure(double f) : fraction(f) {}  // NOLINT: a bare fraction converts, as before grids
  bool wholly() const { return fraction >= 1.0; }
  // E(x) for x on p (the grid cell that contains it, or probes without a grid).
  bool exposed_at(const Patch& p, const Vec3& x, const RayCaster& caster) const;
  // The exposed fraction of the part of p in front of the plane (origin, normal), measured on
  // the grid, or probed on a 16 x 16 one without it; 1 when no grid point lies there.
  double fraction_in_front(const Patch& p, const Vec3& origin, const Vec3& normal,
                           const RayCaster& caster) const;
};

class ExposureMap {
 public:
  ExposureMap(const PatchSet& patches, const RayCaster& caster, int points, int refined_points);
  // The first test on points[i] x points[i] points for patch i (at least 1): a buried region
  // narrower than the points' spacing can fall between them and go unseen, so a large patch
  // whose buried parts matter down to a small size asks for more (the hierarchy's roots, by
  // their smallest element). At refined_points or more, the first test is the refined grid.
  ExposureMap(const PatchSet& patches, const RayCaster& caster, const std::vector<int>& points,
              int refined_points);

  PatchExposure operator[](PatchId i) const;
  double area(PatchId i) const { return area_[i]; }
  // Every A'_i, for those who keep only the areas.
  std::vector<double> areas() const { return area_; }
  // Patches with a grid (partly buried).
  std::size_t partly_buried() const;

 private:
  std::vector<double> area_, fraction_;
  std::vector<std::int64_t> first_word_;  // -1: no grid
  std::vector<std::uint64_t> bits_;
  int n_ = 0;
};

// Every A'_i (ExposureMap's areas).
std::vector<double> exposed_areas(const PatchSet& patches, const RayCaster& caster, int points,
                                  int refined_points);

}  // namespace polyrad
