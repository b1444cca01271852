// The scene's planar mirrors, grouped into planes: what the final gather's mirror images
// (render/camera_gather.h) and the hierarchy's image links (transport/hierarchy.h) both see
// through. A point y in front of plane q is seen from a point x in front of it at its image
//     y' = y - 2 (n . y - d) n                                  (n the plane's normal, d its
//     offset)
// along the segment x -> y', which crosses the plane at
//     p = x + h_x / (h_x + h_y) (y' - x),   h = n . (.) - d,
// where the mirror must be met: inside the plane's box, then by a ray from x whose first hit is a
// patch of the plane (its outline is the union of its patches, and anything in front of it
// hides it), and from p the segment to y must be open (section 8, the mirror image of a lamp).
// Through mirrors that face each other the image repeats, y'' = R_1(R_2(y)) and on; each plane
// lists the planes that face it, where such a chain may go next.
//
//   MirrorPlanes m = mirror_planes(patches, materials, true);
//   bool open = m.path_open(caster, patches, q, x, patches[i], y, patches[j]);
//
// Cost: one pass over the patches, and the facing test, quadratic in the planes (up to
// kMaxFacingPlanes); a path test is two rays.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "polyrad/geometry/convex_polygon.h"
#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/brdf.h"

namespace polyrad {

// A planar mirror patch: a delta lobe on a patch that lies in one plane (to 1e-9 of the scene's
// size; a bent quad does not).
inline bool is_planar_mirror(const Patch& p, const Material& m, double scene_diameter) {
  return m.has_lobe() && m.is_delta() && p.bend <= 1e-9 * scene_diameter;
}

// Past this many planes none lists the planes that face it (a mirror tessellated into facets,
// whose chains of facets would be many and each carry little; the test is quadratic).
inline constexpr std::size_t kMaxFacingPlanes = 256;

// The planar mirror patches, grouped by object, material and plane.
struct MirrorPlanes {
  struct Plane {
    Vec3 normal;    // unit, out of the mirrors' front
    double offset;  // normal . x on the plane
    Vec3 lo, hi;    // the box of its patches' corners, grown by a little
    Rgb specular;   // the mirror's reflectance s
    // A light lies on it: a chain of facing mirrors (mirror_chains.h) passes on only through
    // planes without one, whose light the lamps' images and the reads beyond them then give.
    bool emits = false;
    // The planes a path that leaves this one may meet next: each with a corner of a patch in
    // front of this plane, and a corner of one of this one's in front of it (two mirrors that
    // face each other; no two faces of a convex mirror do).
    std::vector<std::int32_t> facing;
    // Coordinates in the plane (u, v, normal orthonormal), and its window: the convex hull of its
    // patches' corners there, grown by a little (the beams of transport/mirror_chains.h).
    Vec3 u, v;
    std::vector<Vec2> window;

    Vec2 coords(const Vec3& p) const { return Vec2(u.dot(p), v.dot(p)); }
    Vec3 point(const Vec2& c) const { return c.x() * u + c.y() * v + offset * normal; }
    double height(const Vec3& x) const { return normal.dot(x) - offset; }
    Vec3 image(const Vec3& x) const { return x - 2.0 * height(x) * normal; }
    bool in_box(const Vec3& p) const {
      return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
    }
  };
  std::vector<Plane> planes;
  std::vector<std::int32_t> plane_of;  // per patch: its plane, -1 if not a mirror
  double grow = 0.0;  // how far the boxes and windows reach past the patches (against rounding)
  bool empty() const { return planes.empty(); }

  // Whether y on patch py is seen from x on patch px in plane q (both in front of it): the
  // crossing in the plane's box, the first hit from x a front face of the plane, and the segment
  // from there to y open. rays, if given, counts the rays cast.
  bool path_open(const RayCaster& caster, const PatchSet& patches, std::int32_t q, const Vec3& x,
                 const Patch& px, const Vec3& y, const Patch& py, long long* rays = nullptr) const;
};

// With enabled false, none.
MirrorPlanes mirror_planes(const PatchSet& patches, const std::vector<Material>& materials,
                           bool enabled);

}  // namespace polyrad
