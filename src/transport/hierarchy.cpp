// Element trees, the refinement oracle and the passes that link them (hierarchy.h). Equation
// numbers refer to papers/glossy-radiosity.md (H1 the oracle, H2 the operator, section 12).
#include "polyrad/transport/hierarchy.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <span>

#include "hierarchy_builder.h"
#include "polyrad/util/error.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace {

// A convex polygon of at most 8 corners on the stack (an element has 4; one clip adds 1).
struct SmallPolygon {
  std::array<Vec3, 8> v;
  int n = 0;
};

// The part of element p in front of the plane through `origin` with normal `normal`.
void clip_front(const Patch& p, const Vec3& origin, const Vec3& normal, SmallPolygon& out) {
  out.n = 0;
  for (int k = 0; k < p.corners; ++k) {
    const Vec3& a = p.corner[k];
    const Vec3& b = p.corner[(k + 1) % p.corners];
    const double da = (a - origin).dot(normal), db = (b - origin).dot(normal);
    if (da >= 0.0) out.v[out.n++] = a;
    if ((da >= 0.0) != (db >= 0.0)) out.v[out.n++] = a + (da / (da - db)) * (b - a);
  }
}

bool any_corner_in_front(const Patch& p, const Patch& plane, double eps) {
  for (int c = 0; c < p.corners; ++c)
    if ((p.corner[c] - plane.centroid).dot(plane.normal) > eps) return true;
  return false;
}

// A child's shape from its corners, as the mesher makes a patch (Newell normal, area centroid);
// the bend stays the root's, by which rays from any of its points are lifted (ray_caster.h).
Patch child_shape(const Patch& root, const std::array<Vec3, 4>& corner, int corners) {
  Patch p = root;
  p.corners = corners;
  p.corner = corner;
  if (corners == 3) p.corner[3] = p.corner[2];
  Vec3 n = Vec3::Zero();
  for (int a = 0; a < corners; ++a) n += p.corner[a].cross(p.corner[(a + 1) % corners]);
  p.area = 0.5 * n.norm();
  p.normal = n.normalized();
  const Vec3 c012 = (p.corner[0] + p.corner[1] + p.corner[2]) / 3.0;
  if (corners == 3) {
    p.centroid = c012;
  } else {
    const double a012 = 0.5 * (p.corner[1] - p.corner[0]).cross(p.corner[2] - p.corner[0]).norm();
    const Vec3 c023 = (p.corner[0] + p.corner[2] + p.corner[3]) / 3.0;
    const double a023 = 0.5 * (p.corner[2] - p.corner[0]).cross(p.corner[3] - p.corner[0]).norm();
    p.centroid = (a012 * c012 + a023 * c023) / (a012 + a023);
  }
  p.vertex_id = {0, 0, 0, 0};
  return p;
}

// The area centroid of an element in its root's parameters: exact on a 2 x 2 Gauss rule, as a
// planar quad's area density is linear in its parameters (a triangle's is constant).
Vec2 area_centroid_uv(const Patch& root, const std::array<Vec2, 4>& uv) {
  if (root.is_triangle()) return (uv[0] + uv[1] + uv[2]) / 3.0;
  const GaussRule& g = gauss_legendre(2);
  Vec2 sum = Vec2::Zero();
  double weight = 0.0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      const Vec2 q = uv[0] + g.node[a] * (uv[1] - uv[0]) + g.node[b] * (uv[3] - uv[0]);
      Vec3 du, dv;
      root.tangents(q.x(), q.y(), &du, &dv);
      const double w = g.weight[a] * g.weight[b] * du.cross(dv).norm();
      sum += w * q;
      weight += w;
    }
  return weight > 0.0 ? Vec2(sum / weight) : Vec2((uv[0] + uv[2]) / 2.0);
}

// The parameters of the oracle's sample points of an element (as ElementLink's fa, fb).
Vec2 sample_uv(const Element& e, int k) {
  return k < e.shape.corners ? Vec2(e.uv[k] + 0.01 * (e.centroid_uv - e.uv[k])) : e.centroid_uv;
}

// The linear function of the root parameters that fits the point form factors f over element r
// in least squares: its value at r's centroid, its slopes, and the most it misses a point by.
struct LinearFit {
  double mean = 0.0;
  Vec2 slope = Vec2::Zero();
  double miss = 0.0;
};
LinearFit fit_linear(const Element& r, const std::array<float, kOraclePoints>& f) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (int k = 0; k < kOraclePoints; ++k) {
    const Vec2 d = sample_uv(r, k) - r.centroid_uv;
    const Eigen::Vector3d row(1.0, d.x(), d.y());
    normal += row * row.transpose();
    rhs += row * static_cast<double>(f[k]);
  }
  const Eigen::Vector3d x = normal.ldlt().solve(rhs);
  LinearFit fit{x[0], Vec2(x[1], x[2]), 0.0};
  for (int k = 0; k < kOraclePoints; ++k) {
    const Vec2 d = sample_uv(r, k) - r.centroid_uv;
    fit.miss = std::max(fit.miss, std::abs(f[k] - (fit.mean + fit.slope.dot(d))));
  }
  return fit;
}

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

// The factor (at most 1) by which slopes must shrink for a linear function of this mean to stay
// non-negative on r: a linear function's least value on a polygon is at a corner.
double non_negative_scale(const Element& r, const Vec2& slope, double mean) {
  double drop = 0.0;
  for (int k = 0; k < r.shape.corners; ++k)
    drop = std::max(drop, -slope.dot(r.uv[k] - r.centroid_uv));
  return drop > mean ? std::max(mean, 0.0) / drop : 1.0;
}

bool wholly_exposed(const Element& e) { return e.exposed >= e.shape.area * (1.0 - 1e-9); }

}  // namespace

using hierarchy_detail::longest_edge;

// dF of eq. H1 for receiver `r` of link l (r is l.a or l.b).
double HierarchyBuilder::spread(const ElementLink& l, std::int32_t r) const {
  if (l.visibility == LinkVisibility::kHidden) return 0.0;
  const auto& f = r == l.a ? l.fa : l.fb;
  if (l.visibility == LinkVisibility::kUntested) return *std::max_element(f.begin(), f.end());
  // What a link gives r is the fitted linear function, its slopes shrunk where it would go
  // negative: it misses the point values (times their visible fractions, for a partly hidden
  // pair) by the fit's miss plus what the shrinking took.
  const Element& e = el_[r];
  const LinearFit fit = fit_linear(e, f);
  const double scale = non_negative_scale(e, fit.slope, fit.mean);
  double reach = 0.0;
  for (int k = 0; k < e.shape.corners; ++k)
    reach = std::max(reach, std::abs(fit.slope.dot(e.uv[k] - e.centroid_uv)));
  return fit.miss + (1.0 - scale) * reach;
}

// Eq. H1 for receiver r of link l (r is l.a or l.b), per channel c, against what r receives:
// - wholly visible: what the linear function misses of the point values, dF_rs, within the
//   tolerance's share of what the link carries,
//       rho_r B_s dF_rs <= tau rho_r F_rs max(B_s, kDarkest B_ref)
//   (F_rs estimated by the mean of the point values), so that the misses of all the links a
//   leaf reads, which near a wall share one sign, add up to about tau of its light; or the
//   link is negligible: rho_r B_s F_rs <= kNegligible tau max(B_r, kDarkest B_ref);
// - not yet tested by rays: the same with dF = F_max (linked without rays only then);
// - partly hidden: the shadow may put all of it anywhere (the visible fractions at the points
//   shape the linear function but are too noisy to judge it by):
//       rho_r B_s F_max <= tau max(B_r, kDarkest B_ref),
//   a share of r's own radiosity, so a shadow is refined until it is a small part of the
//   light where it falls;
// - hidden: linked as it is, never refined.
// A source in a reflector's tree shines toward r with B_s + S_{root(s)->root(r)} (eq. H3 (a)),
// as the last solve found it.
bool HierarchyBuilder::accurate_for(const ElementLink& l, std::int32_t r) const {
  const auto& f = r == l.a ? l.fa : l.fb;
  const std::int32_t source = r == l.a ? l.b : l.a;
  const Eigen::Array3d b = b_[source] + specular_toward(el_[source].root, el_[r].root);
  // A receiver with a lobe passes on what it gathers with d + s, and shines with B_r plus its
  // links' mean S: judged so, a mirror and a wall are refined as two walls would be (the
  // five points of one end miss the kernel's rise along a shared edge that splitting the
  // other end reveals).
  const Eigen::Array3d& rho = judged_rho_[el_[r].root];
  const Eigen::Array3d b_r = b_[r] + mean_s_[el_[r].root];
  const double tau = o_.tolerance();
  if (l.visibility == LinkVisibility::kHidden) return true;
  if (l.visibility == LinkVisibility::kPartial) {
    const double f_max = r == l.a ? l.fmax_a : l.fmax_b;
    for (int c = 0; c < 3; ++c)
      if (rho[c] * b[c] * f_max > tau * std::max(b_r[c], kDarkest * b_ref_)) return false;
    return true;
  }
  const double d = spread(l, r);
  if (!(d > 0.0)) return true;
  double mean = 0.0;
  for (float v : f) mean += v / kOraclePoints;
  for (int c = 0; c < 3; ++c) {
    if (!(rho[c] > 0.0)) continue;
    const double floor = kDarkest * b_ref_;
    if (d * b[c] <= tau * mean * std::max(b[c], floor)) continue;  // relative to the link
    if (rho[c] * b[c] * mean <= kNegligible * tau * std::max(b_r[c], floor)) continue;
    return false;
  }
  return true;
}

std::uint64_t HierarchyBuilder::pair_key(std::int32_t a, std::int32_t b) const {
  const auto n = static_cast<std::uint64_t>(roots_.size());
  if (el_[a].parent < 0 && el_[b].parent < 0) {  // two roots: the uniform mesh's key
    const auto i = static_cast<std::uint64_t>(std::min(a, b)),
               j = static_cast<std::uint64_t>(std::max(a, b));
    return i * n + j;
  }
  const std::uint64_t ka = el_[a].key, kb = el_[b].key;
  return mix64(std::min(ka, kb)) ^ std::max(ka, kb);
}

bool HierarchyBuilder::point_form_factors(std::int32_t a, std::int32_t b, ElementLink& l) const {
  const Patch &pa = el_[a].shape, &pb = el_[b].shape;
  const double eps = 1e-9 * std::max(pa.diameter(), pb.diameter());
  if (!any_corner_in_front(pb, pa, eps) || !any_corner_in_front(pa, pb, eps)) return false;
  // Eq. 5, unoccluded, from r's sample points (see ElementLink) to s clipped to r's front.
  auto values = [&](const Patch& r, const Patch& s, std::array<float, kOraclePoints>& f) {
    SmallPolygon front;
    clip_front(s, r.centroid, r.normal, front);
    for (int k = 0; k < kOraclePoints; ++k) {
      const Vec3 x = k < r.corners ? r.corner[k] + 0.01 * (r.centroid - r.corner[k]) : r.centroid;
      double v = 0.0;
      if (front.n >= 3 && (x - s.centroid).dot(s.normal) > eps)
        v = point_to_polygon_form_factor(x, r.normal,
                                         std::span<const Vec3>(front.v.data(), front.n));
      f[k] = static_cast<float>(v);
    }
  };
  l.a = a;
  l.b = b;
  values(pa, pb, l.fa);
  values(pb, pa, l.fb);
  return true;
}

PatchExposure HierarchyBuilder::exposure_of(std::int32_t e) const {
  const Element& el = el_[e];
  PatchExposure x(el.shape.area > 0.0 ? el.exposed / el.shape.area : 0.0);
  if (x.fraction > 0.0 && !x.wholly()) {
    const auto [map, index] = exposure_at_[e];
    if (map >= 0) {
      const PatchExposure grid = exposure_maps_[map][index];
      x.n = grid.n;
      x.cells = grid.cells;
    }
  }
  return x;
}

LinkVisibility HierarchyBuilder::probe(ElementLink& l, long long* rays) const {
  // Stratified point pairs keyed by the pair, until both outcomes have been seen.
  const std::int32_t a = l.a, b = l.b;
  const Patch &pa = el_[a].shape, &pb = el_[b].shape;
  const int m = std::max(1, o_.visibility_rays);
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(m))));
  Rng rng(o_.seed, pair_key(a, b));
  // On a partly buried element, points inside other geometry are skipped: they see nothing and
  // no one sees them, which is not a shadow (their area is not in A').
  const bool buried_a = !wholly_exposed(el_[a]), buried_b = !wholly_exposed(el_[b]);
  const PatchExposure exposure_a = exposure_of(a), exposure_b = exposure_of(b);
  int blocked = 0, open = 0;
  for (int k = 0; k < m && !(blocked > 0 && open > 0); ++k) {
    const double u0 = rng.uniform32(), v0 = rng.uniform32();
    const double u1 = rng.uniform32(), v1 = rng.uniform32();
    const int k2 = (k * 5 + 3) % m;  // the other end's stratum, shuffled against this one's
    double density;
    const Vec3 x =
        pa.sample(Vec2((k % side + u0) / side, ((k / side) % side + v0) / side), &density);
    const Vec3 y =
        pb.sample(Vec2((k2 % side + u1) / side, ((k2 / side) % side + v1) / side), &density);
    if ((buried_a && !exposure_a.exposed_at(pa, x, caster_)) ||
        (buried_b && !exposure_b.exposed_at(pb, y, caster_)))
      continue;
    ++*rays;
    if (caster_.segment_occluded(x, pa, y, pb))
      ++blocked;
    else
      ++open;
  }
  if (open == 0) return LinkVisibility::kHidden;
  if (blocked == 0) return LinkVisibility::kVisible;  // (also when every point was buried)
  // Partly hidden: each oracle point's value times its visible fraction, from kPointRays rays
  // to stratified points of the other element, so that the linear function follows a penumbra
  // and the miss measures what it cannot follow.
  auto weigh = [&](const Patch& from, const Patch& to, std::array<float, kOraclePoints>& f,
                   int which) {
    for (int k = 0; k < kOraclePoints; ++k) {
      if (!(f[k] > 0.0f)) continue;
      const Vec3 x = k < from.corners
                         ? Vec3(from.corner[k] + 0.01 * (from.centroid - from.corner[k]))
                         : from.centroid;
      Rng point(o_.seed, pair_key(a, b), which * kOraclePoints + k + 1);
      int seen = 0, cast = 0;
      const bool buried_to = which == 0 ? buried_b : buried_a;
      const PatchExposure& exposure_to = which == 0 ? exposure_b : exposure_a;
      for (int j = 0; j < kPointRays; ++j) {
        const double u = point.uniform32(), v = point.uniform32();
        double density;
        const Vec3 y = to.sample(Vec2((j % 2 + u) / 2.0, (j / 2 + v) / 2.0), &density);
        if (buried_to && !exposure_to.exposed_at(to, y, caster_)) continue;
        ++*rays;
        ++cast;
        if (!caster_.segment_occluded(x, from, y, to)) ++seen;
      }
      f[k] *= cast > 0 ? static_cast<float>(seen) / cast : 0.0f;
    }
  };
  l.fmax_a = *std::max_element(l.fa.begin(), l.fa.end());
  l.fmax_b = *std::max_element(l.fb.begin(), l.fb.end());
  weigh(pa, pb, l.fa, 0);
  weigh(pb, pa, l.fb, 1);
  return LinkVisibility::kPartial;
}

HierarchyBuilder::Outcome HierarchyBuilder::judge(const Candidate& c) const {
  const std::int32_t a = c.a, b = c.b;
  Outcome out;
  if (!(el_[a].exposed > 0.0) || !(el_[b].exposed > 0.0)) return out;
  ElementLink& l = out.link;
  if (!point_form_factors(a, b, l)) return out;
  out.decision = kLink;
  if (c.visibility == LinkVisibility::kVisible) {
    l.visibility = c.visibility;
  } else {
    // Below the tolerance even as a partly hidden pair: link without casting a ray.
    if (accurate(l)) return out;
    out.probed = true;
    // Hidden as far as the rays tell: link at this level (its pair form factor finds whatever
    // the rays missed) and never refine it.
    l.visibility = probe(l, &out.rays);
  }
  if (l.visibility == LinkVisibility::kHidden || accurate(l)) return out;
  const std::int32_t s = split_choice(a, b);
  out.decision = s < 0 ? kLink : (s == a ? kSplitA : kSplitB);
  return out;
}

void HierarchyBuilder::split(std::int32_t e) {
  if (el_[e].first_child >= 0) return;
  const Element parent = el_[e];  // a copy: el_ grows below
  const Patch& root = roots_[parent.root];
  const auto first = static_cast<std::int32_t>(el_.size());
  el_[e].first_child = first;
  // Grown by a quarter, not doubled: the slack sits beside the operator in the solves between
  // passes (elements are 352 bytes), and a copy of 20,000 is quick.
  if (el_.size() + 4 > el_.capacity()) {
    const std::size_t grown = el_.capacity() + el_.capacity() / 4 + 4;
    el_.reserve(grown);
    rho_.reserve(grown);
    b_.reserve(grown);
  }
  std::array<std::array<Vec2, 4>, 4> uvs;
  if (!root.is_triangle()) {
    const Vec2 lo = parent.uv[0], hi = parent.uv[2], mid = 0.5 * (lo + hi);
    for (int c = 0; c < 4; ++c) {
      const int a = c % 2, b = c / 2;  // child c = a + 2 b: a the u half, b the v half
      const double u0 = a ? mid.x() : lo.x(), u1 = a ? hi.x() : mid.x();
      const double v0 = b ? mid.y() : lo.y(), v1 = b ? hi.y() : mid.y();
      uvs[c] = {Vec2(u0, v0), Vec2(u1, v0), Vec2(u1, v1), Vec2(u0, v1)};
    }
  } else {
    const Vec2 &p0 = parent.uv[0], &p1 = parent.uv[1], &p2 = parent.uv[2];
    const Vec2 m01 = 0.5 * (p0 + p1), m12 = 0.5 * (p1 + p2), m20 = 0.5 * (p2 + p0);
    uvs[0] = {p0, m01, m20, m20};
    uvs[1] = {m01, p1, m12, m12};
    uvs[2] = {m20, m12, p2, p2};
    uvs[3] = {m12, m20, m01, m01};  // the middle one, counter-clockwise as its parent
  }
  for (int c = 0; c < 4; ++c) {
    Element child;
    child.root = parent.root;
    child.parent = e;
    child.level = parent.level + 1;
    child.uv = uvs[c];
    std::array<Vec3, 4> corner;
    for (int k = 0; k < 4; ++k) corner[k] = root.point(uvs[c][k].x(), uvs[c][k].y());
    child.shape = child_shape(root, corner, root.corners);
    child.centroid_uv = area_centroid_uv(root, child.uv);
    child.key = mix64(parent.key * 4 + static_cast<std::uint64_t>(c) + 1);
    // Exposure: a wholly exposed or wholly buried parent passes it on; a partly buried one's
    // children are measured again (below, in split_all).
    const double fraction = parent.shape.area > 0.0 ? parent.exposed / parent.shape.area : 0.0;
    child.exposed = fraction >= 1.0 - 1e-12 ? child.shape.area : (fraction <= 0.0 ? 0.0 : -1.0);
    el_.push_back(child);
    rho_.push_back(rho_[e]);
    b_.push_back(b_[e]);
  }
}

void HierarchyBuilder::split_all(std::vector<std::int32_t>& elements, HierarchyPass& pass) {
  std::sort(elements.begin(), elements.end());
  elements.erase(std::unique(elements.begin(), elements.end()), elements.end());
  pass.splits += static_cast<long long>(elements.size());
  const auto before = static_cast<std::int32_t>(el_.size());
  for (std::int32_t e : elements) split(e);
  exposure_at_.resize(el_.size(), {-1, -1});  // the new children: no grid unless measured below
  // Children of partly buried parents: their exposed area on 8 x 8 points, 16 x 16 where the
  // buried boundary crosses them (the roots had 4 x 4 and 32 x 32).
  PatchSet measure;
  std::vector<std::int32_t> which;
  for (auto c = before; c < static_cast<std::int32_t>(el_.size()); ++c)
    if (el_[c].exposed < 0.0) {
      measure.patches.push_back(el_[c].shape);
      which.push_back(c);
    }
  if (!which.empty()) {
    const Stopwatch t0;
    const auto map = static_cast<std::int32_t>(exposure_maps_.size());
    exposure_maps_.emplace_back(measure, caster_, 8, 16);
    for (size_t k = 0; k < which.size(); ++k) {
      el_[which[k]].exposed = exposure_maps_.back().area(static_cast<PatchId>(k));
      exposure_at_[which[k]] = {map, static_cast<std::int32_t>(k)};
    }
    h_.stats_.exposure_seconds += t0.seconds();
  }
}

void HierarchyBuilder::refine(std::vector<Candidate> candidates, HierarchyPass& pass) {
  const Stopwatch t0;
  // Judged in batches, so that the outcomes (each with a link's oracle data) are never held for
  // every candidate at once; each batch's links become one chunk.
  constexpr std::int64_t kBatch = std::int64_t{1} << 15;
  while (!candidates.empty()) {
    const auto count = static_cast<std::int64_t>(candidates.size());
    std::vector<std::pair<Decision, LinkVisibility>> decided(count);
    std::vector<Outcome> outcome;
    for (std::int64_t first = 0; first < count; first += kBatch) {
      const std::int64_t n = std::min(kBatch, count - first);
      outcome.assign(n, Outcome{});
      long long rays = 0, probes = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : rays, probes)
      for (std::int64_t k = 0; k < n; ++k) {
        outcome[k] = judge(candidates[first + k]);
        rays += outcome[k].rays;
        probes += outcome[k].probed ? 1 : 0;
      }
      pass.visibility_tests += probes;
      h_.stats_.oracle_rays += rays;
      std::vector<KeptLink> chunk;
      chunk.reserve(static_cast<std::size_t>(std::count_if(
          outcome.begin(), outcome.end(), [](const Outcome& o) { return o.decision == kLink; })));
      for (std::int64_t k = 0; k < n; ++k) {
        decided[first + k] = {outcome[k].decision, outcome[k].link.visibility};
        if (outcome[k].decision != kLink) continue;
        chunk.push_back(KeptLink::keep(outcome[k].link));
        // A link judged again keeps its form factor where the same rules would integrate it
        // again; one linked without rays whose rays now found a shadow below the roots is
        // integrated again with the full count.
        const Candidate& c = candidates[first + k];
        KeptLink& kept = chunk.back();
        kept.m = c.m >= 0.0f && open_rules(c.a, c.b, c.visibility) ==
                                    open_rules(kept.a, kept.b, kept.visibility)
                     ? c.m
                     : -1.0f;
      }
      if (!chunk.empty()) pending_.push_back(std::move(chunk));
    }
    pass.candidates += count;
    std::vector<std::int32_t> to_split;
    for (std::int64_t k = 0; k < count; ++k) {
      if (decided[k].first == kSplitA) to_split.push_back(candidates[k].a);
      if (decided[k].first == kSplitB) to_split.push_back(candidates[k].b);
    }
    split_all(to_split, pass);
    std::vector<Candidate> next;
    for (std::int64_t k = 0; k < count; ++k) {
      const Candidate& c = candidates[k];
      const auto [decision, visibility] = decided[k];
      if (decision == kSplitA) {
        for (int i = 0; i < 4; ++i)
          next.push_back({el_[c.a].first_child + i, c.b, -1.0f, visibility});
      } else if (decision == kSplitB) {
        for (int i = 0; i < 4; ++i)
          next.push_back({c.a, el_[c.b].first_child + i, -1.0f, visibility});
      }
    }
    candidates.swap(next);
  }
  pass.oracle_seconds += t0.seconds();
}

void HierarchyBuilder::link_form_factors(HierarchyPass& pass) {
  const Stopwatch t0;
  std::int64_t total = 0;
  for (const auto& chunk : pending_) total += static_cast<std::int64_t>(chunk.size());
  long long rays = 0;
  FormFactorOptions open_form_factors = o_.form_factors;  // never more rays than the full count
  open_form_factors.visibility_rays =
      std::min(o_.form_factors.visibility_rays, std::max(1, o_.open_link_rays));
  Progress progress("hierarchy form factors", total);
  for (auto& chunk : pending_) {
    const auto count = static_cast<std::int64_t>(chunk.size());
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : rays)
    for (std::int64_t k = 0; k < count; ++k) {
      KeptLink& l = chunk[k];
      if (l.m >= 0.0f) continue;  // judged again after its rays and kept: its form factor is known
      // Integrate over the smaller element, as the uniform mesh does (with its key for two roots,
      // so that a tree of one level reproduces the uniform system exactly).
      std::int32_t x = l.a, y = l.b;
      const bool roots = el_[x].parent < 0 && el_[y].parent < 0;
      if (roots) {
        const std::int32_t i = std::min(x, y), j = std::max(x, y);
        x = el_[i].shape.area <= el_[j].shape.area ? i : j;
        y = x == i ? j : i;
      } else if (el_[y].shape.area < el_[x].shape.area ||
                 (el_[y].shape.area == el_[x].shape.area && el_[y].key < el_[x].key)) {
        std::swap(x, y);
      }
      const Element& ex = el_[x];
      long long r = 0;
      const double g = pair_area_form_factor(
          ex.shape, el_[y].shape, &caster_,
          open_rules(l.a, l.b, l.visibility) ? open_form_factors : o_.form_factors, pair_key(x, y),
          &r, exposure_of(x));
      rays += r;
      if (x != l.a) l.swap_ends();
      l.m = g > 0.0 && ex.exposed > 0.0 ? static_cast<float>(g / ex.exposed) : 0.0f;
      if (k % 256 == 0) progress.advance(256);
    }
  }
  progress.finish();
  h_.stats_.form_factor_rays += rays;
  // Into the links chunk by chunk, without a copy of them.
  for (auto& chunk : pending_) {
    std::erase_if(chunk, [](const KeptLink& l) { return !(l.m > 0.0f); });
    chunk.shrink_to_fit();
    if (!chunk.empty()) links_.push_back(std::move(chunk));
  }
  LinkChunks().swap(pending_);
  pass.form_factor_seconds += t0.seconds();
}

void HierarchyBuilder::make_operator() {
  h_.op_.reset();  // the last pass's operator, freed before this one is built
  auto op = std::make_shared<HierarchicalOperator>();
  const auto ne = static_cast<std::int32_t>(el_.size());
  // Pre-order, tree by tree: a parent before its children, child 0 first.
  std::vector<std::int32_t> node_of(ne, -1);
  node_element_.clear();
  op->tree_start_.push_back(0);
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
    op->tree_start_.push_back(static_cast<std::int32_t>(node_element_.size()));
  }
  const auto n = static_cast<std::int32_t>(node_element_.size());
  // A' of inner nodes: the sum of their children's, so that the pull conserves flux exactly.
  for (std::int32_t k = n - 1; k >= 0; --k) {
    Element& e = el_[node_element_[k]];
    if (e.first_child < 0) continue;
    double sum = 0.0;
    for (int c = 0; c < 4; ++c) sum += el_[e.first_child + c].exposed;
    e.exposed = sum;
  }
  op->parent_.resize(n);
  op->share_.resize(n);
  op->node_leaf_.assign(n, -1);
  op->exposed_.resize(n);
  h_.leaf_element_.clear();
  for (std::int32_t k = 0; k < n; ++k) {
    Element& e = el_[node_element_[k]];
    op->parent_[k] = e.parent < 0 ? -1 : node_of[e.parent];
    const double pa = e.parent < 0 ? 0.0 : el_[e.parent].exposed;
    op->share_[k] = pa > 0.0 ? static_cast<float>(e.exposed / pa) : 0.0f;
    op->exposed_[k] = e.exposed;
    e.leaf = -1;
    if (e.first_child < 0) {
      e.leaf = static_cast<std::int32_t>(op->leaf_node_.size());
      op->node_leaf_[k] = e.leaf;
      op->leaf_node_.push_back(k);
      op->rho_.push_back(rho_[node_element_[k]].cast<float>());
      h_.leaf_element_.push_back(node_element_[k]);
    }
  }
  // Link rows (eq. H2): F_ab = m, F_ba = m A'_a / A'_b, from one etendue G = A'_a m, each with
  // the slopes of its linear function over the receiver.
  std::vector<std::int64_t> count(n + 1, 0);
  for (const auto& chunk : links_)
    for (const auto& l : chunk) {
      ++count[node_of[l.a] + 1];
      ++count[node_of[l.b] + 1];
    }
  Csr<std::array<float, 5>>& f = op->links_;
  f.rows = f.cols = n;
  f.start.assign(n + 1, 0);
  for (std::int32_t k = 0; k < n; ++k) f.start[k + 1] = f.start[k] + count[k + 1];
  f.column.resize(f.start[n]);
  f.value.resize(f.start[n]);
  // Each side's point form factors (times their visible fractions, for a partly hidden pair) as
  // a linear function of its mean: the fitted slopes scaled to F. Constant for a hidden pair or
  // a partly buried element (whose leaves' exposed areas would not integrate the slopes to 0).
  auto slope_of = [&](std::int32_t r, const std::array<float, kOraclePoints>& points,
                      LinkVisibility v, double mean) -> Vec2 {
    const Element& e = el_[r];
    if (v == LinkVisibility::kHidden || !wholly_exposed(e) || !(mean > 0.0)) return Vec2::Zero();
    const LinearFit fit = fit_linear(e, points);
    return fit.mean > 0.0 ? Vec2(fit.slope * (mean / fit.mean)) : Vec2::Zero();
  };
  auto drop = [&](std::int32_t r, const Vec2& slope) {  // the most the slope takes at a corner
    const Element& e = el_[r];
    double d = 0.0;
    for (int k = 0; k < e.shape.corners; ++k) d = std::max(d, -slope.dot(e.uv[k] - e.centroid_uv));
    return d;
  };
  std::vector<std::int64_t> fill(f.start.begin(), f.start.end() - 1);
  for (const auto& chunk : links_)
    for (const KeptLink& kept : chunk) {
      const ElementLink l = kept.expand();
      const std::int32_t ra = node_of[l.a], rb = node_of[l.b];
      const double aa = el_[l.a].exposed, ab = el_[l.b].exposed;
      const double g = aa * l.m;  // the etendue / pi
      const double f_ab = l.m, f_ba = ab > 0.0 ? g / ab : 0.0;
      Vec2 ga = slope_of(l.a, l.fa, l.visibility, f_ab),
           gb = slope_of(l.b, l.fb, l.visibility, f_ba);
      // The kernel between a point y of a and y' of b is taken as
      // G/(A'_a A'_b) + ga.(y - y_a)/A'_b + gb.(y' - y_b)/A'_a (times A'_b for F_ab): keep it
      // non-negative everywhere, so that T is, by shrinking both slopes together.
      const double need = aa * drop(l.a, ga) + ab * drop(l.b, gb);
      if (need > g) {
        const double scale = g > 0.0 ? g / need : 0.0;
        ga *= scale;
        gb *= scale;
      }
      const Vec2 ca = ab > 0.0 && aa > 0.0 ? Vec2(gb * (ab / aa)) : Vec2::Zero();  // c_ab
      const Vec2 cb = ab > 0.0 && aa > 0.0 ? Vec2(ga * (aa / ab)) : Vec2::Zero();  // c_ba
      f.column[fill[ra]] = rb;
      f.value[fill[ra]++] = {static_cast<float>(f_ab), static_cast<float>(ga.x()),
                             static_cast<float>(ga.y()), static_cast<float>(ca.x()),
                             static_cast<float>(ca.y())};
      f.column[fill[rb]] = ra;
      f.value[fill[rb]++] = {static_cast<float>(f_ba), static_cast<float>(gb.x()),
                             static_cast<float>(gb.y()), static_cast<float>(cb.x()),
                             static_cast<float>(cb.y())};
    }
  std::vector<std::pair<std::int32_t, std::array<float, 5>>> row;
  for (std::int32_t k = 0; k < n; ++k) {  // columns ascending in each row
    row.clear();
    for (auto e = f.start[k]; e < f.start[k + 1]; ++e) row.emplace_back(f.column[e], f.value[e]);
    std::sort(row.begin(), row.end(),
              [](const auto& x, const auto& y) { return x.first < y.first; });
    for (size_t e = 0; e < row.size(); ++e) {
      f.column[f.start[k] + e] = row[e].first;
      f.value[f.start[k] + e] = row[e].second;
    }
  }
  op->centroid_.resize(n);
  for (std::int32_t k = 0; k < n; ++k) {
    const Vec2& c = el_[node_element_[k]].centroid_uv;
    op->centroid_[k] = {static_cast<float>(c.x()), static_cast<float>(c.y())};
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
  op->guard_.assign(op->leaf_node_.size(), 1.0f);
  {
    const Material* brightest = brightest_material(materials_);
    const double a_max = brightest ? brightest->albedo_bound().maxCoeff() : 0.0;
    // The receivers' reflectance as T applies it (floats), a lobe's colour added in full.
    std::vector<Eigen::Array3d> bound = op->tree_reflectance();
    for (std::int32_t t = 0; t < h_.num_roots_; ++t) {
      const Material& m = materials_[roots_[t].material];
      if (lobes_ && m.has_lobe()) bound[t] += m.specular.cast<float>().cast<double>();
    }
    const std::vector<double> sums =
        op->column_sums_by([&](std::int32_t t, std::int64_t) { return bound[t]; });
    h_.stats_.guard_max_excess = 0.0;
    h_.stats_.guard_leaves = 0;
    for (double sum : sums)
      if (sum > a_max) {
        h_.stats_.guard_max_excess = std::max(h_.stats_.guard_max_excess, sum / a_max - 1.0);
        ++h_.stats_.guard_leaves;
      }
    if (o_.energy_guard && a_max > 0.0) {
      const std::vector<double> ff = op->column_sums(false, false);
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
          float& g = op->guard_[leaves[k]];
          g = static_cast<float>(c[k]);
          // float rounding must not leave the column above a_max
          while (static_cast<double>(g) * sums[leaves[k]] > a_max) g = std::nextafter(g, 0.0f);
        }
      }
    }
  }
  h_.op_ = std::move(op);
}

int HierarchyBuilder::solve(HierarchyPass& pass) {
  const Stopwatch t0;
  const HierarchicalOperator& op = *h_.op_;
  const auto leaves = static_cast<Eigen::Index>(h_.num_leaves());
  const RootSpecular* sp = op.specular();
  const Eigen::Index size = op.size();
  Field e = Field::Zero(size, 3);
  std::vector<double> w(size);  // flux weights over pi: A'_l, then tau_ik / pi
  for (Eigen::Index l = 0; l < leaves; ++l) {
    e.row(l) = h_.leaf(static_cast<int>(l)).emission.matrix().transpose();
    w[l] = el_[h_.leaf_element_[l]].exposed;
  }
  for (Eigen::Index l = leaves; l < size; ++l) w[l] = sp->flux_weight[l - leaves] / kPi;
  auto norm = [&](const Field& f) {
    double s = 0.0;
    for (Eigen::Index l = 0; l < size; ++l) s += w[l] * f.row(l).cwiseAbs().sum();
    return s;
  };
  const double norm_e = norm(e);
  Field u = e, previous;
  int sweeps = 0;
  for (; sweeps < 200 && norm_e > 0.0; ++sweeps) {
    previous = u;
    op.gauss_seidel_sweep(e, u);
    if (!u.allFinite()) throw NumericalError("the hierarchy's solve between passes diverged");
    if (norm(u - previous) < o_.pass_tolerance * norm_e) {
      ++sweeps;
      break;
    }
  }
  // The specular links' values, for the oracle's sources in reflectors' trees.
  seen_links_.clear();
  seen_s_.clear();
  seen_start_.assign(roots_.size() + 1, 0);
  if (sp) {
    seen_links_ = sp->links;
    seen_start_ = sp->link_start;
    for (Eigen::Index l = leaves; l < size; ++l) seen_s_.push_back(u.row(l).transpose().array());
    for (std::size_t i = 0; i < roots_.size(); ++i) {
      Eigen::Array3d sum = Eigen::Array3d::Zero();
      double weight = 0.0;
      for (auto l = seen_start_[i]; l < seen_start_[i + 1]; ++l) {
        sum += sp->flux_weight[l] * seen_s_[l];
        weight += sp->flux_weight[l];
      }
      mean_s_[i] = weight > 0.0 ? Eigen::Array3d(sum / weight) : Eigen::Array3d::Zero();
    }
  }
  // Radiosity of every element: its leaves' area average (the pull, without the guard).
  for (Eigen::Index l = 0; l < leaves; ++l) b_[h_.leaf_element_[l]] = u.row(l).transpose().array();
  for (auto k = static_cast<std::int64_t>(node_element_.size()) - 1; k >= 0; --k) {
    const Element& x = el_[node_element_[k]];
    if (x.first_child < 0) continue;
    Eigen::Array3d sum = Eigen::Array3d::Zero();
    for (int c = 0; c < 4; ++c) {
      const Element& child = el_[x.first_child + c];
      if (x.exposed > 0.0) sum += (child.exposed / x.exposed) * b_[x.first_child + c];
    }
    b_[node_element_[k]] = sum;
  }
  // From now on B_ref is the solution's own mean reflected radiosity (luminance, by exposed
  // area): the first pass's estimate assumes a closed scene, and an open one loses light.
  double area = 0.0, sum = 0.0;
  for (Eigen::Index l = 0; l < leaves; ++l) {
    area += w[l];
    sum += w[l] * luminance((u.row(l) - e.row(l)).transpose().array());
  }
  if (area > 0.0 && sum > 0.0) b_ref_ = h_.stats_.b_ref = sum / area;
  pass.sweeps = sweeps;
  pass.solve_seconds += t0.seconds();
  return sweeps;
}

void HierarchyBuilder::run() {
  const Stopwatch t_start;
  const auto r = static_cast<std::int32_t>(roots_.size());
  h_.num_roots_ = r;
  h_.roots_ = &roots_;
  HierarchyStats& st = h_.stats_;
  // The roots, with the uniform mesh's exposed areas (form_factors.h).
  {
    const Stopwatch t0;
    exposure_maps_.emplace_back(roots_, caster_, o_.form_factors.exposure_points,
                                o_.form_factors.exposure_refined);
    exposure_at_.resize(r);
    for (std::int32_t p = 0; p < r; ++p) exposure_at_[p] = {0, p};
    st.exposure_seconds += t0.seconds();
    el_.resize(r);
    for (std::int32_t p = 0; p < r; ++p) {
      Element& e = el_[p];
      e.shape = roots_[p];
      e.root = p;
      e.key = static_cast<std::uint64_t>(p);
      e.exposed = exposure_maps_[0].area(p);
      e.uv = roots_[p].is_triangle()
                 ? std::array<Vec2, 4>{Vec2(0, 0), Vec2(1, 0), Vec2(0, 1), Vec2(0, 1)}
                 : std::array<Vec2, 4>{Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
      e.centroid_uv = area_centroid_uv(roots_[p], e.uv);
    }
  }
  min_size_.resize(r);
  for (std::int32_t p = 0; p < r; ++p)
    min_size_[p] = o_.min_element_size > 0.0 ? o_.min_element_size : longest_edge(roots_[p]) / 8.0;
  st.link_tolerance = o_.tolerance();
  st.min_element_size = o_.min_element_size > 0.0 ? o_.min_element_size : 0.0;
  // B_ref: the mean radiosity of a scene whose surfaces all had the mean reflectance.
  double area = 0.0, emitted = 0.0, reflected = 0.0;
  rho_.resize(r);
  b_.resize(r);
  for (std::int32_t p = 0; p < r; ++p) {
    const Patch& q = roots_[p];
    rho_[p] = materials_[q.material].diffuse;
    b_[p] = q.emission;  // the first pass knows only the emission
    area += q.area;
    emitted += q.area * luminance(q.emission);
    reflected += q.area * luminance(rho_[p]);
  }
  const double mean_rho = area > 0.0 ? std::min(reflected / area, 0.99) : 0.0;
  st.b_ref = area > 0.0 ? emitted / area / (1.0 - mean_rho) : 0.0;
  b_ref_ = st.b_ref_estimate = st.b_ref;
  seen_start_.assign(r + 1, 0);  // no specular light known before the first solve
  for (std::int32_t p = 0; p < r && o_.specular_links; ++p)
    lobes_ = lobes_ || materials_[roots_[p].material].has_lobe();
  judged_rho_.resize(r);
  mean_s_.assign(r, Eigen::Array3d::Zero());
  for (std::int32_t p = 0; p < r; ++p) {
    const Material& m = materials_[roots_[p].material];
    judged_rho_[p] = lobes_ && m.has_lobe() ? Eigen::Array3d(m.diffuse + m.specular) : m.diffuse;
  }

  // Pass 0: every facing pair of roots (as the uniform mesh's pair loop), judged with B = E.
  HierarchyPass pass;
  std::vector<Candidate> candidates;
  {
    std::vector<std::vector<Candidate>> rows(r);
    long long facing = 0;
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : facing)
    for (std::int32_t i = 0; i < r; ++i) {
      const Patch& pi = roots_[i];
      for (std::int32_t j = i + 1; j < r; ++j) {
        const Patch& pj = roots_[j];
        const double eps = 1e-9 * std::max(pi.diameter(), pj.diameter());
        if (!any_corner_in_front(pj, pi, eps) || !any_corner_in_front(pi, pj, eps)) continue;
        ++facing;
        if (el_[i].exposed > 0.0 && el_[j].exposed > 0.0) rows[i].push_back({i, j});
      }
    }
    st.root_pairs_facing = facing;
    for (auto& row : rows) candidates.insert(candidates.end(), row.begin(), row.end());
  }
  refine(std::move(candidates), pass);
  link_form_factors(pass);
  // A root that exchanges light with nothing has no exposed area (as in the uniform mesh: a
  // block's face pressed flat on the floor, whose probes cannot tell it is buried).
  {
    std::vector<char> linked(r, 0);
    for (const auto& chunk : links_)
      for (const auto& l : chunk) {
        linked[el_[l.a].root] = 1;
        linked[el_[l.b].root] = 1;
      }
    for (auto& e : el_)
      if (!linked[e.root]) e.exposed = 0.0;
  }
  make_operator();
  if (o_.passes == 0) publish_links();
  attach_specular();
  pass.links = link_count();
  pass.elements = static_cast<long long>(el_.size());
  pass.leaves = h_.num_leaves();
  if (o_.passes > 0) solve(pass);
  st.passes.push_back(pass);

  // Later passes: with the radiosities of the last solve, the links that have become too coarse
  // are judged again: first casting their rays if the first pass linked them without, else
  // splitting the larger end.
  for (int p = 1; p <= o_.passes; ++p) {
    HierarchyPass next;
    std::vector<Candidate> again;
    struct Split {
      std::int32_t element, other;
      LinkVisibility visibility;
    };
    std::vector<Split> split_links;
    for (auto& chunk : links_) {  // the links kept, compacted in place (no copy of them all)
      std::size_t kept = 0;
      for (std::size_t k = 0; k < chunk.size(); ++k) {
        const ElementLink l = chunk[k].expand();
        if (accurate(l)) {
          chunk[kept++] = chunk[k];
        } else if (l.visibility == LinkVisibility::kUntested) {
          again.push_back({l.a, l.b, l.m});
        } else {
          const std::int32_t s = split_choice(l.a, l.b);
          if (s < 0)
            chunk[kept++] = chunk[k];
          else
            split_links.push_back({s, s == l.a ? l.b : l.a, l.visibility});
        }
      }
      chunk.resize(kept);
      chunk.shrink_to_fit();  // one chunk's copy at a time; the slack was 5 MB on the mirror cube
    }
    std::erase_if(links_, [](const auto& chunk) { return chunk.empty(); });
    if (again.empty() && split_links.empty()) break;
    std::vector<std::int32_t> to_split;
    for (const auto& sl : split_links) to_split.push_back(sl.element);
    split_all(to_split, next);
    for (const auto& sl : split_links)
      for (int c = 0; c < 4; ++c)
        again.push_back({el_[sl.element].first_child + c, sl.other, -1.0f, sl.visibility});
    refine(std::move(again), next);
    link_form_factors(next);
    make_operator();
    if (p == o_.passes) publish_links();
    attach_specular();
    next.links = link_count();
    next.elements = static_cast<long long>(el_.size());
    next.leaves = h_.num_leaves();
    if (p < o_.passes) solve(next);
    st.passes.push_back(next);
  }
  if (!links_.empty()) publish_links();  // the passes ended early
  el_.shrink_to_fit();  // the last growth's slack (split grows the arrays by a quarter)
  h_.build_corner_averages(roots_);
  h_.build_lookup(roots_);
  st.seconds = t_start.seconds();
}

void HierarchyBuilder::publish_links() {
  std::vector<LinkedPair> pairs;
  pairs.reserve(static_cast<std::size_t>(link_count()));
  // What the oracle measured goes chunk by chunk as it is copied, before the last specular part
  // is built: the pairs' reserved pages become resident only as they are filled, so the kept
  // links (19 MB on the mirror cube) shrink as they grow (5 MB). Freed only at the end, both
  // beside the operator were the build's peak (72.3 MiB against 68.8 at make_operator).
  for (auto& chunk : links_) {
    for (const KeptLink& l : chunk) pairs.push_back({l.a, l.b, l.m});
    std::vector<KeptLink>().swap(chunk);
  }
  h_.links_.swap(pairs);
  LinkChunks().swap(links_);
}

void HierarchyBuilder::attach_specular() {
  if (!lobes_) return;
  HierarchyStats& st = h_.stats_;
  Stopwatch watch;
  h_.root_ff_ = root_form_factors(h_, materials_, [&](const LinkVisitor& visit) {
    for (const LinkedPair& l : h_.links_) visit(l);  // published (then links_ is empty)
    for (const auto& chunk : links_)
      for (const KeptLink& l : chunk) visit({l.a, l.b, l.m});
  });
  st.root_form_factor_seconds += watch.lap();
  st.root_form_factors = h_.root_ff_.f.nnz();
  // The transfer once, on the first pass's root form factors: later passes split links but
  // keep their pairs of roots, and R_jik is a fraction (each row at most 1) whatever form
  // factors later normalise the flux weights by.
  if (!transfer_done_) {
    h_.transfer_ = compute_specular_transfer(roots_, materials_, h_.root_ff_, caster_, o_.specular);
    transfer_done_ = true;
    st.transfer_seconds += watch.lap();
    st.transfer_entries = h_.transfer_.entries();
  }
  RootSpecular sp = build_root_specular(h_, materials_, h_.root_ff_, h_.transfer_);
  st.specular_links = sp.num_links();
  st.specular_row_entries = sp.rows.nnz();
  h_.op_->specular_ = std::make_shared<const RootSpecular>(std::move(sp));
  st.specular_link_seconds += watch.lap();
}

void ElementHierarchy::release_transfer() {
  root_ff_ = FormFactors{};
  const SpecularStats stats = transfer_.stats;
  transfer_ = SpecularTransfer{};
  transfer_.stats = stats;
}

ElementHierarchy build_hierarchy(const PatchSet& roots, const std::vector<Material>& materials,
                                 const RayCaster& caster, const HierarchyOptions& options) {
  ElementHierarchy h;
  HierarchyBuilder(roots, materials, caster, options, h).run();
  return h;
}

TransportOperator hierarchical_transport(std::shared_ptr<const ElementHierarchy> hierarchy,
                                         const std::vector<Material>& materials) {
  const ElementHierarchy& h = *hierarchy;
  TransportOperator t;
  t.hierarchy_ = h.op();
  t.layout_.hierarchy = hierarchy;
  const auto leaves = h.num_leaves();
  t.layout_.num_patches = leaves;
  t.layout_.flux_weight.resize(leaves);
  t.patch_emission_.resize(leaves);
  for (int l = 0; l < leaves; ++l) {
    t.layout_.flux_weight[l] = kPi * h.elements()[h.element_of_leaf(l)].exposed;
    t.patch_emission_[l] = h.leaf(l).emission;
  }
  // The specular links after the leaves (eq. H3), over root ids: link_start has the layout's
  // num_patches + 1 entries (there are at least as many leaves as roots), constant past the
  // last root, so that link_unknown(i, k) takes the root ids a ray hit names.
  t.layout_.link_start.assign(leaves + 1, 0);
  if (const RootSpecular* sp = h.op()->specular()) {
    t.layout_.links = sp->links;
    for (int r = 0; r <= leaves; ++r)
      t.layout_.link_start[r] = sp->link_start[std::min(r, h.num_roots())];
    t.layout_.flux_weight.insert(t.layout_.flux_weight.end(), sp->flux_weight.begin(),
                                 sp->flux_weight.end());
  }
  if (const Material* m = brightest_material(materials)) {  // a_max
    t.max_albedo_ = m->albedo_bound().maxCoeff();
    t.brightest_material_ = m->name;
  }
  t.weights_.cols = t.size();
  return t;
}

}  // namespace polyrad
