// Convex polygons in the plane (geometry/convex_polygon.h).
#include "polyrad/geometry/convex_polygon.h"

#include <algorithm>
#include <array>
#include <cstddef>

namespace polyrad {

namespace {

double cross(const Vec2& a, const Vec2& b, const Vec2& p) {
  return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
}

// The part of polygon[0, n) on the left of the line a -> b, into out[0, room); returns its
// corner count. A convex polygon gains at most one corner; one made not quite convex by
// rounding (corners a hair apart on the line) may cross it more often, and what would not fit
// is dropped rather than written past the room.
std::size_t clip_left(const Vec2* polygon, std::size_t n, const Vec2& a, const Vec2& b, Vec2* out,
                      std::size_t room) {
  std::size_t m = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2& p = polygon[k];
    const Vec2& q = polygon[(k + 1) % n];
    const double sp = cross(a, b, p), sq = cross(a, b, q);
    if (sp >= 0.0 && m < room) out[m++] = p;
    if ((sp >= 0.0) != (sq >= 0.0) && m < room) out[m++] = p + (sp / (sp - sq)) * (q - p);
  }
  return m;
}

// Whether the boxes of two polygons are apart: then so are the polygons (half the chains a
// gather tries among four mirror walls end so, and this costs a + b corners, not a x b).
bool boxes_apart(std::span<const Vec2> a, std::span<const Vec2> b) {
  Vec2 alo = a[0], ahi = a[0], blo = b[0], bhi = b[0];
  for (const Vec2& p : a) {
    alo = alo.cwiseMin(p);
    ahi = ahi.cwiseMax(p);
  }
  for (const Vec2& p : b) {
    blo = blo.cwiseMin(p);
    bhi = bhi.cwiseMax(p);
  }
  return (ahi.array() < blo.array()).any() || (bhi.array() < alo.array()).any();
}

}  // namespace

double twice_signed_area(std::span<const Vec2> polygon) {
  double sum = 0.0;
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Vec2& p = polygon[k];
    const Vec2& q = polygon[(k + 1) % polygon.size()];
    sum += p.x() * q.y() - q.x() * p.y();
  }
  return sum;
}

std::vector<Vec2> convex_hull(std::vector<Vec2> points) {
  std::sort(points.begin(), points.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  std::vector<Vec2> hull(2 * points.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {  // lower chain
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  for (std::size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {  // upper chain
    while (k >= lower && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);  // the last point is the first again
  return hull;
}

std::size_t intersect_convex(std::span<const Vec2> a, std::span<const Vec2> b,
                             std::vector<Vec2>& out) {
  if (a.size() < 3 || b.size() < 3 || boxes_apart(a, b)) return 0;
  // Each clip of a convex polygon adds at most one corner: two buffers of a + b corners and
  // more, in turn (on the stack for the beams' few corners, which a gather clips at every hit).
  const std::size_t room = a.size() + b.size() + 4;
  std::array<Vec2, 64> stack;
  std::vector<Vec2> heap;
  Vec2* from = stack.data();
  if (2 * room > stack.size()) {
    heap.resize(2 * room);
    from = heap.data();
  }
  Vec2* to = from + room;
  std::size_t n = a.size();
  if (twice_signed_area(a) > 0.0)
    std::copy(a.begin(), a.end(), from);
  else
    std::reverse_copy(a.begin(), a.end(), from);
  const bool ccw = twice_signed_area(b) > 0.0;
  for (std::size_t k = 0; k < b.size() && n >= 3; ++k) {
    const Vec2& p = b[k];
    const Vec2& q = b[(k + 1) % b.size()];
    n = ccw ? clip_left(from, n, p, q, to, room) : clip_left(from, n, q, p, to, room);
    std::swap(from, to);
  }
  if (n < 3 || !(twice_signed_area(std::span<const Vec2>(from, n)) > 0.0)) return 0;
  out.insert(out.end(), from, from + n);
  return n;
}

bool convex_contains(const Vec2* corners, std::size_t count, const Vec2& p) {
  if (count < 3) return false;
  for (std::size_t k = 0; k < count; ++k)
    if (cross(corners[k], corners[(k + 1) % count], p) < 0.0) return false;
  return true;
}

}  // namespace polyrad
