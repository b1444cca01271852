// The hierarchy's image links (hierarchy.h, eq. H4 of papers/glossy-radiosity.md, section
// 12.8): pairs of elements that see each other in a planar mirror, judged by the same oracle as
// the direct links on the mirror image of one end, their visibility by rays through the mirror.
#include <algorithm>
#include <cmath>
#include <limits>

#include "hierarchy_builder.h"
#include "polyrad/transport/form_factors.h"
#include "polyrad/util/sampling.h"

namespace polyrad {

namespace {

// Patch p mirrored in the plane: corners in reverse order, so that they turn about the mirrored
// normal as p's turn about its own. What the form factors read of it: corners, normal,
// centroid, area, diameter.
Patch image_patch(const Patch& p, const MirrorPlanes::Plane& plane) {
  Patch m = p;
  for (int k = 0; k < p.corners; ++k) m.corner[k] = plane.image(p.corner[p.corners - 1 - k]);
  if (p.corners == 3) m.corner[3] = m.corner[2];
  m.normal = p.normal - 2.0 * p.normal.dot(plane.normal) * plane.normal;
  m.centroid = plane.image(p.centroid);
  return m;
}

// Whether some corner of p lies in front of the plane (by more than eps).
bool in_front_of(const Patch& p, const MirrorPlanes::Plane& plane, double eps) {
  for (int c = 0; c < p.corners; ++c)
    if (plane.height(p.corner[c]) > eps) return true;
  return false;
}

// The part of p in front of the plane.
hierarchy_detail::SmallPolygon front_of(const Patch& p, const MirrorPlanes::Plane& plane) {
  hierarchy_detail::SmallPolygon f;
  hierarchy_detail::clip_front(hierarchy_detail::SmallPolygon(p), plane.offset * plane.normal,
                               plane.normal, f);
  return f;
}

// Whether a segment from a point of a to the image of a point of b may cross the plane inside
// its box: the crossings of such segments fill the convex hull of the crossings of the segments
// between the corners of the parts of a and b in front of the plane (a's in front, b's image
// behind it), tested by that hull's box.
bool may_cross_mirror(const Patch& a, const Patch& b, const MirrorPlanes::Plane& plane) {
  const hierarchy_detail::SmallPolygon fa = front_of(a, plane), fb = front_of(b, plane);
  if (fa.n < 3 || fb.n < 3) return false;
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (int i = 0; i < fa.n; ++i) {
    const double ha = std::max(0.0, plane.height(fa.v[i]));
    for (int j = 0; j < fb.n; ++j) {
      const double hb = std::max(0.0, plane.height(fb.v[j]));
      const Vec3 p = ha + hb > 0.0
                         ? Vec3(fa.v[i] + (ha / (ha + hb)) * (plane.image(fb.v[j]) - fa.v[i]))
                         : fa.v[i];
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  return (lo.array() <= plane.hi.array()).all() && (hi.array() >= plane.lo.array()).all();
}

// The inward normal, in the plane of normal n, of edge k of polygon m (counter-clockwise about n).
Vec3 inward(const hierarchy_detail::SmallPolygon& m, int k, const Vec3& n) {
  return n.cross(m.v[(k + 1) % m.n] - m.v[k]);
}

// Whether point p of the plane of normal n lies in the convex polygon m.
bool inside(const Vec3& p, const hierarchy_detail::SmallPolygon& m, const Vec3& n) {
  for (int c = 0; c < m.n; ++c)
    if ((p - m.v[c]).dot(inward(m, c, n)) < 0.0) return false;
  return true;
}

// Each part of the outline (convex polygons in the plane) where the image of s (in front of
// the plane) shows from x, of normal n, in front of x: s's image projected from x onto the plane
// (the same solid angle), cut by each outline polygon and by x's tangent plane. visit(piece).
template <class Visit>
void visible_pieces(const MirrorPlanes::Plane& plane,
                    const std::vector<hierarchy_detail::SmallPolygon>& outline, const Vec3& x,
                    const Vec3& n, const hierarchy_detail::SmallPolygon& s, Visit&& visit) {
  using hierarchy_detail::clip_front;
  using hierarchy_detail::SmallPolygon;
  const double hx = plane.height(x);
  SmallPolygon projected;
  projected.n = s.n;
  for (int k = 0; k < s.n; ++k) {
    const double hy = std::max(0.0, plane.height(s.v[k]));
    projected.v[k] = x + (hx / (hx + hy)) * (plane.image(s.v[k]) - x);
  }
  // Clipped from one buffer into the other, swapped by pointer (a polygon is 600 bytes).
  SmallPolygon buffer[2];
  for (const auto& m : outline) {
    const SmallPolygon* in = &projected;
    SmallPolygon *out = &buffer[0], *spare = &buffer[1];
    for (int k = 0; k < m.n && in->n >= 3; ++k) {
      clip_front(*in, m.v[k], inward(m, k, plane.normal), *out);
      in = out;
      std::swap(out, spare);
    }
    if (in->n < 3) continue;
    clip_front(*in, x, n, *out);
    visit(*out);
  }
}

}  // namespace

using hierarchy_detail::any_corner_in_front;

void HierarchyBuilder::find_mirror_planes() {
  const auto r = static_cast<std::int32_t>(roots_.size());
  root_lobe_.assign(r, 0);
  for (std::int32_t p = 0; p < r; ++p)
    root_lobe_[p] = lobes_ && materials_[roots_[p].material].has_lobe();
  if (!lobes_ || !o_.mirror_links) return;
  MirrorPlanes m = mirror_planes(roots_, materials_, true);
  if (m.planes.size() > static_cast<std::size_t>(kMaxMirrorPlanes)) {
    m.planes.resize(kMaxMirrorPlanes);
    for (auto& q : m.plane_of)
      if (q >= kMaxMirrorPlanes) q = -1;
  }
  h_.stats_.mirror_planes = static_cast<long long>(m.planes.size());
  plane_patches_.assign(m.planes.size(), {});
  plane_roots_.assign(m.planes.size(), {});
  for (std::int32_t p = 0; p < r; ++p)
    if (m.plane_of[p] >= 0) {
      plane_patches_[m.plane_of[p]].push_back(hierarchy_detail::SmallPolygon(roots_[p]));
      plane_roots_[m.plane_of[p]].push_back(p);
    }
  h_.mirrors_ = std::move(m);
  outline_mirror_planes();
}

// A plane whose patches tile a convex polygon (their corners' convex hull has their summed area)
// is clipped against that hull alone: a wall mirror cut into 16 patches takes one clip a point,
// not 16.
void HierarchyBuilder::outline_mirror_planes() {
  plane_outline_ = plane_patches_;
  for (std::size_t q = 0; q < plane_patches_.size(); ++q) {
    const Vec3& n = h_.mirrors_.planes[q].normal;
    const Vec3 u = n.unitOrthogonal(), v = n.cross(u);
    std::vector<Vec2> pts;
    double area = 0.0;
    for (std::int32_t r : plane_roots_[q]) {
      area += roots_[r].area;
      for (int c = 0; c < roots_[r].corners; ++c)
        pts.emplace_back(roots_[r].corner[c].dot(u), roots_[r].corner[c].dot(v));
    }
    // Andrew's monotone chain, counter-clockwise about n.
    std::sort(pts.begin(), pts.end(), [](const Vec2& a, const Vec2& b) {
      return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
    });
    const auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
      return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
    };
    std::vector<Vec2> hull(2 * pts.size());
    std::size_t k = 0;
    const double eps = 1e-12 * std::max(area, 1e-300);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      while (k >= 2 && cross(hull[k - 2], hull[k - 1], pts[i]) <= eps) --k;
      hull[k++] = pts[i];
    }
    for (std::size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {
      while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i]) <= eps) --k;
      hull[k++] = pts[i];
    }
    hull.resize(k > 0 ? k - 1 : 0);
    double hull_area = 0.0;
    for (std::size_t i = 0; i < hull.size(); ++i)
      hull_area += 0.5 * cross(Vec2::Zero(), hull[i], hull[(i + 1) % hull.size()]);
    if (hull.size() < 3 || hull.size() > 8 || std::abs(hull_area - area) > 1e-6 * area) continue;
    hierarchy_detail::SmallPolygon outline;
    const double d = h_.mirrors_.planes[q].offset;
    for (const Vec2& h : hull) outline.v[outline.n++] = d * n + h.x() * u + h.y() * v;
    plane_outline_[q] = {outline};
  }
}

// Every pair of exposed roots i <= j (a root may see itself) off plane q, in front of it, whose
// images face each other through the plane's box, one end at least without a lobe (a lobed
// receiver takes mirror light on its specular links).
std::vector<HierarchyBuilder::Candidate> HierarchyBuilder::mirrored_root_pairs() {
  std::vector<Candidate> candidates;
  const MirrorPlanes& mirrors = h_.mirrors_;
  const auto r = static_cast<std::int32_t>(roots_.size());
  for (std::int32_t q = 0; q < static_cast<std::int32_t>(mirrors.planes.size()); ++q) {
    const MirrorPlanes::Plane& plane = mirrors.planes[q];
    std::vector<std::vector<Candidate>> rows(r);
#pragma omp parallel for schedule(dynamic, 16)
    for (std::int32_t i = 0; i < r; ++i) {
      const Patch& pi = roots_[i];
      const double eps_i = 1e-9 * pi.diameter();
      if (mirrors.plane_of[i] == q || !(el_[i].exposed > 0.0) || !in_front_of(pi, plane, eps_i))
        continue;
      for (std::int32_t j = i; j < r; ++j) {
        const Patch& pj = roots_[j];
        if (mirrors.plane_of[j] == q || !(el_[j].exposed > 0.0)) continue;
        if (root_lobe_[i] && root_lobe_[j]) continue;
        const double eps = 1e-9 * std::max(pi.diameter(), pj.diameter());
        if (!in_front_of(pj, plane, eps)) continue;
        const Patch image = image_patch(pj, plane);
        if (!any_corner_in_front(image, pi, eps) || !any_corner_in_front(pi, image, eps)) continue;
        if (!may_cross_mirror(pi, pj, plane)) continue;
        rows[i].push_back({i, j, -1.0f, LinkVisibility::kUntested, q});
      }
    }
    for (auto& row : rows) candidates.insert(candidates.end(), row.begin(), row.end());
  }
  return candidates;
}

bool HierarchyBuilder::image_point_form_factors(std::int32_t a, std::int32_t b, std::int32_t q,
                                                ElementLink& l) const {
  const MirrorPlanes::Plane& plane = h_.mirrors_.planes[q];
  const Patch &pa = el_[a].shape, &pb = el_[b].shape;
  const double eps = 1e-9 * std::max(pa.diameter(), pb.diameter());
  if (!in_front_of(pa, plane, eps) || !in_front_of(pb, plane, eps)) return false;
  const Patch ib = image_patch(pb, plane);
  if (!any_corner_in_front(ib, pa, eps) || !any_corner_in_front(pa, ib, eps)) return false;
  if (!may_cross_mirror(pa, pb, plane)) return false;
  const auto front = [&](const Patch& p) { return front_of(p, plane); };
  l.a = a;
  l.b = b;
  l.mirror = q;
  for (int k = 0; k < kOraclePoints; ++k) {
    l.fa[k] = static_cast<float>(image_point_form_factor(hierarchy_detail::oracle_point(pa, k),
                                                         pa.normal, front(pb), pb.normal, q));
    l.fb[k] = static_cast<float>(image_point_form_factor(hierarchy_detail::oracle_point(pb, k),
                                                         pb.normal, front(pa), pa.normal, q));
  }
  return true;
}

HierarchyBuilder::Path HierarchyBuilder::path_between(const ElementLink& l, const Vec3& x,
                                                      const Patch& pa, const Vec3& y,
                                                      const Patch& pb, long long* rays) const {
  if (l.mirror < 0) {
    ++*rays;
    return caster_.segment_occluded(x, pa, y, pb) ? Path::kBlocked : Path::kOpen;
  }
  const MirrorPlanes::Plane& plane = h_.mirrors_.planes[l.mirror];
  const double hx = plane.height(x), hy = plane.height(y);
  if (!(hx > 0.0) || !(hy > 0.0)) return Path::kOutside;
  const Vec3 p = x + (hx / (hx + hy)) * (plane.image(y) - x);
  if (!on_outline(p, l.mirror)) return Path::kOutside;
  return h_.mirrors_.path_open(caster_, roots_, l.mirror, x, pa, y, pb, rays) ? Path::kOpen
                                                                              : Path::kBlocked;
}

bool HierarchyBuilder::on_outline(const Vec3& p, std::int32_t q) const {
  const Vec3& n = h_.mirrors_.planes[q].normal;
  for (const auto& m : plane_outline_[q])
    if (inside(p, m, n)) return true;
  return false;
}

std::int32_t HierarchyBuilder::plane_root_at(const Vec3& p, std::int32_t q) const {
  const Vec3& n = h_.mirrors_.planes[q].normal;
  for (std::size_t k = 0; k < plane_patches_[q].size(); ++k)
    if (inside(p, plane_patches_[q][k], n)) return plane_roots_[q][k];
  return -1;
}

std::int32_t HierarchyBuilder::crossing_root(std::int32_t a, std::int32_t b, std::int32_t q) const {
  const MirrorPlanes::Plane& plane = h_.mirrors_.planes[q];
  const Vec3 &x = el_[a].shape.centroid, &y = el_[b].shape.centroid;
  const double hx = std::max(0.0, plane.height(x)), hy = std::max(0.0, plane.height(y));
  const Vec3 p = hx + hy > 0.0 ? Vec3(x + (hx / (hx + hy)) * (plane.image(y) - x)) : x;
  const std::int32_t at = plane_root_at(p, q);
  if (at >= 0) return at;
  std::int32_t nearest = -1;
  double best = std::numeric_limits<double>::infinity();
  for (std::int32_t r : plane_roots_[q]) {
    const double d = (roots_[r].centroid - p).squaredNorm();
    if (d < best) {
      best = d;
      nearest = r;
    }
  }
  return nearest;
}

namespace {

// The form factor from x (normal n) to a convex polygon of any number of corners (in fans of at
// most 8), its sign whichever way the polygon turns.
double polygon_form_factor(const Vec3& x, const Vec3& n, const hierarchy_detail::SmallPolygon& p) {
  if (p.n < 3) return 0.0;
  if (p.n <= 8)
    return std::abs(point_to_polygon_form_factor(x, n, std::span<const Vec3>(p.v.data(), p.n)));
  std::array<Vec3, 8> fan;
  double f = 0.0;
  for (int first = 1; first + 1 < p.n; first += 6) {
    int m = 0;
    fan[m++] = p.v[0];
    for (int k = first; k < std::min(p.n, first + 7); ++k) fan[m++] = p.v[k];
    f += std::abs(point_to_polygon_form_factor(x, n, std::span<const Vec3>(fan.data(), m)));
  }
  return f;
}

}  // namespace

double HierarchyBuilder::image_point_form_factor(const Vec3& x, const Vec3& n,
                                                 const hierarchy_detail::SmallPolygon& s,
                                                 const Vec3& n_s, std::int32_t q) const {
  const MirrorPlanes::Plane& plane = h_.mirrors_.planes[q];
  // x must see the front of s's image: its own image in front of s.
  if (!(plane.height(x) > 0.0) || s.n < 3 || !((plane.image(x) - s.v[0]).dot(n_s) > 0.0))
    return 0.0;
  double f = 0.0;
  visible_pieces(
      plane, plane_outline_[q], x, n, s,
      [&](const hierarchy_detail::SmallPolygon& piece) { f += polygon_form_factor(x, n, piece); });
  return f;
}

void HierarchyBuilder::image_view(const ElementLink& l, std::int32_t from, std::int32_t to,
                                  const Vec3& x, ImageView* view) const {
  using hierarchy_detail::SmallPolygon;
  ImageView& w = *view;
  w.count = 0;
  w.total = 0.0;
  const Patch& pt = el_[to].shape;
  const MirrorPlanes::Plane& plane = h_.mirrors_.planes[l.mirror];
  const SmallPolygon s = front_of(pt, plane);
  if (!(plane.height(x) > 0.0) || s.n < 3) return;
  w.x = x;
  w.plane = &plane;
  w.image_normal = pt.normal - 2.0 * pt.normal.dot(plane.normal) * plane.normal;
  w.on = plane.image(s.v[0]);
  // The pieces of the outline where to's image shows from x (those image_point_form_factor
  // integrates over), each a fan of triangles.
  visible_pieces(plane, plane_outline_[l.mirror], x, el_[from].shape.normal, s,
                 [&](const SmallPolygon& b) {
                   for (int k = 1; k + 1 < b.n && w.count < 48; ++k) {
                     w.tri[w.count] = {b.v[0], b.v[k], b.v[k + 1]};
                     w.area[w.count] = 0.5 * (b.v[k] - b.v[0]).cross(b.v[k + 1] - b.v[0]).norm();
                     w.total += w.area[w.count++];
                   }
                 });
}

bool HierarchyBuilder::ImageView::draw(const Vec2& u, Vec3* y) const {
  if (!(total > 0.0)) return false;
  // A triangle drawn by area, a point uniform in it.
  double pick = u.x() * total;
  int t = 0;
  while (t + 1 < count && pick >= area[t]) pick -= area[t++];
  const double r1 = std::clamp(pick / area[t], 0.0, 1.0), r2 = u.y();
  const double su = std::sqrt(r1);
  const Vec3 p = (1.0 - su) * tri[t][0] + su * (1.0 - r2) * tri[t][1] + su * r2 * tri[t][2];
  // Along x -> p to the plane of to's image, and back through the mirror.
  const double den = (p - x).dot(image_normal);
  if (!(std::abs(den) > 0.0)) return false;
  *y = plane->image(x + ((on - x).dot(image_normal) / den) * (p - x));
  return true;
}

bool HierarchyBuilder::target_through(const ElementLink& l, std::int32_t from, std::int32_t to,
                                      const Vec3& x, const Vec2& u, Vec3* y) const {
  if (l.mirror < 0) {
    double density;
    *y = el_[to].shape.sample(u, &density);
    return true;
  }
  ImageView view;
  image_view(l, from, to, x, &view);
  return view.draw(u, y);
}

// The outer rule of the direct links (pair_outer_rule) on x toward y's image, graded where the
// two meet (an element beside the mirror and the image of one beside it), at each point the
// exact form factor to y's image through the mirror's outline; unless the oracle found the pair
// wholly visible, times the share of rays from the point to stratified points of y, among those
// through the mirror, that nothing hides (form_factors.visibility_rays of them where the oracle
// saw a shadow or between two roots, open_link_rays where it cast none below the roots, as the
// direct links). A partly buried x: the mean over its exposed points, times the exposed part of
// the region, as the direct links.
double HierarchyBuilder::image_pair_form_factor(std::int32_t x, std::int32_t y, std::int32_t q,
                                                LinkVisibility v, long long* rays) const {
  if (v == LinkVisibility::kHidden) return 0.0;
  const MirrorPlanes::Plane& plane = h_.mirrors_.planes[q];
  const Element &ex = el_[x], &ey = el_[y];
  thread_local std::vector<AreaPoint> rule;
  const Patch image = image_patch(ey.shape, plane);
  const bool whole = pair_outer_rule(ex.shape, image, o_.form_factors, rule);
  if (rule.empty()) return 0.0;
  const hierarchy_detail::SmallPolygon front = front_of(ey.shape, plane);
  const bool roots = ex.parent < 0 && ey.parent < 0;  // rays as the direct links' (below)
  const int m = v == LinkVisibility::kPartial || roots
                    ? std::max(1, o_.form_factors.visibility_rays)
                    : std::max(1, o_.open_link_rays);
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(m))));
  Rng rng(o_.seed, link_key(x, y, q));
  ElementLink l;
  l.mirror = q;
  const bool buried = !hierarchy_detail::wholly_exposed(ex);
  const PatchExposure exposure = exposure_of(x);
  ImageView view;
  double sum = 0.0, weight = 0.0, exposed_weight = 0.0;
  for (const AreaPoint& point : rule) {
    const Vec3& p = point.x;
    weight += point.w;
    if (buried && !exposure.exposed_at(ex.shape, p, caster_)) continue;
    exposed_weight += point.w;
    const double f = image_point_form_factor(p, ex.shape.normal, front, ey.shape.normal, q);
    if (!(f > 0.0)) continue;
    double visible = 1.0;
    if (v != LinkVisibility::kVisible) {
      image_view(l, x, y, p, &view);
      int seen = 0, cast = 0;
      for (int k = 0; k < m; ++k) {
        Vec3 t;
        const double u0 = rng.uniform32(), v0 = rng.uniform32();
        if (!view.draw(Vec2((k % side + u0) / side, (k / side % side + v0) / side), &t)) continue;
        const Path path = path_between(l, p, ex.shape, t, ey.shape, rays);
        if (path == Path::kOutside) continue;
        ++cast;
        if (path == Path::kOpen) ++seen;
      }
      visible = cast > 0 ? static_cast<double>(seen) / cast : 1.0;
    }
    sum += point.w * f * visible;
  }
  if (!buried) return sum;
  // As the direct links: the exposed part of the region the rule covers, not the points' count.
  return buried_pair_integral(sum, weight, exposed_weight, whole, exposure, ex.shape, image,
                              caster_);
}

void HierarchyBuilder::split_pair(const Candidate& c, std::int32_t split_end, LinkVisibility v,
                                  std::vector<Candidate>& out) const {
  const std::int32_t first = el_[split_end].first_child;
  if (c.a == c.b) {  // an element and its own image: each pair of its children once
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j) out.push_back({first + i, first + j, -1.0f, v, c.mirror});
    return;
  }
  for (int i = 0; i < 4; ++i) {
    if (split_end == c.a)
      out.push_back({first + i, c.b, -1.0f, v, c.mirror});
    else
      out.push_back({c.a, first + i, -1.0f, v, c.mirror});
  }
}

}  // namespace polyrad
