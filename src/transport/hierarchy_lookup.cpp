// What a ray hit reads from a hierarchy (hierarchy.h): the leaf under a point of a root patch,
// and the leaves' corner averages for smooth shading.
#include <algorithm>
#include <cmath>
#include <map>

#include "polyrad/transport/hierarchy.h"

namespace polyrad {

namespace {

constexpr double kParamTolerance = 1e-9;
// The deepest grid leaf_at starts a quad's descent from: 256 cells, 1 KiB a root.
constexpr int kMaxGridDepth = 4;

// Parameters of a root's corners (Patch::point): quad corners at the unit square's, triangle
// corners at (0,0), (1,0), (0,1).
Vec2 corner_param(const Patch& p, int k) {
  static const Vec2 kQuad[4] = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  static const Vec2 kTriangle[3] = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)};
  return p.is_triangle() ? kTriangle[k % 3] : kQuad[k % 4];
}

// Barycentric parameters of q in the parameter triangle uv[0..2] (an element's corners).
Vec2 triangle_local(const Vec2* uv, const Vec2& q) {
  const Vec2 a = uv[1] - uv[0], b = uv[2] - uv[0], d = q - uv[0];
  const double det = a.x() * b.y() - a.y() * b.x();
  return Vec2((d.x() * b.y() - d.y() * b.x()) / det, (a.x() * d.y() - a.y() * d.x()) / det);
}

// q's parameters on the element with parameter corners uv (its own Patch::point).
Vec2 local_params(const Vec2* uv, bool triangle, const Vec2& q) {
  if (triangle) return triangle_local(uv, q);
  return Vec2((q.x() - uv[0].x()) / (uv[2].x() - uv[0].x()),
              (q.y() - uv[0].y()) / (uv[2].y() - uv[0].y()));
}
// Whether element e holds q within tol.
bool holds(const Element& e, const Vec2& q, double tol) {
  const Vec2 st = local_params(e.uv.data(), e.shape.is_triangle(), q);
  if (e.shape.is_triangle())
    return st.x() >= -tol && st.y() >= -tol && st.x() + st.y() <= 1.0 + tol;
  return st.x() >= -tol && st.x() <= 1.0 + tol && st.y() >= -tol && st.y() <= 1.0 + tol;
}

// The child of node n that holds q (its children tile it; ties go to the later half).
std::int32_t child_holding(const ElementHierarchy::LookupNode& n, bool triangle, const Vec2& q) {
  if (!triangle) {
    const Vec2 mid = 0.5 * (n.uv[0] + n.uv[2]);
    return n.first_child + (q.x() >= mid.x() ? 1 : 0) + (q.y() >= mid.y() ? 2 : 0);
  }
  const Vec2 st = triangle_local(n.uv.data(), q);
  if (st.x() >= 0.5) return n.first_child + 1;
  if (st.y() >= 0.5) return n.first_child + 2;
  if (st.x() + st.y() <= 0.5) return n.first_child;
  return n.first_child + 3;
}

// The point of quad p that Embree's parameters (u, v) name: Embree splits the quad into
// triangles (0, 1, 3) and (2, 3, 1) and reports the second's parameters as 1 - u', 1 - v'.
Vec3 embree_point(const Patch& p, double u, double v) {
  if (u + v <= 1.0)
    return p.corner[0] + u * (p.corner[1] - p.corner[0]) + v * (p.corner[3] - p.corner[0]);
  return p.corner[2] + (1.0 - u) * (p.corner[3] - p.corner[2]) +
         (1.0 - v) * (p.corner[1] - p.corner[2]);
}

// Parameters of the bilinear map (Patch::point) nearest to x, by Gauss-Newton from (u, v).
Vec2 bilinear_params(const Patch& p, const Vec3& x, double u, double v) {
  Vec2 st(u, v);
  for (int it = 0; it < 6; ++it) {
    Vec3 du, dv;
    p.tangents(st.x(), st.y(), &du, &dv);
    const Vec3 r = x - p.point(st.x(), st.y());
    const double a = du.dot(du), b = du.dot(dv), c = dv.dot(dv);
    const double det = a * c - b * b;
    if (!(det > 0.0)) break;
    const double gx = du.dot(r), gy = dv.dot(r);
    const Vec2 step((c * gx - b * gy) / det, (a * gy - b * gx) / det);
    st = (st + step).cwiseMax(0.0).cwiseMin(1.0);
    if (step.squaredNorm() < 1e-24) break;
  }
  return st;
}

}  // namespace

LeafPoint ElementHierarchy::leaf_at(PatchId root, double u, double v) const {
  const Patch& p = (*roots_)[root];
  const bool triangle = p.is_triangle();
  Vec2 q(u, v);
  if (!triangle) {
    if (skewed_[root]) q = bilinear_params(p, embree_point(p, u, v), u, v);
    q = q.cwiseMax(0.0).cwiseMin(1.0);
  }
  std::int32_t e = root;
  if (const int depth = grid_depth_[root]; depth > 0) {  // a quad's tree: its grid first
    const int n = 1 << depth;
    const int i = std::min(static_cast<int>(q.x() * n), n - 1);
    const int j = std::min(static_cast<int>(q.y() * n), n - 1);
    e = grid_[grid_start_[root] + j * n + i];
  }
  while (lookup_[e].first_child >= 0) e = child_holding(lookup_[e], triangle, q);
  const Vec2 st = local_params(lookup_[e].uv.data(), triangle, q);
  return {e, lookup_[e].leaf, st.x(), st.y(), lookup_[e].diameter};
}

void ElementHierarchy::build_lookup(const PatchSet& roots) {
  lookup_.resize(elements_.size());
  for (std::size_t k = 0; k < elements_.size(); ++k) {
    const Element& e = elements_[k];
    lookup_[k] = {e.first_child, e.leaf, e.shape.diameter(), {e.uv[0], e.uv[1], e.uv[2]}};
  }
  skewed_.resize(roots.size());
  // Each root's deepest level (roots are elements 0 to R - 1, at level 0), at most
  // kMaxGridDepth: the depth of its grid.
  std::vector<int> deepest(roots.size(), 0);
  for (const Element& e : elements_) deepest[e.root] = std::max(deepest[e.root], e.level);
  grid_depth_.assign(roots.size(), 0);
  grid_start_.assign(roots.size(), 0);
  grid_.clear();
  for (std::size_t r = 0; r < roots.size(); ++r) {
    const Patch& p = roots[r];
    skewed_[r] = !p.is_triangle() && !p.is_parallelogram();
    // The grid of a quad's tree at its leaves' deepest level: each cell the element the descent
    // reaches at that level. The splits halve the parameters, so a cell is the floor of q times
    // 2^depth, exactly as the descent compares q with the midpoints.
    const int depth = std::min(deepest[r], kMaxGridDepth);
    if (p.is_triangle() || depth == 0) continue;
    const int n = 1 << depth;
    grid_depth_[r] = static_cast<std::uint8_t>(depth);
    grid_start_[r] = static_cast<std::int64_t>(grid_.size());
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Vec2 q((i + 0.5) / n, (j + 0.5) / n);
        std::int32_t e = static_cast<std::int32_t>(r);
        while (lookup_[e].first_child >= 0 && elements_[e].level < depth)
          e = child_holding(lookup_[e], false, q);
        grid_.push_back(e);
      }
  }
}

void ElementHierarchy::diffuse_weights(PatchId root, double u, double v, bool smooth,
                                       std::vector<std::pair<std::int32_t, double>>& out) const {
  diffuse_weights(leaf_at(root, u, v), smooth, out);
}

void ElementHierarchy::diffuse_weights(const LeafPoint& lp, bool smooth,
                                       std::vector<std::pair<std::int32_t, double>>& out) const {
  if (!smooth) {
    out.emplace_back(lp.leaf, 1.0);
    return;
  }
  const auto cw = elements_[lp.element].shape.corner_weights(lp.s, lp.t);
  for (int c = 0; c < 4; ++c) {
    if (cw[c] == 0.0) continue;
    const auto k = 4 * static_cast<std::int64_t>(lp.leaf) + c;
    for (auto e = corner_start_[k]; e < corner_start_[k + 1]; ++e)
      out.emplace_back(corner_entries_[e].first, cw[c] * corner_entries_[e].second);
  }
}

void ElementHierarchy::build_corner_averages(const PatchSet& roots) {
  // Roots by welded corner id, and root edges by their directed pair of corner ids (the ids are
  // welded within an object, so neighbours found here are of the same object).
  std::map<std::int32_t, std::vector<PatchId>> by_vertex;
  std::map<std::pair<std::int32_t, std::int32_t>, std::vector<std::pair<PatchId, int>>> by_edge;
  for (PatchId r = 0; r < static_cast<PatchId>(roots.size()); ++r) {
    const Patch& p = roots[r];
    for (int k = 0; k < p.corners; ++k) {
      auto& list = by_vertex[p.vertex_id[k]];
      if (list.empty() || list.back() != r) list.push_back(r);
      by_edge[{p.vertex_id[k], p.vertex_id[(k + 1) % p.corners]}].emplace_back(r, k);
    }
  }
  std::vector<std::int32_t> found, stack;
  // Leaves of root r whose closed parameter domain holds q.
  auto collect = [&](PatchId r, const Vec2& q) {
    stack.assign(1, r);
    while (!stack.empty()) {
      const std::int32_t e = stack.back();
      stack.pop_back();
      if (!holds(elements_[e], q, kParamTolerance)) continue;
      if (elements_[e].first_child < 0)
        found.push_back(e);
      else
        for (int c = 0; c < 4; ++c) stack.push_back(elements_[e].first_child + c);
    }
  };
  const double cos_limit = std::cos(10.0 * kPi / 180.0);
  const auto leaves = static_cast<std::int64_t>(leaf_element_.size());
  corner_start_.assign(4 * leaves + 1, 0);
  corner_entries_.clear();
  for (std::int64_t l = 0; l < leaves; ++l) {
    const Element& leaf = elements_[leaf_element_[l]];
    const Patch& root = roots[leaf.root];
    for (int c = 0; c < 4; ++c) {
      const Vec2 q = leaf.uv[std::min(c, leaf.shape.corners - 1)];
      found.clear();
      collect(leaf.root, q);
      int at_corner = -1;
      for (int k = 0; k < root.corners; ++k)
        if ((q - corner_param(root, k)).cwiseAbs().maxCoeff() < kParamTolerance) at_corner = k;
      if (at_corner >= 0) {  // every root that shares the welded corner
        const std::int32_t id = root.vertex_id[at_corner];
        for (PatchId r : by_vertex[id]) {
          if (r == leaf.root) continue;
          for (int k = 0; k < roots[r].corners; ++k)
            if (roots[r].vertex_id[k] == id) {
              collect(r, corner_param(roots[r], k));
              break;
            }
        }
      } else {  // on an edge of the root: the root across it, at the same point of the edge
        int edge = -1;
        double tau = 0.0;
        if (root.is_triangle()) {
          if (std::abs(q.y()) < kParamTolerance)
            edge = 0, tau = q.x();
          else if (std::abs(q.x() + q.y() - 1.0) < kParamTolerance)
            edge = 1, tau = q.y();
          else if (std::abs(q.x()) < kParamTolerance)
            edge = 2, tau = 1.0 - q.y();
        } else {
          if (std::abs(q.y()) < kParamTolerance)
            edge = 0, tau = q.x();
          else if (std::abs(q.x() - 1.0) < kParamTolerance)
            edge = 1, tau = q.y();
          else if (std::abs(q.y() - 1.0) < kParamTolerance)
            edge = 2, tau = 1.0 - q.x();
          else if (std::abs(q.x()) < kParamTolerance)
            edge = 3, tau = 1.0 - q.y();
        }
        if (edge >= 0) {
          const std::int32_t a = root.vertex_id[edge],
                             b = root.vertex_id[(edge + 1) % root.corners];
          for (bool reversed : {true, false}) {
            auto it = by_edge.find(reversed ? std::make_pair(b, a) : std::make_pair(a, b));
            if (it == by_edge.end()) continue;
            for (const auto& [r, m] : it->second) {
              if (r == leaf.root) continue;
              const double t = reversed ? 1.0 - tau : tau;
              const Vec2 qr = (1.0 - t) * corner_param(roots[r], m) +
                              t * corner_param(roots[r], (m + 1) % roots[r].corners);
              collect(r, qr);
            }
          }
        }
      }
      std::sort(found.begin(), found.end());
      found.erase(std::unique(found.begin(), found.end()), found.end());
      double total = 0.0;
      const auto first = corner_entries_.size();
      for (std::int32_t e : found) {
        const Element& x = elements_[e];
        if (x.shape.normal.dot(leaf.shape.normal) < cos_limit) continue;
        corner_entries_.emplace_back(x.leaf, static_cast<float>(x.exposed));
        total += x.exposed;
      }
      for (auto k = first; k < corner_entries_.size(); ++k)
        corner_entries_[k].second =
            total > 0.0 ? static_cast<float>(corner_entries_[k].second / total) : 0.0f;
      corner_start_[4 * l + c + 1] = static_cast<std::int64_t>(corner_entries_.size());
    }
  }
}

}  // namespace polyrad
