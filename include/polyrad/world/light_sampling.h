// Next-event estimation: points drawn on the emitting patches, and the weight that combines
// such a sample with a BRDF sample by multiple importance (the path tracer and the camera
// gather both use them); and the lights' boxes, which tell a ray that cannot meet a light.
//
//   LightSampler lights(patches, weights);          // weights[p] >= 0; 0: never drawn
//   LightSample s = lights.sample(u_select, u_point);
//   double w = power_heuristic(n_light * s.area_pdf * dist2 / cos_y, n_brdf * brdf_pdf);
//
// A patch is chosen with probability weight / sum of weights, then a point on it by
// Patch::sample, so the area density of the point is select / (area * map density); the map
// density is 1 on triangles and parallelograms, which are told once, when the sampler is made.
// Cost: O(1) a sample on average (a guide table of one entry per emitter starts the search of
// the cumulative weights); O(patches) memory.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "polyrad/geometry/mesher.h"

namespace polyrad {

// Power heuristic with exponent 2 (Veach's thesis, eq. 9.13): the weight of the strategy whose
// density (times its sample count) is `a`, the other's being `b`.
inline double power_heuristic(double a, double b) {
  double a2 = a * a, b2 = b * b;
  if (!(a2 + b2 > 0.0)) return 0.0;
  if (std::isinf(a2)) return 1.0;
  return a2 / (a2 + b2);
}

struct LightSample {
  PatchId patch = -1;
  Vec3 point = Vec3::Zero();
  Vec2 uv = Vec2::Zero();  // the point's parameters on the patch (Patch::point)
  double area_pdf = 0.0;   // density of drawing this point, per unit area
};

class LightSampler {
 public:
  // Keeps a reference to patches. weight has one entry per patch.
  LightSampler(const PatchSet& patches, const std::vector<double>& weight);

  bool empty() const { return emitters_.empty(); }
  double total_weight() const { return total_; }
  // Probability of choosing patch p (0 if p is never drawn).
  double select_pdf(PatchId p) const { return select_pdf_[p]; }

  // u_select in [0, 1) picks the patch (so stratifying it stratifies the choice); u_point the
  // point on it. Requires !empty().
  LightSample sample(double u_select, const Vec2& u_point) const;
  // One point of the unit square for both: u.x picks the patch and, rescaled within that
  // patch's share of [0, 1), becomes the point's first coordinate. A stratified grid of u then
  // stays stratified over the lights (over both coordinates of a single patch), where separate
  // draws would leave the points on each patch independent. Requires !empty().
  LightSample sample(const Vec2& u) const;
  // The area density sample() has at point y of patch p.
  double area_pdf(PatchId p, const Vec3& y) const;

 private:
  size_t choose(double u) const;  // the emitter index u falls on
  LightSample point_on(size_t e, const Vec2& u_point) const;
  const PatchSet& patches_;
  std::vector<PatchId> emitters_;  // patches with a positive weight
  std::vector<double> cdf_;        // cumulative selection probability, last = 1
  // guide_[k]: the first emitter whose cdf_ exceeds k / emitters (choose starts there).
  std::vector<std::uint32_t> guide_;
  std::vector<double> select_pdf_;
  std::vector<char> flat_;  // per patch: a triangle or a parallelogram (map density 1)
  double total_ = 0.0;
};

// Boxes around the named lights (the patches marked emitter), one per emitting object: whether
// a ray may meet a light at all. A BRDF sample that only looks for the lights (the final
// gather's IndirectMode::kMesh) need not be traced when it cannot; the answer is conservative,
// so what such a sample adds is unchanged, only the rays that would find nothing are saved.
//
//   LightBounds bounds(patches);
//   const Vec3 o = caster.origin_from(x, patches[i], dir);  // where the ray really leaves
//   if (bounds.may_meet(o, dir)) hit = caster.intersect(o, dir);
//
// Each box is padded by 1e-5 of the scene's largest coordinate or size, far above the single
// precision of the ray caster's geometry; asked from x itself instead of the lifted origin, a
// ray that grazes a lamp's edge may be wrongly refused.
// Cost: one slab test per box (kMaxBoxes at most; beyond that every ray may meet a light).
class LightBounds {
 public:
  explicit LightBounds(const PatchSet& patches);
  // False only if the ray x + t dir, t >= 0, misses every box.
  bool may_meet(const Vec3& x, const Vec3& dir) const;
  // The boxes tested; 0 with no lights, or with more emitting objects than kMaxBoxes (then
  // may_meet is always true).
  std::size_t boxes() const { return all_ ? 0 : lo_.size(); }

  static constexpr std::size_t kMaxBoxes = 16;

 private:
  std::vector<Vec3> lo_, hi_;
  bool all_ = false;
};

}  // namespace polyrad
