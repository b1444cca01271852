// The one place that talks to Embree: closest hits and occlusion against the patches.
//
// Every patch is one Embree primitive (a quad; a triangle repeats its last corner), so a hit
// names the patch directly. Rays are in world units; the caller chooses [tnear, tfar] and uses
// epsilon() to step off surfaces. Thread-safe: any number of threads may cast at once.
//
//   RayCaster rc(patches);
//   Hit h = rc.intersect(origin, dir);             // h.patch < 0 on a miss
//   bool blocked = rc.occluded(x, y - x, eps, 1 - eps);   // segment test, direction unnormalised
//
// Callers count their own rays (a shared counter would serialise the threads).
// Cost: building is O(P log P); a ray is O(log P). Memory: about 100 bytes per patch.
#pragma once

#include <limits>
#include <memory>

#include "polyrad/mesher.h"
#include "polyrad/types.h"

namespace polyrad {

struct Hit {
  PatchId patch = -1;  // -1: the ray left the scene
  double t = 0.0;      // distance along the ray in units of |direction|
  double u = 0.0, v = 0.0;  // parameters on the patch (Patch::point)
  bool front = false;       // the ray met the patch's front side
  bool valid() const { return patch >= 0; }
};

class RayCaster {
 public:
  explicit RayCaster(const PatchSet& patches);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  Hit intersect(const Vec3& origin, const Vec3& direction, double tnear = 0.0,
                double tfar = std::numeric_limits<double>::infinity()) const;
  bool occluded(const Vec3& origin, const Vec3& direction, double tnear = 0.0,
                double tfar = std::numeric_limits<double>::infinity()) const;

  // A distance below which two surface points count as the same: 1e-5 of the scene's size,
  // well above Embree's single-precision error for rays that leave a surface at a shallow angle.
  double epsilon() const { return epsilon_; }
  // True if anything blocks the open segment between surface points a and b.
  bool segment_occluded(const Vec3& a, const Vec3& b) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const PatchSet& patches_;
  double epsilon_;
};

}  // namespace polyrad
