// The chains of mirror planes a straight path from a point may pass (mirror_chains.h).
#include "polyrad/transport/mirror_chains.h"

#include <algorithm>
#include <span>
#include <utility>

namespace polyrad {

namespace {

// An affine map p -> l p + t: a reflection in a plane, or several composed.
struct Unfold {
  Eigen::Matrix3d l;
  Vec3 t;
  Vec3 operator()(const Vec3& p) const { return l * p + t; }
};

// R(p) = p - 2 (n . p - d) n.
Unfold reflection(const MirrorPlanes::Plane& q) {
  return {Eigen::Matrix3d::Identity() - 2.0 * q.normal * q.normal.transpose(),
          2.0 * q.offset * q.normal};
}

// a after b.
Unfold compose(const Unfold& a, const Unfold& b) { return {a.l * b.l, a.l * b.t + a.t}; }

// Plane c's window unfolded by f, cut to its part beyond plane `first` (height < 0; x, at height
// hx > 0, sees nothing nearer through the first window), and projected from x onto `first`, into
// out (whose room is kept from call to call).
void projected_window(const MirrorPlanes::Plane& first, const MirrorPlanes::Plane& c,
                      const Unfold& f, const Vec3& x, double hx, std::vector<Vec2>& out) {
  const std::size_t n = c.window.size();
  const auto corner = [&](std::size_t k) { return f(c.point(c.window[k])); };
  const auto project = [&](const Vec3& p, double hp) {
    return first.coords(x + (hx / (hx - hp)) * (p - x));
  };
  out.clear();
  Vec3 p = corner(0);
  double hp = first.height(p);
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 q = corner((k + 1) % n);
    const double hq = first.height(q);
    if (hp < 0.0) out.push_back(project(p, hp));
    if ((hp < 0.0) != (hq < 0.0)) out.push_back(project(p + (hp / (hp - hq)) * (q - p), 0.0));
    p = q;
    hp = hq;
  }
}

// Whether a beam is a real one: wider than the windows' growth, 2 area / perimeter (a strip's
// width). Where two windows meet at an edge, their growth overlaps in a sliver as wide as it,
// which no path takes (the corner of two walls, met twice in a row on one axis).
bool wider_than(std::span<const Vec2> beam, double width) {
  double perimeter = 0.0;
  for (std::size_t k = 0; k < beam.size(); ++k)
    perimeter += (beam[(k + 1) % beam.size()] - beam[k]).norm();
  return twice_signed_area(beam) > width * perimeter;
}

}  // namespace

std::int32_t MirrorChains::next(std::int32_t at, std::int32_t q) const {
  std::int32_t begin = 0, end = roots;
  if (at >= 0) {
    const Chain& c = chains[static_cast<std::size_t>(at)];
    begin = c.first_child;
    end = c.first_child + c.children;
  }
  for (std::int32_t k = begin; k < end; ++k)
    if (chains[static_cast<std::size_t>(k)].plane == q) return k;
  return -1;
}

void MirrorChains::planes_of(std::int32_t at, std::int32_t* out) const {
  for (; at >= 0; at = chains[static_cast<std::size_t>(at)].parent) {
    const Chain& c = chains[static_cast<std::size_t>(at)];
    out[c.length - 1] = c.plane;
  }
}

bool MirrorChains::in_beam(std::int32_t at, const Vec2& c) const {
  const Chain& chain = chains[static_cast<std::size_t>(at)];
  return convex_contains(beams.data() + chain.beam_begin, static_cast<std::size_t>(chain.beam_size),
                         c);
}

MirrorChains mirror_chains(const MirrorPlanes& m, const Vec3& x, int max_length,
                           std::size_t budget) {
  MirrorChains out;
  out.x = x;
  const auto& planes = m.planes;
  const auto plane = [&](std::int32_t q) -> const MirrorPlanes::Plane& {
    return planes[static_cast<std::size_t>(q)];
  };
  if (max_length < 2 ||
      std::none_of(planes.begin(), planes.end(), [](const auto& p) { return !p.facing.empty(); }))
    return out;
  std::vector<Unfold> unfold;       // per chain: R_0 ... R_{n-1}, which unfolds its next window
  std::vector<std::int32_t> first;  // per chain: its first plane
  for (std::int32_t q = 0; q < static_cast<std::int32_t>(planes.size()); ++q)
    if (!plane(q).facing.empty() && plane(q).height(x) > 0.0 && plane(q).window.size() >= 3) {
      const auto& window = plane(q).window;
      out.chains.push_back({q, -1, 1, 0, 0, static_cast<std::int32_t>(out.beams.size()),
                            static_cast<std::int32_t>(window.size())});
      out.beams.insert(out.beams.end(), window.begin(), window.end());
      unfold.push_back(reflection(plane(q)));
      first.push_back(q);
    }
  out.roots = static_cast<int>(out.chains.size());
  out.depth = out.roots > 0 ? 1 : 0;
  std::size_t begin = 0, end = out.chains.size(), kept = 0;
  std::vector<Vec2> window;  // a projected window, its room kept
  std::vector<MirrorChains::Chain> level;
  std::vector<Vec2> level_beams;
  std::vector<std::pair<std::int32_t, std::int32_t>> children;  // per chain of a level
  for (int length = 2; length <= max_length && begin < end; ++length) {
    // The next level, kept only whole.
    level.clear();
    level_beams.clear();
    children.clear();
    const auto base = static_cast<std::int32_t>(out.chains.size());
    for (std::size_t at = begin; at < end; ++at) {
      const MirrorChains::Chain& c = out.chains[at];
      const MirrorPlanes::Plane& a = plane(first[at]);
      const std::span<const Vec2> beam(out.beams.data() + c.beam_begin,
                                       static_cast<std::size_t>(c.beam_size));
      const auto before = static_cast<std::int32_t>(level.size());
      for (const std::int32_t b : plane(c.plane).facing) {
        if (plane(b).emits) continue;
        projected_window(a, plane(b), unfold[at], x, a.height(x), window);
        const std::size_t start = level_beams.size();
        const std::size_t corners = intersect_convex(beam, window, level_beams);
        if (corners == 0) continue;
        if (!wider_than(std::span<const Vec2>(level_beams.data() + start, corners),
                        10.0 * m.grow)) {
          level_beams.resize(start);
          continue;
        }
        level.push_back({b, static_cast<std::int32_t>(at), length, 0, 0,
                         static_cast<std::int32_t>(start), static_cast<std::int32_t>(corners)});
        // A level that outgrows the budget is dropped whole: stop clipping it (at budget 256 on
        // the mirrored room's floor, that level is as large as half the kept ones together).
        if (kept + level.size() > budget) {
          out.cut = true;
          return out;
        }
      }
      children.emplace_back(base + before, static_cast<std::int32_t>(level.size()) - before);
    }
    if (level.empty()) break;
    for (std::size_t at = begin; at < end; ++at) {
      out.chains[at].first_child = children[at - begin].first;
      out.chains[at].children = children[at - begin].second;
    }
    const auto shift = static_cast<std::int32_t>(out.beams.size());
    for (MirrorChains::Chain& c : level) {
      c.beam_begin += shift;
      unfold.push_back(
          compose(unfold[static_cast<std::size_t>(c.parent)], reflection(plane(c.plane))));
      first.push_back(first[static_cast<std::size_t>(c.parent)]);
      out.chains.push_back(c);
    }
    out.beams.insert(out.beams.end(), level_beams.begin(), level_beams.end());
    kept += level.size();
    out.depth = length;
    begin = end;
    end = out.chains.size();
  }
  return out;
}

}  // namespace polyrad
