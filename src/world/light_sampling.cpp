// Next-event estimation's light sampler and the lights' boxes (light_sampling.h).
#include "polyrad/world/light_sampling.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "polyrad/util/error.h"

namespace polyrad {

LightSampler::LightSampler(const PatchSet& patches, const std::vector<double>& weight)
    : patches_(patches), select_pdf_(patches.size(), 0.0) {
  POLYRAD_CHECK(weight.size() == patches.size());
  for (PatchId p = 0; p < static_cast<PatchId>(patches.size()); ++p) {
    if (!(weight[p] > 0.0)) continue;
    emitters_.push_back(p);
    total_ += weight[p];
  }
  double running = 0.0;
  for (PatchId p : emitters_) {
    running += weight[p];
    cdf_.push_back(running / total_);
    select_pdf_[p] = weight[p] / total_;
  }
  if (!cdf_.empty()) cdf_.back() = 1.0;
  const std::size_t n = emitters_.size();
  guide_.resize(n);
  std::size_t e = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double u = static_cast<double>(k) / static_cast<double>(n);
    while (e + 1 < n && !(cdf_[e] > u)) ++e;
    guide_[k] = static_cast<std::uint32_t>(e);
  }
  flat_.resize(patches.size());
  for (PatchId p : emitters_) flat_[p] = patches[p].is_triangle() || patches[p].is_parallelogram();
}

size_t LightSampler::choose(double u) const {
  // The first emitter whose cdf exceeds u (as std::upper_bound finds it), searched from the
  // guide's entry for u: every emitter before that entry has cdf <= k / n <= u (the step back
  // is for a u within rounding below k / n).
  const std::size_t n = emitters_.size();
  // NaN and u >= 1 take the last emitter, as the search would; no cast of either to an index.
  const std::size_t k = !(u < 1.0) ? n - 1
                        : u > 0.0
                            ? std::min(static_cast<std::size_t>(u * static_cast<double>(n)), n - 1)
                            : 0;
  std::size_t e = guide_[k];
  while (e > 0 && cdf_[e - 1] > u) --e;
  while (e + 1 < n && !(cdf_[e] > u)) ++e;
  return e;
}

LightSample LightSampler::point_on(size_t e, const Vec2& u_point) const {
  LightSample s;
  s.patch = emitters_[e];
  const Patch& light = patches_[s.patch];
  if (flat_[s.patch] && !light.is_triangle()) {  // a parallelogram: no tangents to take
    s.point = light.point(u_point.x(), u_point.y());
    s.uv = u_point;
    s.area_pdf = select_pdf_[s.patch] / light.area;
    return s;
  }
  double density = 1.0;
  s.point = light.sample(u_point, &density, &s.uv);
  s.area_pdf = density > 0.0 ? select_pdf_[s.patch] / (light.area * density) : 0.0;
  return s;
}

LightSample LightSampler::sample(double u_select, const Vec2& u_point) const {
  return point_on(choose(u_select), u_point);
}

LightSample LightSampler::sample(const Vec2& u) const {
  const size_t e = choose(u.x());
  const double lo = e > 0 ? cdf_[e - 1] : 0.0, width = cdf_[e] - lo;
  const double x = width > 0.0 ? std::clamp((u.x() - lo) / width, 0.0, std::nextafter(1.0, 0.0)) : 0.5;
  return point_on(e, Vec2(x, u.y()));
}

double LightSampler::area_pdf(PatchId p, const Vec3& y) const {
  const Patch& q = patches_[p];
  double select = select_pdf_[p];
  if (!(select > 0.0)) return 0.0;
  if (flat_[p]) return select / q.area;
  // Patch::sample maps the unit square bilinearly, so its area density is 1 / |du x dv|, which
  // varies over a quad that is not a parallelogram: find y's parameters (Gauss-Newton on the
  // bilinear map, exact in one step for a parallelogram) and evaluate it there.
  double u = 0.5, v = 0.5;
  for (int it = 0; it < 4; ++it) {
    Vec3 du, dv;
    q.tangents(u, v, &du, &dv);
    Vec3 r = y - q.point(u, v);
    double a = du.dot(du), b = du.dot(dv), c = dv.dot(dv);
    double det = a * c - b * b;
    if (!(det > 0.0)) break;
    double ru = du.dot(r), rv = dv.dot(r);
    u = std::clamp(u + (c * ru - b * rv) / det, 0.0, 1.0);
    v = std::clamp(v + (a * rv - b * ru) / det, 0.0, 1.0);
  }
  Vec3 du, dv;
  q.tangents(u, v, &du, &dv);
  double jacobian = du.cross(dv).norm();
  return jacobian > 0.0 ? select / jacobian : 0.0;
}

LightBounds::LightBounds(const PatchSet& patches) {
  std::map<ObjectId, std::size_t> box_of;
  double extent = patches.scene_diameter;  // the scene's scale, for the padding below
  for (std::size_t i = 0; i < patches.size(); ++i) {
    const Patch& p = patches[i];
    for (int k = 0; k < p.corners; ++k)
      extent = std::max(extent, p.corner[k].cwiseAbs().maxCoeff());
    if (!p.emitter) continue;
    const auto [it, added] = box_of.emplace(p.object, lo_.size());
    if (added) {
      lo_.push_back(p.corner[0]);
      hi_.push_back(p.corner[0]);
    }
    for (int k = 0; k < p.corners; ++k) {
      lo_[it->second] = lo_[it->second].cwiseMin(p.corner[k]);
      hi_[it->second] = hi_[it->second].cwiseMax(p.corner[k]);
    }
  }
  if (lo_.size() > kMaxBoxes) {
    all_ = true;
    return;
  }
  // A flat lamp's box has no thickness: pad every box well above the single precision in which
  // the ray caster holds the geometry and casts its rays, about 1e-7 of the scene's largest
  // coordinate or size, not the lamp's (a ray from 10 units away finds a lamp 0.01 wide at the
  // origin up to 1e-6 outside its edges).
  const double pad = 1e-5 * extent + 1e-12;
  for (std::size_t b = 0; b < lo_.size(); ++b) {
    lo_[b].array() -= pad;
    hi_[b].array() += pad;
  }
}

bool LightBounds::may_meet(const Vec3& x, const Vec3& dir) const {
  if (all_) return true;
  for (std::size_t b = 0; b < lo_.size(); ++b) {
    double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
    bool miss = false;
    for (int a = 0; a < 3 && !miss; ++a) {
      if (dir[a] == 0.0) {  // parallel to this slab: inside it or never
        miss = x[a] < lo_[b][a] || x[a] > hi_[b][a];
        continue;
      }
      const double inv = 1.0 / dir[a];
      double near = (lo_[b][a] - x[a]) * inv, far = (hi_[b][a] - x[a]) * inv;
      if (near > far) std::swap(near, far);
      t0 = std::max(t0, near);
      t1 = std::min(t1, far);
      miss = t0 > t1;
    }
    if (!miss) return true;
  }
  return false;
}

}  // namespace polyrad
