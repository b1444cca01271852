// The specular transfer R_jik: which fraction of the flux that arrives at a non-diffuse patch i
// from patch j its lobe sends on to patch k. Sparse: a lobe reaches few patches.
//
// Estimator (papers/glossy-radiosity.md, eq. 8): for each facing pair (j -> i), S stratified
// point pairs (y on P_j, x on P_i), each weighted by w = G(x, y) V(x, y); at x the lobe's own
// sampler picks the outgoing direction with weight beta = lobe * cos / pdf, and the ray credits
// the patch k it meets:
//     R_jik = sum(w * beta * [ray hits k]) / sum(w)
// beta is 1 for the mirror and at most 1 for GGX, so sum_k R_jik <= 1 (the lobe colour, at most
// the albedo bound, multiplies later); a Phong sample's beta reaches (n + 2) / (n + 1), which
// the balancing below caps.
//
// Reciprocity balancing (eq. 9): for one reflector i, the flux matrix M_jk = tau_ij R_jik is
// symmetric for a reciprocal BRDF. Every source's rays are a multinomial sample (to each k, or
// lost); the symmetric M of highest likelihood given all of them keeps each row within its
// etendue (energy conservation) and, in a closed scene, makes every row and hence every column
// carry what its own samples saw, so each link radiance S_{i->k} is exact in a uniform field
// instead of carrying the noise of the few rays that reached k. The likelihood's dual is
// solved by coordinate ascent, and by Newton's method where that is slow. The seed's
// centre-point evaluation of rho is available as an option to compare.
//
//   SpecularTransfer st = compute_specular_transfer(patches, materials, ff, caster, {});
//   for (auto e = st.start[i]; e < st.start[i + 1]; ++e) use(st.from[e], st.to[e], st.fraction[e]);
//
// Cost: S shadow rays + S lobe rays per facing pair into a non-diffuse patch, plus the balancing
// (up to 30 sweeps over each reflector's entries, then a few Newton steps of conjugate gradients
// over them); memory 12 bytes per stored R_jik.
#pragma once

#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/transport/form_factors.h"

namespace polyrad {

enum class SpecularEstimator {
  kMonteCarlo,   // eq. 8: point pairs and lobe sampling (the default)
  kCentrePoint,  // the seed's rho evaluated at patch centres (compared, never the default)
};
template <>
struct EnumNames<SpecularEstimator> {
  static constexpr const char* kind = "specular estimator";
  static constexpr std::array<std::pair<SpecularEstimator, const char*>, 2> table{
      {{SpecularEstimator::kMonteCarlo, "monte-carlo"},
       {SpecularEstimator::kCentrePoint, "centre-point"}}};
};

struct SpecularOptions {
  int samples = 16;     // point pairs per link pair (j -> i)
  bool balance = true;  // reciprocity balancing (eq. 9); off only to compare
  SpecularEstimator estimator = SpecularEstimator::kMonteCarlo;
  std::uint64_t seed = 7;
};

struct SpecularStats {
  double seconds = 0.0;
  long long rays = 0;
  long long pairs = 0;            // link pairs (j -> i) into non-diffuse patches
  long long pairs_unseen = 0;     // pairs with F_ij > 0 whose samples were all blocked
  double escaped_fraction = 0.0;  // weight-average share of lobe rays that hit no front face
  long long dropped_hits = 0;     // lobe rays that met a patch with F_ik = 0 (not a link)
  double balance_mismatch = 0.0;  // largest relative stationarity residual left by balancing
};

class SpecularTransfer {
 public:
  // Entries of patch i (the reflector): [start[i], start[i+1]), sorted by (from, to).
  std::vector<std::int64_t> start;
  std::vector<PatchId> from;    // j
  std::vector<PatchId> to;      // k
  std::vector<float> fraction;  // R_jik, colour excluded
  SpecularStats stats;

  std::int64_t entries() const { return static_cast<std::int64_t>(to.size()); }
  std::size_t bytes() const {
    return start.size() * sizeof(std::int64_t) + from.size() * sizeof(PatchId) +
           to.size() * sizeof(PatchId) + fraction.size() * sizeof(float);
  }
};

SpecularTransfer compute_specular_transfer(const PatchSet& patches,
                                           const std::vector<Material>& materials,
                                           const FormFactors& ff, const RayCaster& caster,
                                           const SpecularOptions& options = {});

// The entries of one reflecting patch i, as (j, k, R_jik), computed exactly as
// compute_specular_transfer does (same seeds): the building block of the on-the-fly operator.
struct TransferEntry {
  PatchId from, to;
  float fraction;
};
struct TransferCounters {
  long long rays = 0;
  long long unseen = 0;
  long long dropped = 0;
  double escaped = 0.0;  // sum of w * beta of rays that met no front face
  double weight = 0.0;   // sum of w
  double mismatch = 0.0;
};
void specular_entries_of(const PatchSet& patches, const Material& material, const FormFactors& ff,
                         const RayCaster& caster, const SpecularOptions& options, PatchId i,
                         std::vector<TransferEntry>& out, TransferCounters* counters = nullptr);

}  // namespace polyrad
