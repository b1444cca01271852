// Form factors (form_factors.h). Equation numbers refer to papers/glossy-radiosity.md.
#include "polyrad/transport/form_factors.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <span>
#include <stdexcept>

#include "polyrad/scene/brdf.h"
#include "polyrad/util/error.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace {

struct QuadraturePoint {
  Vec3 x;
  double w;  // area weight; the weights of a polygon sum to its area
};

// A convex polygon on the stack. The pair loop below runs for every facing pair of patches, and
// heap-allocated corner lists there cost about as much as the geometry they hold. Patches have
// at most 4 corners, one clip adds at most one, and the pieces of the outer rule have 3 or 4.
struct Polygon {
  static constexpr int kCapacity = 8;
  std::array<Vec3, kCapacity> v;
  int n = 0;

  Polygon() = default;
  Polygon(std::initializer_list<Vec3> corners) {
    for (const Vec3& c : corners) push_back(c);
  }
  explicit Polygon(const Patch& p) {
    for (int c = 0; c < p.corners; ++c) push_back(p.corner[c]);
  }
  std::size_t size() const { return static_cast<std::size_t>(n); }
  const Vec3& operator[](std::size_t k) const { return v[k]; }
  void push_back(const Vec3& x) { v[n++] = x; }
};

// Sutherland-Hodgman against one plane, for a vector or a Polygon; the result has at most one
// corner more than the input.
template <typename Poly>
void clip_into(const Poly& polygon, const Vec3& origin, const Vec3& normal, Poly& out) {
  size_t n = polygon.size();
  for (size_t k = 0; k < n; ++k) {
    const Vec3& p = polygon[k];
    const Vec3& q = polygon[(k + 1) % n];
    double dp = (p - origin).dot(normal), dq = (q - origin).dot(normal);
    if (dp >= 0.0) out.push_back(p);
    if ((dp >= 0.0) != (dq >= 0.0)) out.push_back(p + (dp / (dp - dq)) * (q - p));
  }
}

// atan2(y, x) for y >= 0, an angle in [0, pi], on four lanes at once, within 2 ulp of
// std::atan2 (checked on 2e7 random pairs over 12 decades). The contour integral takes one per
// edge at every outer point; libm's atan2 was the costliest function of the form factors after
// Embree's (9 percent of their time on the Cornell box). Range reduction to |t| <= tan(pi/8) by
// the tangent addition formula, then the rational approximation of atan(t) of S. L. Moshier's
// Cephes library, with pi/2 and pi/4 carried in two parts. The reduction is chosen by selects,
// not branches, so the lanes of Eigen's packets run in step and nothing is mispredicted.
using Lanes = Eigen::Array4d;
inline Lanes edge_angles(const Lanes& y, const Lanes& x) {
  constexpr double kPio2 = 1.57079632679489661923, kPio4 = 0.78539816339744830962;
  constexpr double kPio2Low = 6.123233995736765886130e-17;  // pi/2 - kPio2
  constexpr double kTan3Pio8 = 2.41421356237309504880;
  const Lanes ax = x.abs();
  const auto steep = y > kTan3Pio8 * ax;          // atan(y/ax) = pi/2 - atan(ax/y)
  const auto middle = !steep && (y > 0.66 * ax);  // = pi/4 + atan((y - ax)/(y + ax))
  const Lanes num = steep.select(-ax, middle.select(y - ax, y));
  const Lanes den = steep.select(y, middle.select(y + ax, ax.max(1e-300)));
  const Lanes base =
      steep.select(Lanes::Constant(kPio2), middle.select(Lanes::Constant(kPio4), Lanes::Zero()));
  const Lanes base_low = steep.select(
      Lanes::Constant(kPio2Low), middle.select(Lanes::Constant(0.5 * kPio2Low), Lanes::Zero()));
  const Lanes t = num / den;
  const Lanes z = t * t;
  const Lanes p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z -
                    7.500855792314704667340e1) *
                       z -
                   1.228866684490136173410e2) *
                      z -
                  6.485021904942025371773e1;
  const Lanes q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
                    4.328810604912902668951e2) *
                       z +
                   4.853903996359136964868e2) *
                      z +
                  1.945506571482613964425e2;
  const Lanes a = base + ((t * (z * p / q) + t) + base_low);
  return (x < 0.0).select((2.0 * kPio2 - a) + 2.0 * kPio2Low, a);  // pi - atan(y/|x|)
}

// A polygon's edges laid out for Lambert's contour formula: the start and end corners of four
// edges per group, one edge per lane (structure of arrays), so that every step of the formula
// is a packet operation. Built once per pair, read at every outer point. Unused lanes repeat
// the first corner as both ends: a zero cross product, masked in contour_form_factor.
struct ContourEdges {
  static constexpr int kGroups = 2;  // up to 8 edges: a clipped quad has at most 5
  std::array<Lanes, kGroups> x0, y0, z0, x1, y1, z1;
  int groups = 0;

  template <typename Poly>
  explicit ContourEdges(const Poly& polygon) {
    const int m = static_cast<int>(polygon.size());
    groups = (m + 3) / 4;
    for (int g = 0; g < groups; ++g)
      for (int l = 0; l < 4; ++l) {
        const int k = 4 * g + l;
        const Vec3& p = polygon[k < m ? k : 0];
        const Vec3& q = polygon[k < m ? (k + 1) % m : 0];
        x0[g][l] = p.x(), y0[g][l] = p.y(), z0[g][l] = p.z();
        x1[g][l] = q.x(), y1[g][l] = q.y(), z1[g][l] = q.z();
      }
  }
};

// Lambert's contour formula (point_to_polygon_form_factor).
inline double contour_form_factor(const Vec3& x, const Vec3& n, const ContourEdges& edges) {
  // F = 1/(2 pi) sum_edges gamma_e (n . unit(r_k x r_k+1)), gamma_e the angle the edge
  // subtends at x (eq. 5). The sign of the sum follows the winding; the magnitude is F.
  double sum = 0.0;
  for (int g = 0; g < edges.groups; ++g) {
    const Lanes ax = edges.x0[g] - x.x(), ay = edges.y0[g] - x.y(), az = edges.z0[g] - x.z();
    const Lanes bx = edges.x1[g] - x.x(), by = edges.y1[g] - x.y(), bz = edges.z1[g] - x.z();
    const Lanes cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    const Lanes cn = (cx * cx + cy * cy + cz * cz).sqrt();
    const Lanes gamma = edge_angles(cn, ax * bx + ay * by + az * bz);
    // Lanes with cn = 0 (unused, or x on the edge's line) add nothing; dividing them by 1
    // keeps them finite.
    const auto some = cn > 0.0;
    const Lanes term = gamma * (n.x() * cx + n.y() * cy + n.z() * cz) / some.select(cn, 1.0);
    sum += some.select(term, Lanes::Zero()).sum();
  }
  return std::abs(sum) * (0.5 / kPi);
}

// Gauss rule on a convex polygon. An unclipped quad uses its bilinear map, anything else a fan
// of triangles with the Duffy map (s, t) -> a + s (b - a) + s t (c - b), Jacobian 2 A s.
void gauss_rule(const Polygon& poly, bool bilinear_quad, int n, std::vector<QuadraturePoint>& out) {
  const GaussRule& g = gauss_legendre(n);
  if (bilinear_quad) {
    const Vec3 &v0 = poly[0], &v1 = poly[1], &v2 = poly[2], &v3 = poly[3];
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        double s = g.node[a], t = g.node[b];
        Vec3 x = (1 - s) * (1 - t) * v0 + s * (1 - t) * v1 + s * t * v2 + (1 - s) * t * v3;
        Vec3 ds = (1 - t) * (v1 - v0) + t * (v2 - v3);
        Vec3 dt = (1 - s) * (v3 - v0) + s * (v2 - v1);
        out.push_back({x, g.weight[a] * g.weight[b] * ds.cross(dt).norm()});
      }
    return;
  }
  for (size_t k = 1; k + 1 < poly.size(); ++k) {
    const Vec3 &a = poly[0], &b = poly[k], &c = poly[k + 1];
    double twice_area = (b - a).cross(c - b).norm();
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        double s = g.node[i], t = g.node[j];
        out.push_back(
            {a + s * (b - a) + s * t * (c - b), g.weight[i] * g.weight[j] * twice_area * s});
      }
  }
}

double polygon_diameter(const Polygon& poly) {
  double d = 0.0;
  for (size_t a = 0; a < poly.size(); ++a)
    for (size_t b = a + 1; b < poly.size(); ++b) d = std::max(d, (poly[a] - poly[b]).norm());
  return d;
}

// Distance from x to a planar convex polygon (to its plane if x projects inside, else to the
// nearest edge).
double distance_to_polygon(const Vec3& x, const Polygon& poly) {
  Vec3 n = Vec3::Zero();
  for (size_t k = 0; k < poly.size(); ++k) n += poly[k].cross(poly[(k + 1) % poly.size()]);
  n.normalize();
  bool inside = true;
  double best = 1e300;
  for (size_t k = 0; k < poly.size(); ++k) {
    const Vec3& p = poly[k];
    const Vec3& q = poly[(k + 1) % poly.size()];
    if ((q - p).cross(x - p).dot(n) < 0.0) inside = false;
    Vec3 e = q - p;
    double t = std::clamp((x - p).dot(e) / e.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (x - (p + t * e)).norm());
  }
  return inside ? std::abs((x - poly[0]).dot(n)) : best;
}

// Whether a piece of the outer patch is closer to the other patch than its own size.
bool near_enough_to_split(const Polygon& poly, const Polygon& other) {
  Vec3 centre = Vec3::Zero();
  for (size_t k = 0; k < poly.size(); ++k) centre += poly[k] / static_cast<double>(poly.size());
  return distance_to_polygon(centre, other) < polygon_diameter(poly);
}

// The outer rule, refined geometrically toward the other patch: a piece near enough to it is
// split in four (up to `depth` times), so the log-singular integrand of patches that share an
// edge is integrated on a grading toward that edge.
void outer_rule(const Polygon& poly, bool bilinear_quad, const Polygon& other, int n, int depth,
                std::vector<QuadraturePoint>& out) {
  if (depth == 0 || !near_enough_to_split(poly, other)) {
    gauss_rule(poly, bilinear_quad, n, out);
    return;
  }
  if (bilinear_quad) {
    auto at = [&](double s, double t) -> Vec3 {
      return (1 - s) * (1 - t) * poly[0] + s * (1 - t) * poly[1] + s * t * poly[2] +
             (1 - s) * t * poly[3];
    };
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b) {
        double s0 = 0.5 * a, s1 = 0.5 * (a + 1), t0 = 0.5 * b, t1 = 0.5 * (b + 1);
        outer_rule({at(s0, t0), at(s1, t0), at(s1, t1), at(s0, t1)}, true, other, n, depth - 1,
                   out);
      }
    return;
  }
  for (size_t k = 1; k + 1 < poly.size(); ++k) {
    const Vec3 &a = poly[0], &b = poly[k], &c = poly[k + 1];
    Vec3 ab = 0.5 * (a + b), bc = 0.5 * (b + c), ca = 0.5 * (c + a);
    outer_rule({a, ab, ca}, false, other, n, depth - 1, out);
    outer_rule({ab, b, bc}, false, other, n, depth - 1, out);
    outer_rule({ca, bc, c}, false, other, n, depth - 1, out);
    outer_rule({ab, bc, ca}, false, other, n, depth - 1, out);
  }
}

// The Gauss rules of whole quad patches at the point counts pairs use. A whole quad's rule is
// the outer rule of most pairs and the same for every partner, so it is made once per patch
// here instead of once per pair (it was 3 percent of the form factors' time).
class WholeQuadRules {
 public:
  WholeQuadRules(const PatchSet& patches, const FormFactorOptions& o) {
    for (int n : {o.near_points, o.mid_points, o.far_points}) {
      POLYRAD_CHECK(n >= 1 && n < static_cast<int>(rules_.size()));  // gauss_legendre's range
      if (!rules_[n].empty()) continue;
      rules_[n].resize(patches.size() * static_cast<std::size_t>(n * n));
      std::vector<QuadraturePoint> rule;
      for (std::size_t p = 0; p < patches.size(); ++p) {
        if (patches[p].is_triangle()) continue;
        rule.clear();
        gauss_rule(Polygon(patches[p]), true, n, rule);
        std::copy(rule.begin(), rule.end(),
                  rules_[n].begin() + static_cast<std::ptrdiff_t>(p * n * n));
      }
    }
  }
  // The n x n rule of quad patch p (n one of the options' counts).
  std::span<const QuadraturePoint> get(PatchId p, int n) const {
    return {rules_[n].data() + static_cast<std::size_t>(p) * n * n,
            static_cast<std::size_t>(n * n)};
  }

 private:
  std::array<std::vector<QuadraturePoint>, 17> rules_;  // by n; gauss_legendre's n <= 16
};

// Area-uniform stratified points on a convex polygon (fan triangles chosen by area).
class PolygonSampler {
 public:
  explicit PolygonSampler(const Polygon& poly) : poly_(poly) {
    double total = 0.0;
    for (size_t k = 1; k + 1 < poly.size(); ++k) {
      total += 0.5 * (poly[k] - poly[0]).cross(poly[k + 1] - poly[0]).norm();
      cumulative_[count_++] = total;
    }
    for (int k = 0; k < count_; ++k) cumulative_[k] /= total;
    // The reciprocal of each triangle's share: sample() multiplies (no division per ray).
    for (int k = 0; k < count_; ++k) {
      const double share = cumulative_[k] - (k == 0 ? 0.0 : cumulative_[k - 1]);
      inverse_share_[k] = share > 0.0 ? 1.0 / share : 0.0;  // an empty triangle: its first corner
    }
  }
  // u0 selects the triangle (and is reused inside it), u1 is the second coordinate.
  Vec3 sample(double u0, double u1) const {
    size_t k = 0;
    while (k + 1 < static_cast<size_t>(count_) && u0 > cumulative_[k]) ++k;
    double lo = k == 0 ? 0.0 : cumulative_[k - 1];
    double r = std::clamp((u0 - lo) * inverse_share_[k], 0.0, 1.0);
    double sr = std::sqrt(r);
    const Vec3 &a = poly_[0], &b = poly_[k + 1], &c = poly_[k + 2];
    return (1 - sr) * a + sr * (1 - u1) * b + sr * u1 * c;
  }

 private:
  const Polygon& poly_;
  std::array<double, Polygon::kCapacity> cumulative_{}, inverse_share_{};
  int count_ = 0;
};

bool any_corner_in_front(const Patch& p, const Patch& plane, double eps) {
  for (int c = 0; c < p.corners; ++c)
    if ((p.corner[c] - plane.centroid).dot(plane.normal) > eps) return true;
  return false;
}

int points_for(const Patch& a, const Patch& b, double larger_diameter, const FormFactorOptions& o) {
  double ratio = (a.centroid - b.centroid).norm() / larger_diameter;
  if (ratio < o.near_ratio) return o.near_points;
  if (ratio < o.far_ratio) return o.mid_points;
  return o.far_points;
}

constexpr std::size_t kFan = RayCaster::SegmentPacket::kSize;

// The kernel-weighted fraction of unblocked rays from each exposed outer point to b (exact when
// b is wholly visible or hidden), for the rule's points first .. first + points.size() (at most
// kFan). Each point draws options.visibility_rays points of b from its own stream, keyed by the
// pair and its index in the rule; every ray leaves a's front. Drawn before any is cast (drawing a
// point is a chain of dependent divisions and square roots, and the chains overlap where one
// after each ray would wait for the one before: 7 percent of the whole), then cast kFan at a time.
void visible_fractions(const Patch& a, const Patch& b, const PolygonSampler& target,
                       const RayCaster& caster, const FormFactorOptions& options, std::uint64_t key,
                       std::size_t first, std::span<const QuadraturePoint> points,
                       const std::array<bool, kFan>& exposed, std::array<double, kFan>& visible,
                       long long& rays_cast) {
  struct FanRay {
    std::size_t point;
    double k, r2;
    Vec3 y;
  };
  thread_local std::vector<FanRay> fan;  // one per thread, reused across pairs
  fan.clear();
  const int m = options.visibility_rays;
  std::array<double, kFan> kernel_sum{}, kernel_visible{};
  std::array<Vec3, kFan> x_lifted;
  for (std::size_t g = 0; g < points.size(); ++g) {
    if (!exposed[g]) continue;
    const Vec3& x = points[g].x;
    x_lifted[g] = caster.lifted_front(x, a);
    Rng rng(options.seed, key, first + g);
    for (int s = 0; s < m; ++s) {
      // Second coordinate drawn first (see specular_transfer.cpp: the order GCC used).
      const double v = rng.uniform32(), u = rng.uniform32();
      const Vec3 y = target.sample((s + u) / m, v);
      const Vec3 d = y - x;
      const double r2 = d.squaredNorm();
      if (!(r2 > 0.0)) continue;  // also a NaN from a degenerate clipped polygon
      const double k = std::max(0.0, d.dot(a.normal)) * std::max(0.0, -d.dot(b.normal)) / (r2 * r2);
      kernel_sum[g] += k;
      if (!(k <= 0.0)) fan.push_back({g, k, r2, y});  // as cast before (a NaN k too)
    }
  }
  RayCaster::SegmentPacket packet;
  for (std::size_t f0 = 0; f0 < fan.size(); f0 += kFan) {
    const std::size_t count = std::min(kFan, fan.size() - f0);
    packet.clear();
    for (std::size_t f = f0; f < f0 + count; ++f)
      caster.add_facing_segment(packet, x_lifted[fan[f].point], a, fan[f].y, b, fan[f].r2);
    caster.cast(packet);
    for (std::size_t f = 0; f < count; ++f)
      if (!packet.blocked[f]) kernel_visible[fan[f0 + f].point] += fan[f0 + f].k;
  }
  rays_cast += static_cast<long long>(fan.size());
  for (std::size_t g = 0; g < points.size(); ++g)
    if (exposed[g]) visible[g] = kernel_sum[g] > 0.0 ? kernel_visible[g] / kernel_sum[g] : 1.0;
}

// The outer rule's setting for a pair that passed the facing test: a's part in front of b's
// plane and b's in front of a's, whether a's is all of a, and the rule's points a side and its
// grading depth (points_for). False where either part is empty.
struct PairRegions {
  Polygon a_front, b_front;
  bool a_whole = false;
  int n = 0, depth = 0;
};

bool pair_regions(const Patch& a, const Patch& b, double larger_diameter,
                  const FormFactorOptions& options, PairRegions& r) {
  clip_into(Polygon(a), b.centroid, b.normal, r.a_front);
  clip_into(Polygon(b), a.centroid, a.normal, r.b_front);
  if (r.a_front.size() < 3 || r.b_front.size() < 3) return false;
  // All four corners: a quad cut off at one corner by b's plane (within rounding of it) keeps
  // four corners, and its cached rule would cover the part behind the plane.
  r.a_whole = static_cast<int>(r.a_front.size()) == a.corners;
  for (int c = 0; r.a_whole && c < a.corners; ++c) r.a_whole = r.a_front[c] == a.corner[c];
  r.n = points_for(a, b, larger_diameter, options);
  r.depth = r.n == options.near_points ? options.near_depth : 0;
  return true;
}

// pair_area_form_factor for a pair that passed the facing test, with the larger of the two
// diameters given and the quadrature points' buffer supplied by the caller (one per thread).
// With `whole` (and a's id), a whole quad a that needs no refinement takes its rule from there.
double facing_pair_form_factor(const Patch& a, const Patch& b, double larger_diameter,
                               const RayCaster* caster, const FormFactorOptions& options,
                               std::uint64_t key, long long& rays_cast,
                               const PatchExposure& a_exposure,
                               std::vector<QuadraturePoint>& buffer,
                               const WholeQuadRules* whole = nullptr, PatchId a_id = -1) {
  PairRegions regions;
  if (!pair_regions(a, b, larger_diameter, options, regions)) return 0.0;
  const Polygon &a_front = regions.a_front, &b_front = regions.b_front;
  const bool a_whole = regions.a_whole, a_whole_quad = a_whole && !a.is_triangle();
  const int n = regions.n, depth = regions.depth;
  std::span<const QuadraturePoint> points;
  if (whole && a_whole_quad && (depth == 0 || !near_enough_to_split(a_front, b_front))) {
    points = whole->get(a_id, n);
  } else {
    buffer.clear();
    outer_rule(a_front, a_whole_quad, b_front, n, depth, buffer);
    points = buffer;
  }
  PolygonSampler target(b_front);
  const ContourEdges b_edges(b_front);

  // Visibility first, a group of outer points at a time: the unoccluded factor (eq. 5) is not
  // needed where every ray is blocked, and the group's rays, a fan from a to b, are cast in
  // packets (RayCaster::SegmentPacket).
  const bool partly_buried = caster && !a_exposure.wholly();
  // As many points as fill one packet, one alone when its rays fill more.
  const auto m = static_cast<std::size_t>(std::max(0, options.visibility_rays));
  const std::size_t group = caster && m > 0 ? std::max<std::size_t>(1, kFan / m) : kFan;
  std::array<bool, kFan> exposed;
  std::array<double, kFan> visible;
  double total = 0.0, weight = 0.0, exposed_weight = 0.0;
  for (std::size_t q0 = 0; q0 < points.size(); q0 += group) {
    const std::size_t n_group = std::min(group, points.size() - q0);
    for (std::size_t g = 0; g < n_group; ++g) {
      const QuadraturePoint& p = points[q0 + g];
      exposed[g] = !partly_buried || a_exposure.exposed_at(a, p.x, *caster);
      visible[g] = 1.0;
    }
    if (caster)
      visible_fractions(a, b, target, *caster, options, key, q0, points.subspan(q0, n_group),
                        exposed, visible, rays_cast);
    for (std::size_t g = 0; g < n_group; ++g) {
      const QuadraturePoint& p = points[q0 + g];
      weight += p.w;
      if (!exposed[g]) continue;
      exposed_weight += p.w;
      if (visible[g] <= 0.0) continue;
      total += p.w * contour_form_factor(p.x, a.normal, b_edges) * visible[g];
    }
  }
  return partly_buried ? buried_pair_integral(total, weight, exposed_weight, a_whole, a_exposure, a,
                                              b, *caster)
                       : total;
}

}  // namespace

std::vector<Vec3> clip_to_front(const std::vector<Vec3>& polygon, const Vec3& origin,
                                const Vec3& normal) {
  std::vector<Vec3> out;
  clip_into(polygon, origin, normal, out);
  return out;
}

double point_to_polygon_form_factor(const Vec3& x, const Vec3& n, const std::vector<Vec3>& polygon) {
  return point_to_polygon_form_factor(x, n, std::span<const Vec3>(polygon));
}

double point_to_polygon_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> polygon) {
  if (polygon.size() > 4 * ContourEdges::kGroups)
    throw std::invalid_argument("point_to_polygon_form_factor: more than 8 corners");
  return contour_form_factor(x, n, ContourEdges(polygon));
}

double pair_area_form_factor(const Patch& a, const Patch& b, const RayCaster* caster,
                             const FormFactorOptions& options, std::uint64_t key,
                             long long* rays_cast, const PatchExposure& a_exposure) {
  const double larger_diameter = std::max(a.diameter(), b.diameter());
  double eps = 1e-9 * larger_diameter;
  if (!any_corner_in_front(b, a, eps) || !any_corner_in_front(a, b, eps)) return 0.0;
  // One buffer per thread, reused: callers loop over many pairs (the hierarchy's links).
  thread_local std::vector<QuadraturePoint> points;
  long long rays = 0;
  double g =
      facing_pair_form_factor(a, b, larger_diameter, caster, options, key, rays, a_exposure, points);
  if (rays_cast) *rays_cast += rays;
  return g;
}

bool pair_outer_rule(const Patch& a, const Patch& b, const FormFactorOptions& options,
                     std::vector<AreaPoint>& out) {
  out.clear();
  const double larger_diameter = std::max(a.diameter(), b.diameter());
  const double eps = 1e-9 * larger_diameter;
  if (!any_corner_in_front(b, a, eps) || !any_corner_in_front(a, b, eps)) return false;
  PairRegions r;
  if (!pair_regions(a, b, larger_diameter, options, r)) return false;
  thread_local std::vector<QuadraturePoint> points;
  points.clear();
  outer_rule(r.a_front, r.a_whole && !a.is_triangle(), r.b_front, r.n, r.depth, points);
  for (const QuadraturePoint& p : points) out.push_back({p.x, p.w});
  return r.a_whole;
}

// A partly buried a: its mean over exposed points, times its exposed part of the region. The
// region is a_front: where b's plane cuts a, its exposed fraction is not a's. A face standing on
// a partly buried floor patch cuts off exactly the buried part, so the region is wholly exposed;
// scaling by a's fraction there lost two thirds of the pair (row sums of 0.69 seen beside
// furniture in scenes/room).
double buried_pair_integral(double total, double weight, double exposed_weight, bool a_whole,
                            const PatchExposure& a_exposure, const Patch& a, const Patch& b,
                            const RayCaster& caster) {
  if (exposed_weight <= 0.0) return 0.0;
  const double region_exposed =
      a_whole ? a_exposure.fraction : a_exposure.fraction_in_front(a, b.centroid, b.normal, caster);
  return total * weight * region_exposed / exposed_weight;
}

double FormFactors::row_sum(PatchId i) const {
  double s = 0.0;
  for (auto [j, f_ij] : f.row(i)) s += f_ij;
  return s;
}

FormFactors compute_form_factors(const PatchSet& patches, const RayCaster& caster,
                                 const FormFactorOptions& options) {
  const Stopwatch watch;
  const auto n = static_cast<PatchId>(patches.size());
  const ExposureMap exposure(patches, caster, options.exposure_points, options.exposure_refined);
  std::vector<double> exposed = exposure.areas();
  // upper[i]: (j, A_i F_ij) for j > i. Filled by whichever thread owns row i.
  std::vector<std::vector<std::pair<PatchId, double>>> upper(n);
  long long facing = 0, rays = 0;
  std::vector<double> diameter(n);
  for (PatchId i = 0; i < n; ++i) diameter[i] = patches[i].diameter();
  const WholeQuadRules whole(patches, options);
  Progress progress("form factors", n);

#pragma omp parallel
  {
    std::vector<QuadraturePoint> points;  // this thread's buffer, reused for every pair
#pragma omp for schedule(dynamic, 4) reduction(+ : facing, rays)
    for (PatchId i = 0; i < n; ++i) {
      const Patch& pi = patches[i];
      for (PatchId j = i + 1; j < n; ++j) {
        const Patch& pj = patches[j];
        // Integrate over the smaller patch; G = A_a F_ab is the same number either way.
        bool i_outer = pi.area <= pj.area;
        const Patch& a = i_outer ? pi : pj;
        const Patch& b = i_outer ? pj : pi;
        const double larger_diameter = std::max(diameter[i], diameter[j]);
        double eps = 1e-9 * larger_diameter;
        if (!any_corner_in_front(b, a, eps) || !any_corner_in_front(a, b, eps)) continue;
        ++facing;
        std::uint64_t key = static_cast<std::uint64_t>(i) * static_cast<std::uint64_t>(n) + j;
        PatchId a_id = i_outer ? i : j;
        double g = exposed[a_id] <= 0.0
                       ? 0.0
                       : facing_pair_form_factor(a, b, larger_diameter, &caster, options, key, rays,
                                                 exposure[a_id], points, &whole, a_id);
        if (g > 0.0 && exposed[i] > 0.0 && exposed[j] > 0.0) upper[i].emplace_back(j, g);
      }
      progress.advance();
    }
  }
  progress.finish();

  FormFactors ff;
  std::vector<std::int64_t> degree(n + 1, 0);
  for (PatchId i = 0; i < n; ++i)
    for (const auto& [j, g] : upper[i]) {
      ++degree[i];
      ++degree[j];
    }
  ff.f.rows = ff.f.cols = n;
  ff.f.start.assign(n + 1, 0);
  for (PatchId i = 0; i < n; ++i) ff.f.start[i + 1] = ff.f.start[i] + degree[i];
  ff.f.column.resize(ff.f.start[n]);
  ff.f.value.resize(ff.f.start[n]);
  std::vector<std::int64_t> fill(ff.f.start.begin(), ff.f.start.end() - 1);
  // Row r receives (r, i) for i < r while i ascends, then its own (r, j > r): columns sorted.
  for (PatchId i = 0; i < n; ++i)
    for (const auto& [j, g] : upper[i]) {
      ff.f.column[fill[i]] = j;
      ff.f.value[fill[i]++] = static_cast<float>(g / exposed[i]);
      ff.f.column[fill[j]] = i;
      ff.f.value[fill[j]++] = static_cast<float>(g / exposed[j]);
    }
  // A patch that exchanges light with nothing has no exposed area either: this covers a face
  // pressed flat against another (a block's bottom on the floor), whose probe rays start beyond
  // the contact plane and so cannot tell it is buried.
  for (PatchId i = 0; i < n; ++i)
    if (ff.f.start[i + 1] == ff.f.start[i]) exposed[i] = 0.0;
  ff.area = std::move(exposed);
  ff.stats.pairs_facing = facing;
  ff.stats.rays = rays;
  ff.stats.pairs_visible = static_cast<long long>(ff.f.nnz() / 2);
  ff.stats.seconds = watch.seconds();
  return ff;
}

}  // namespace polyrad
