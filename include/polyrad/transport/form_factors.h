// Form factors between patches, with visibility, by Embree rays.
//
//   F_ij = 1/(pi A_i) int_{P_i} int_{P_j} cos(theta_x) cos(theta_y) / r^2 V(x, y) dA_y dA_x
//                                                       (papers/glossy-radiosity.md, eq. 4)
// Method, per unordered pair: the inner integral over the receiving patch is the exact
// point-to-polygon form factor (Lambert's contour formula) after clipping both patches to each
// other's front half-space; the outer integral is a Gauss-Legendre rule on the smaller patch,
// refined geometrically toward the other patch for near pairs; visibility multiplies each outer
// point by the kernel-weighted fraction of unblocked shadow rays to stratified points of the other
// patch. This is exact for unoccluded pairs up to the outer rule's error, including pairs that
// share an edge (where the point-to-point integrand is singular but the contour formula is not).
// One value G_ij = A_i F_ij is computed per pair, so reciprocity holds to rounding.
//
// Exposure: the part of a patch buried inside other geometry is left out, F_ij = G_ij / A'_i
// with A'_i the exposed area (exposure.h). For a partly buried patch the pair integral is
// normalised by the exposed weight of its own quadrature points, read from the patch's exposure
// grid, so that both sides of F_ij = G_ij / A'_i see the boundary at the same resolution.
//
// Deterministic for any thread count: shadow-ray points come from (seed, pair, point) keys.
//
//   FormFactors ff = compute_form_factors(patches, caster, {});
//   double f = ff.at(i, j);
//
// Cost: O(P^2) pair tests, and rays ~ (outer points x visibility rays) per facing pair.
// Memory: 8 bytes per non-zero F_ij (both directions are stored).
#pragma once

#include <span>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/transport/exposure.h"
#include "polyrad/util/sparse.h"

namespace polyrad {

struct FormFactorOptions {
  int near_points = 3;        // Gauss points per side on the outer patch, near pairs ...
  int near_depth = 3;         // ... on pieces split up to this many times toward the other patch
  int mid_points = 3;         // pairs at a moderate distance
  int far_points = 2;         // distant pairs
  double near_ratio = 1.5;    // centre distance / larger diameter below which a pair is near
  double far_ratio = 4.0;     // ... above which it is distant
  int visibility_rays = 4;    // shadow rays per outer point
  int exposure_points = 4;    // points per side tested for being buried ...
  int exposure_refined = 32;  // ... and where the patch is partly buried
  std::uint64_t seed = 1;
};

struct FormFactorStats {
  double seconds = 0.0;
  long long rays = 0;
  long long pairs_facing = 0;   // pairs that pass the plane test
  long long pairs_visible = 0;  // pairs with F > 0
};

struct FormFactors {
  Csr<float> f;  // row i: the j with F_ij > 0
  // A'_i: the exposed area of each patch, by which row i is normalised (0 for a patch that
  // sees nothing). pi A'_i F_ij is the etendue tau_ij, symmetric in i and j.
  std::vector<double> area;
  FormFactorStats stats;

  double at(PatchId i, PatchId j) const { return f.at(i, j); }
  double row_sum(PatchId i) const;
  std::size_t bytes() const { return f.bytes(); }
};

FormFactors compute_form_factors(const PatchSet& patches, const RayCaster& caster,
                                 const FormFactorOptions& options = {});

// A_a F_ab for one pair, integrated over a (with visibility if caster is non-null): the
// building block, exposed for tests. key seeds the shadow-ray points; rays_cast, if given, is
// increased by the number of shadow rays.
// a_exposure: a's exposure (a bare fraction A'_a / A_a converts to one); below 1 the quadrature
// points are tested for being buried (on a's grid if it has one, else by probes) and the result
// is A'_a times the mean over a's exposed points.
double pair_area_form_factor(const Patch& a, const Patch& b, const RayCaster* caster,
                             const FormFactorOptions& options, std::uint64_t key,
                             long long* rays_cast = nullptr,
                             const PatchExposure& a_exposure = PatchExposure());

// One point of an outer rule: where, and its share of the area.
struct AreaPoint {
  Vec3 x;
  double w;
};
// The points pair_area_form_factor integrates a over with b its partner: on a's part in front of
// b's plane (weights summing to that part's area), pieces of near pairs split toward b where
// they are nearer than their own size, for the log-singular integrand where two patches meet.
// Empty where the two do not face. (For a pair seen in a mirror, b is the partner's image.)
// Returns whether that part is all of a (buried_pair_integral's a_whole).
bool pair_outer_rule(const Patch& a, const Patch& b, const FormFactorOptions& options,
                     std::vector<AreaPoint>& out);
// A partly buried a's integral over such a rule toward b: the mean over its exposed points (total
// the sum of w f over them, exposed_weight their weight, weight every point's) times a's exposed
// area in the region the rule covers (all of a when a_whole, else a's part in front of b's plane,
// whose exposed fraction is not a's).
double buried_pair_integral(double total, double weight, double exposed_weight, bool a_whole,
                            const PatchExposure& a_exposure, const Patch& a, const Patch& b,
                            const RayCaster& caster);

// The exact form factor from a point x with normal n to a polygon that lies entirely in front
// of x's tangent plane and faces x (Lambert's formula). At most 8 corners (std::invalid_argument
// beyond: the formula runs on two packets of four edges).
double point_to_polygon_form_factor(const Vec3& x, const Vec3& n, const std::vector<Vec3>& polygon);
// The same on corners held anywhere (no allocation: for loops over many points and polygons).
double point_to_polygon_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> polygon);

// The part of a convex polygon on the positive side of the plane through `origin` with normal
// `normal` (Sutherland-Hodgman against one plane).
std::vector<Vec3> clip_to_front(const std::vector<Vec3>& polygon, const Vec3& origin,
                                const Vec3& normal);

}  // namespace polyrad
