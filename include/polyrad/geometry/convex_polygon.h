// Convex polygons in the plane, counter-clockwise: the outline of a mirror plane's patches and the
// beam of straight lines through a chain of mirrors (transport/mirror_chains.h) are both kept so.
// The intersection of two convex polygons is the first clipped by each edge of the second
// (Sutherland and Hodgman): a point p stays on the left of edge a -> b where
//     (b - a) x (p - a) >= 0.
//
//   std::vector<Vec2> hull = convex_hull(points);            // counter-clockwise, no repeats
//   std::vector<Vec2> both = intersect_convex(hull, other);  // empty if they do not overlap
//   bool in = convex_contains(both, p);
//
// Cost: the hull O(n log n); an intersection O(n m); a containment test O(n).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "polyrad/types.h"

namespace polyrad {

// Twice the signed area (positive counter-clockwise).
double twice_signed_area(std::span<const Vec2> polygon);

// The convex hull of points, counter-clockwise (Andrew's monotone chain); fewer than three
// corners if the points are all on one line.
std::vector<Vec2> convex_hull(std::vector<Vec2> points);

// a n b for convex a and b of either orientation, counter-clockwise, appended to out; returns
// how many corners it appended: none (out as it was) when they meet in less than a positive area
// (at most an edge or a corner).
std::size_t intersect_convex(std::span<const Vec2> a, std::span<const Vec2> b,
                             std::vector<Vec2>& out);
inline std::vector<Vec2> intersect_convex(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
  std::vector<Vec2> out;
  intersect_convex(std::span<const Vec2>(a), std::span<const Vec2>(b), out);
  return out;
}

// Whether p lies in the counter-clockwise convex polygon of corners[0, count) (its edges
// included).
bool convex_contains(const Vec2* corners, std::size_t count, const Vec2& p);
inline bool convex_contains(const std::vector<Vec2>& polygon, const Vec2& p) {
  return convex_contains(polygon.data(), polygon.size(), p);
}

}  // namespace polyrad
