// The scene's planar mirrors (mirror_planes.h).
#include "polyrad/transport/mirror_planes.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace polyrad {

bool MirrorPlanes::path_open(const RayCaster& caster, const PatchSet& patches, std::int32_t q,
                             const Vec3& x, const Patch& px, const Vec3& y, const Patch& py,
                             long long* rays) const {
  const Plane& plane = planes[static_cast<std::size_t>(q)];
  const double hx = plane.height(x), hy = plane.height(y);
  if (!(hx > 0.0) || !(hy > 0.0)) return false;
  const Vec3 to = plane.image(y) - x;
  if (!plane.in_box(x + (hx / (hx + hy)) * to)) return false;
  const Vec3 d = to.normalized();
  if (rays) ++*rays;
  const Hit h = caster.intersect_from(x, px, d);
  if (!h.valid() || !h.front || plane_of[h.patch] != q) return false;
  if (rays) ++*rays;
  return !caster.segment_occluded(h.position, patches[h.patch], y, py);
}

namespace {

// Two planes face when a corner of a patch of each lies in front of the other by more than
// `ahead` (the patches' corners, not the boxes': a box reaches past a facet that does not lie
// along the axes; and more than rounding, so that two faces of a convex mirror meeting at an
// edge do not).
void find_facing(MirrorPlanes& m, const PatchSet& patches, double ahead) {
  const std::size_t count = m.planes.size();
  if (count > kMaxFacingPlanes) return;
  std::vector<std::vector<Vec3>> corners(count);
  for (std::size_t p = 0; p < patches.size(); ++p)
    if (m.plane_of[p] >= 0)
      for (const Vec3& corner : patches[p].corner)
        corners[static_cast<std::size_t>(m.plane_of[p])].push_back(corner);
  const auto in_front = [&](std::size_t of, std::size_t a) {
    return std::any_of(corners[of].begin(), corners[of].end(),
                       [&](const Vec3& c) { return m.planes[a].height(c) > ahead; });
  };
  for (std::size_t a = 0; a < count; ++a)
    for (std::size_t b = 0; b < count; ++b)
      if (a != b && in_front(b, a) && in_front(a, b))
        m.planes[a].facing.push_back(static_cast<std::int32_t>(b));
}

// Each plane's window: the hull of its patches' corners in its coordinates, each corner moved
// `grow` further from the hull's centre.
void find_windows(MirrorPlanes& m, const PatchSet& patches, double grow) {
  std::vector<std::vector<Vec2>> corners(m.planes.size());
  for (std::size_t p = 0; p < patches.size(); ++p)
    if (m.plane_of[p] >= 0) {
      const auto q = static_cast<std::size_t>(m.plane_of[p]);
      for (const Vec3& corner : patches[p].corner) corners[q].push_back(m.planes[q].coords(corner));
    }
  for (std::size_t q = 0; q < m.planes.size(); ++q) {
    std::vector<Vec2> hull = convex_hull(std::move(corners[q]));
    Vec2 centre = Vec2::Zero();
    for (const Vec2& c : hull) centre += c;
    centre /= std::max<double>(1.0, static_cast<double>(hull.size()));
    for (Vec2& c : hull) {
      const double r = (c - centre).norm();
      if (r > 0.0) c += (grow / r) * (c - centre);
    }
    m.planes[q].window = std::move(hull);
  }
}

}  // namespace

MirrorPlanes mirror_planes(const PatchSet& patches, const std::vector<Material>& materials,
                           bool enabled) {
  MirrorPlanes m;
  if (!enabled) return m;
  m.plane_of.assign(patches.size(), -1);
  std::vector<std::pair<ObjectId, MaterialId>> owner;  // per plane
  const double close = 1e-9 * std::max(patches.scene_diameter, 1e-300);
  for (std::size_t p = 0; p < patches.size(); ++p) {
    const Patch& patch = patches[p];
    const Material& mat = materials[patch.material];
    // A bent quad is no plane: its mirror light stays in the links.
    if (!is_planar_mirror(patch, mat, patches.scene_diameter)) continue;
    const double offset = patch.normal.dot(patch.centroid);
    std::size_t q = 0;
    for (; q < m.planes.size(); ++q)
      if (owner[q] == std::make_pair(patch.object, patch.material) &&
          m.planes[q].normal.dot(patch.normal) > 1.0 - 1e-12 &&
          std::abs(m.planes[q].offset - offset) <= close)
        break;
    if (q == m.planes.size()) {
      MirrorPlanes::Plane plane;
      plane.normal = patch.normal;
      plane.offset = offset;
      plane.lo = plane.hi = patch.centroid;
      plane.specular = mat.specular;
      const Frame frame = Frame::from_normal(patch.normal);
      plane.u = frame.s;
      plane.v = frame.t;
      m.planes.push_back(std::move(plane));
      owner.emplace_back(patch.object, patch.material);
    }
    MirrorPlanes::Plane& plane = m.planes[q];
    for (int k = 0; k < 4; ++k) {
      plane.lo = plane.lo.cwiseMin(patch.corner[static_cast<std::size_t>(k)]);
      plane.hi = plane.hi.cwiseMax(patch.corner[static_cast<std::size_t>(k)]);
    }
    m.plane_of[p] = static_cast<std::int32_t>(q);
  }
  // Grown so that a crossing computed on the plane is not lost to rounding at its edges (the ray
  // decides whether the mirror is met).
  const double grow = 1e-6 * patches.scene_diameter;
  m.grow = grow;
  for (auto& plane : m.planes) {
    plane.lo.array() -= grow;
    plane.hi.array() += grow;
  }
  find_windows(m, patches, grow);
  for (std::size_t p = 0; p < patches.size(); ++p)
    if (m.plane_of[p] >= 0 && patches[p].emitter)
      m.planes[static_cast<std::size_t>(m.plane_of[p])].emits = true;
  find_facing(m, patches, 10.0 * grow);
  return m;
}

}  // namespace polyrad
