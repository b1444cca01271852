// The hierarchy's operator as its builder lays it out (hierarchy_builder.h; eq. H2 of
// papers/glossy-radiosity.md): the trees in pre-order, the link rows with their slopes, and the
// energy guard (section 5).
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "hierarchy_builder.h"
#include "polyrad/util/machine.h"

namespace polyrad {

namespace {

// The energy guard's factors c_k for one tree's leaves, of exposed areas A'_k, form-factor sums
// s_k and caps u_k: c_k = min(w, u_k), with the water level w >= 1 that keeps the tree's flux
// sum_k A'_k c_k s_k at sum_k A'_k s_k (the links' etendues), or as near as the caps allow.
// By bisection.
std::vector<double> guard_weights(const std::vector<double>& area, const std::vector<double>& sum,
                                  const std::vector<double>& cap) {
  double flux = 0.0, room = 0.0;
  for (std::size_t k = 0; k < area.size(); ++k) {
    flux += area[k] * sum[k];
    room += area[k] * cap[k] * sum[k];
  }
  const auto shot = [&](double w) {
    double f = 0.0;
    for (std::size_t k = 0; k < area.size(); ++k) f += area[k] * std::min(w, cap[k]) * sum[k];
    return f;
  };
  double w = 1.0;
  if (shot(1.0) < flux) {
    if (!(flux < room)) {
      // No water level keeps it: every leaf at its cap.
      w = std::numeric_limits<double>::infinity();
    } else {
      double lo = 1.0, hi = 2.0;
      while (shot(hi) < flux && hi < 1e6) hi *= 2.0;
      for (int step = 0; step < 60; ++step)
        (shot(0.5 * (lo + hi)) < flux ? lo : hi) = 0.5 * (lo + hi);
      w = hi;
    }
  }
  std::vector<double> c(area.size());
  for (std::size_t k = 0; k < area.size(); ++k) c[k] = std::min(w, cap[k]);
  return c;
}

// Columns ascending in each row of the link rows, a row a task.
void sort_rows(Csr<std::array<float, 5>>& f) {
  std::vector<std::pair<std::int32_t, std::array<float, 5>>> row;
#pragma omp parallel for schedule(dynamic, 256) firstprivate(row)
  for (std::int32_t k = 0; k < static_cast<std::int32_t>(f.rows); ++k) {
    row.clear();
    for (auto e = f.start[k]; e < f.start[k + 1]; ++e) row.emplace_back(f.column[e], f.value[e]);
    std::sort(row.begin(), row.end(),
              [](const auto& x, const auto& y) { return x.first < y.first; });
    for (size_t e = 0; e < row.size(); ++e) {
      f.column[f.start[k] + e] = row[e].first;
      f.value[f.start[k] + e] = row[e].second;
    }
  }
}

// The rows [lo, hi) of the calling thread of a parallel region: those whose entries start in
// its equal share of all of them, so that the team's threads together hold every row once.
std::pair<std::int32_t, std::int32_t> thread_rows(const std::vector<std::int64_t>& start) {
  const std::int64_t total = start.back(), t = omp_get_thread_num(), team = omp_get_num_threads();
  const auto row_at = [&](std::int64_t e) {
    if (e >= total) return static_cast<std::int32_t>(start.size() - 1);
    return static_cast<std::int32_t>(std::lower_bound(start.begin(), start.end(), e) -
                                     start.begin());
  };
  return {t == 0 ? 0 : row_at(total * t / team), row_at(total * (t + 1) / team)};
}

}  // namespace

using hierarchy_detail::corner_drop;
using hierarchy_detail::fit_linear;
using hierarchy_detail::LinearFit;
using hierarchy_detail::wholly_exposed;

void HierarchyBuilder::make_operator() {
  h_.op_.reset();  // the last pass's operator, freed before this one is built
  auto op = std::make_shared<HierarchicalOperator>();
  const std::vector<std::int32_t> node_of = lay_out_trees(*op);
  sum_inner_exposed();
  lay_out_nodes(*op, node_of);
  const auto n = static_cast<std::int32_t>(node_element_.size());
  op->centroid_.resize(n);
  for (std::int32_t k = 0; k < n; ++k) {
    const Vec2& c = el_[node_element_[k]].centroid_uv;
    op->centroid_[k] = {static_cast<float>(c.x()), static_cast<float>(c.y())};
  }
  const LeafBoxes boxes = box_leaf_centroids(*op);
  fill_link_rows(*op, node_of, boxes, false);
  sort_rows(op->links_);
  fill_link_rows(*op, node_of, boxes, true);  // image rows keep the links' order (with planes)
  for (const auto& plane : h_.mirrors_.planes)
    op->plane_colour_.push_back(plane.specular.cast<float>());
  energy_guard(*op);
  h_.op_ = std::move(op);
}

// Pre-order, tree by tree: a parent before its children, child 0 first.
std::vector<std::int32_t> HierarchyBuilder::lay_out_trees(HierarchicalOperator& op) {
  const auto ne = static_cast<std::int32_t>(el_.size());
  std::vector<std::int32_t> node_of(ne, -1);
  node_element_.clear();
  op.tree_start_.push_back(0);
  std::vector<std::int32_t> stack;
  for (std::int32_t r = 0; r < h_.num_roots_; ++r) {
    stack.push_back(r);
    while (!stack.empty()) {
      const std::int32_t e = stack.back();
      stack.pop_back();
      node_of[e] = static_cast<std::int32_t>(node_element_.size());
      node_element_.push_back(e);
      if (el_[e].first_child >= 0)
        for (int c = 3; c >= 0; --c) stack.push_back(el_[e].first_child + c);
    }
    op.tree_start_.push_back(static_cast<std::int32_t>(node_element_.size()));
  }
  return node_of;
}

// A' of inner nodes: the sum of their children's, so that the pull conserves flux exactly.
void HierarchyBuilder::sum_inner_exposed() {
  const auto n = static_cast<std::int32_t>(node_element_.size());
  for (std::int32_t k = n - 1; k >= 0; --k) {
    Element& e = el_[node_element_[k]];
    if (e.first_child < 0) continue;
    double sum = 0.0;
    for (int c = 0; c < 4; ++c) sum += el_[e.first_child + c].exposed;
    e.exposed = sum;
  }
}

// Each node's parent, its share of the parent's A', its A' and its leaf; the leaves' reflectance.
void HierarchyBuilder::lay_out_nodes(HierarchicalOperator& op,
                                     const std::vector<std::int32_t>& node_of) {
  const auto n = static_cast<std::int32_t>(node_element_.size());
  op.parent_.resize(n);
  op.share_.resize(n);
  op.node_leaf_.assign(n, -1);
  op.exposed_.resize(n);
  h_.leaf_element_.clear();
  for (std::int32_t k = 0; k < n; ++k) {
    Element& e = el_[node_element_[k]];
    op.parent_[k] = e.parent < 0 ? -1 : node_of[e.parent];
    const double pa = e.parent < 0 ? 0.0 : el_[e.parent].exposed;
    op.share_[k] = pa > 0.0 ? static_cast<float>(e.exposed / pa) : 0.0f;
    op.exposed_[k] = e.exposed;
    e.leaf = -1;
    if (e.first_child < 0) {
      e.leaf = static_cast<std::int32_t>(op.leaf_node_.size());
      op.node_leaf_[k] = e.leaf;
      op.leaf_node_.push_back(k);
      op.rho_.push_back(rho_[node_element_[k]].cast<float>());
      h_.leaf_element_.push_back(node_element_[k]);
    }
  }
}

// Link rows (eq. H2): F_ab = m, F_ba = m A'_a / A'_b, from one etendue G = A'_a m, each with
// the slopes of its linear function over the receiver. A block of links at a time: their
// entries on all threads (the slopes' fits are most of the cost), then each thread writes the
// entries of its own run of rows, so that no two threads write one row's counter (with the
// places taken atomically instead, the two threads fought over the counters of rows they shared,
// and filling the room's rows on two threads took longer than on one: 0.47 against 0.34 s; now
// 0.25 s). Each thread scans the whole block for its rows' entries, work that grows with the
// team: cheap on two threads, worth bucketing by owner on many. The order in a row is then the
// links', and sort_rows puts it in column order (no two links join one pair).
void HierarchyBuilder::fill_link_rows(HierarchicalOperator& op,
                                      const std::vector<std::int32_t>& node_of,
                                      const LeafBoxes& boxes, bool images) const {
  // Which rows a link fills: a direct link both ends' rows; an image link those of its ends
  // that take images, one row for an element seen in a mirror by itself.
  const auto in_a = [&](const KeptLink& l) {
    return (l.mirror() >= 0) == images && (!images || takes_images(l.a));
  };
  const auto in_b = [&](const KeptLink& l) {
    return (l.mirror() >= 0) == images && (!images || (takes_images(l.b) && l.a != l.b));
  };
  constexpr std::int64_t kBlock = std::int64_t{1} << 16;  // 2.6 MB of entries
  const auto n = static_cast<std::int32_t>(node_element_.size());
  std::vector<std::int64_t> count(n + 1, 0);
  for (const auto& chunk : links_)
    for (const auto& l : chunk) {
      if (in_a(l)) ++count[node_of[l.a] + 1];
      if (in_b(l)) ++count[node_of[l.b] + 1];
    }
  Csr<std::array<float, 5>>& f = images ? op.images_ : op.links_;
  f.rows = f.cols = n;
  f.start.assign(n + 1, 0);
  for (std::int32_t k = 0; k < n; ++k) f.start[k + 1] = f.start[k] + count[k + 1];
  resize_on_huge_pages(f.column, f.start[n]);
  resize_on_huge_pages(f.value, f.start[n]);
  if (images) {
    op.image_plane_.assign(static_cast<std::size_t>(f.start[n]), 0);
    op.image_root_.assign(static_cast<std::size_t>(f.start[n]), -1);
  }
  std::vector<std::int32_t> crossing(images ? kBlock : 0);
  std::vector<std::int64_t> fill(f.start.begin(), f.start.end() - 1);
  std::vector<LinkEntries> entries(kBlock);
  for (const auto& chunk : links_) {
    const auto size = static_cast<std::int64_t>(chunk.size());
    for (std::int64_t first = 0; first < size; first += kBlock) {
      const std::int64_t m = std::min(kBlock, size - first);
#pragma omp parallel for schedule(dynamic, 256)
      for (std::int64_t k = 0; k < m; ++k) {
        const KeptLink& l = chunk[first + k];
        if (!in_a(l) && !in_b(l)) continue;
        entries[k] = link_entries(l.expand(), node_of, boxes);
        if (images) crossing[k] = crossing_root(l.a, l.b, l.mirror());
      }
#pragma omp parallel
      {
        // This thread's rows: those whose entries start in its share of them all.
        const auto [lo, hi] = thread_rows(f.start);
        for (std::int64_t k = 0; k < m; ++k) {
          const KeptLink& l = chunk[first + k];
          const std::int32_t ra = node_of[l.a], rb = node_of[l.b];
          if (ra >= lo && ra < hi && in_a(l)) {
            if (images) {
              op.image_plane_[fill[ra]] = static_cast<std::uint8_t>(l.mirror());
              op.image_root_[fill[ra]] = crossing[k];
            }
            f.column[fill[ra]] = rb;
            f.value[fill[ra]++] = entries[k].a;
          }
          if (rb >= lo && rb < hi && in_b(l)) {
            if (images) {
              op.image_plane_[fill[rb]] = static_cast<std::uint8_t>(l.mirror());
              op.image_root_[fill[rb]] = crossing[k];
            }
            f.column[fill[rb]] = ra;
            f.value[fill[rb]++] = entries[k].b;
          }
        }
      }
    }
  }
}

// Each side's point form factors (times their visible fractions, for a partly hidden pair) as
// a linear function of its mean: the fitted slopes scaled to F. Constant for a hidden pair or
// a partly buried element (whose leaves' exposed areas would not integrate the slopes to 0).
Vec2 HierarchyBuilder::slope_of(std::int32_t r, const std::array<float, kOraclePoints>& points,
                                LinkVisibility v, double mean) const {
  const Element& e = el_[r];
  if (v == LinkVisibility::kHidden || !wholly_exposed(e) || !(mean > 0.0)) return Vec2::Zero();
  const LinearFit fit = fit_linear(e, points);
  return fit.mean > 0.0 ? Vec2(fit.slope * (mean / fit.mean)) : Vec2::Zero();
}

// Per node, the box of its leaves' centroids about its own, from the operator's float centroids
// as the pull and the push take their differences: a leaf's box is its centroid alone, a
// parent's holds its children's. Reverse pre-order, so that a child is complete first.
HierarchyBuilder::LeafBoxes HierarchyBuilder::box_leaf_centroids(
    const HierarchicalOperator& op) const {
  const auto n = static_cast<std::int32_t>(node_element_.size());
  constexpr double kInf = std::numeric_limits<double>::infinity();
  LeafBoxes at(n, {kInf, kInf, -kInf, -kInf});  // absolute u0 v0 u1 v1
  for (std::int32_t k = n - 1; k >= 0; --k) {
    auto& b = at[k];
    if (op.node_leaf_[k] >= 0)
      b = {op.centroid_[k][0], op.centroid_[k][1], op.centroid_[k][0], op.centroid_[k][1]};
    const std::int32_t p = op.parent_[k];
    if (p < 0) continue;
    auto& bp = at[p];
    bp = {std::min(bp[0], b[0]), std::min(bp[1], b[1]), std::max(bp[2], b[2]),
          std::max(bp[3], b[3])};
  }
  for (std::int32_t k = 0; k < n; ++k) {
    const double cu = op.centroid_[k][0], cv = op.centroid_[k][1];
    at[k] = {at[k][0] - cu, at[k][1] - cv, at[k][2] - cu, at[k][3] - cv};
  }
  return at;
}

// The most the slope takes below its value at a node's centroid (element r, its leaves' box b)
// where the operator reads it: at the centroids of the leaves under it, which lie in their box
// and in r (the smaller of the two bounds: a triangle's box reaches beyond it). Bounded at r's
// corners instead, the slopes were shrunk on links whose leaves never read the kernel there,
// and with them the part of what a receiver gathers where the source's light and the form
// factor vary together: cornell-box read from the mesh (roots 25, tau 0.05) had its walls,
// floor and ceiling 0.08 to 0.13 percent dark against 16,384 spp, now 0.05 to 0.09.
double HierarchyBuilder::leaf_drop(std::int32_t r, const std::array<double, 4>& b,
                                   const Vec2& slope) const {
  const double box = std::max(-slope.x() * b[0], -slope.x() * b[2]) +
                     std::max(-slope.y() * b[1], -slope.y() * b[3]);
  return std::max(0.0, std::min(corner_drop(el_[r], slope), box));
}

// Link l's entries: in a's row (F_ab, its slopes over a, c_ab) and in b's.
HierarchyBuilder::LinkEntries HierarchyBuilder::link_entries(
    const ElementLink& l, const std::vector<std::int32_t>& node_of, const LeafBoxes& boxes) const {
  const std::int32_t ra = node_of[l.a], rb = node_of[l.b];
  const double aa = el_[l.a].exposed, ab = el_[l.b].exposed;
  const double g = aa * l.m;  // the etendue / pi
  const double f_ab = l.m, f_ba = ab > 0.0 ? g / ab : 0.0;
  Vec2 ga = slope_of(l.a, l.fa, l.visibility, f_ab), gb = slope_of(l.b, l.fb, l.visibility, f_ba);
  // The kernel between a point y of a and y' of b is taken as
  // G/(A'_a A'_b) + ga.(y - y_a)/A'_b + gb.(y' - y_b)/A'_a (times A'_b for F_ab): keep it
  // non-negative over the boxes of the leaves' centroids under a and b (leaf_drop), so that T
  // is, by shrinking both slopes together; with a margin of 1e-5 for the floats they are stored
  // in, since a leaf may sit at the corner where the kernel is least (with none, entries of
  // -1.5e-11 came out).
  constexpr double kKeep = 1.0 - 1e-5;
  const double need = aa * leaf_drop(l.a, boxes[ra], ga) + ab * leaf_drop(l.b, boxes[rb], gb);
  if (need > kKeep * g) {
    const double scale = g > 0.0 ? kKeep * g / need : 0.0;
    ga *= scale;
    gb *= scale;
  }
  const Vec2 ca = ab > 0.0 && aa > 0.0 ? Vec2(gb * (ab / aa)) : Vec2::Zero();  // c_ab
  const Vec2 cb = ab > 0.0 && aa > 0.0 ? Vec2(ga * (aa / ab)) : Vec2::Zero();  // c_ba
  return {{static_cast<float>(f_ab), static_cast<float>(ga.x()), static_cast<float>(ga.y()),
           static_cast<float>(ca.x()), static_cast<float>(ca.y())},
          {static_cast<float>(f_ba), static_cast<float>(gb.x()), static_cast<float>(gb.y()),
           static_cast<float>(cb.x()), static_cast<float>(cb.y())}};
}

// The energy guard: every column of T sums to at most a_max in flux form (section 5). The form
// factors along the links of the nodes above a leaf, each at the leaf's own place to first
// order, sum to about its true total, at most 1; near contacts, where the linear functions are
// too coarse, they sum above it. Where that takes the leaf's column, each receiver weighed by
// its albedo bound (d + s for a lobe: a bound of d + s sum_k R_jik, not yet known here), above
// a_max, the leaf's values are scaled down before the pull. No further: the links' etendues are
// exact, so a leaf's excess is what its tree's other leaves lack, and scaling loses the flux of
// a tree with no room to take it back. Held to 1 by the form factors alone, the guard scaled
// 39,386 of the room's 87,965 leaves (now 166 of 87,995) and its trees of one level were not
// the uniform mesh: the room at 60 cm, unrefined, 0.5 to 0.7 percent darker (now the same
// image). What it takes is given back to the tree's leaves whose form factors sum below 1, up
// to their own flux and the bound (guard_weights): scaling alone lost 1.2 to 1.7 percent of a
// closed box's flux.
void HierarchyBuilder::energy_guard(HierarchicalOperator& op) {
  op.guard_.assign(op.leaf_node_.size(), 1.0f);
  const Material* brightest = brightest_material(materials_);
  const double a_max = brightest ? brightest->albedo_bound().maxCoeff() : 0.0;
  // The receivers' reflectance as T applies it (floats), a lobe's colour added in full. A planar
  // mirror's colour so counts what its image links carry too (eq. H4): from the points of a
  // leaf, the images seen in a mirror fill at most the mirror's own solid angle, so they are
  // left out of the bound; counted at their receivers' reflectance instead, a leaf whose form
  // factors sum above 1 near a contact went unguarded (a closed box of grey faces and a mirror,
  // every albedo a_max: leaves up to 0.9 percent too bright, 0.4 with the mirror's colour).
  std::vector<Eigen::Array3d> bound = op.tree_reflectance();
  for (std::int32_t t = 0; t < h_.num_roots_; ++t) {
    const Material& m = materials_[roots_[t].material];
    if (lobes_ && m.has_lobe()) bound[t] += m.specular.cast<float>().cast<double>();
  }
  const std::vector<double> sums =
      op.column_sums_by([&](std::int32_t t, std::int64_t) { return bound[t]; }, false);
  h_.stats_.guard_max_excess = 0.0;
  h_.stats_.guard_leaves = 0;
  for (double sum : sums)
    if (sum > a_max) {
      h_.stats_.guard_max_excess = std::max(h_.stats_.guard_max_excess, sum / a_max - 1.0);
      ++h_.stats_.guard_leaves;
    }
  if (o_.energy_guard && a_max > 0.0) guard_trees(op, sums, a_max);
}

// The guard's factors tree by tree, from each leaf's column sum `sums` (weighed by the bound).
void HierarchyBuilder::guard_trees(HierarchicalOperator& op, const std::vector<double>& sums,
                                   double a_max) const {
  const std::vector<double> ff = op.column_sums(false, false);
  std::vector<std::vector<std::int32_t>> tree_leaves(roots_.size());
  for (std::size_t l = 0; l < sums.size(); ++l)
    tree_leaves[el_[h_.leaf_element_[l]].root].push_back(static_cast<std::int32_t>(l));
  for (const auto& leaves : tree_leaves) {
    // Caps: the bound, and no more than the leaf's own flux where its form factors sum
    // below 1, so what is given back goes where the form factors are short of it.
    std::vector<double> area(leaves.size()), sum(leaves.size()), cap(leaves.size());
    for (std::size_t k = 0; k < leaves.size(); ++k) {
      const std::int32_t l = leaves[k];
      area[k] = el_[h_.leaf_element_[l]].exposed;
      sum[k] = ff[l];
      cap[k] = std::max(1.0, ff[l] > 0.0 ? 1.0 / ff[l] : 1.0);
      if (sums[l] > 0.0) cap[k] = std::min(cap[k], a_max / sums[l]);
    }
    const std::vector<double> c = guard_weights(area, sum, cap);
    for (std::size_t k = 0; k < leaves.size(); ++k) {
      float& g = op.guard_[leaves[k]];
      g = static_cast<float>(c[k]);
      // float rounding must not leave the column above a_max
      while (static_cast<double>(g) * sums[leaves[k]] > a_max) g = std::nextafter(g, 0.0f);
    }
  }
}

}  // namespace polyrad
