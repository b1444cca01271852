// Whether the patches resolve each glossy lobe: a cheap check, made once the specular transfer
// is known, that says when a coarse mesh smears a sharp lobe (papers/glossy-radiosity.md,
// section 11, "coarse patches against sharp lobes").
//
// The transfer R_jik is constant over the patch k a lobe ray lands on, so it resolves the
// outgoing direction only to within the angle k subtends from i. When that angle exceeds the
// width of the lobe, the lobe is averaged over a patch: the light a glossy object sends to
// other surfaces, and what other glossy surfaces see in it, is smeared over whole patches. The
// check compares, for every object with a GGX or Phong lobe:
//   - the lobe's width: the full angle of the cone about the mirror direction that holds half
//     of the lobe's energy (lobe_half_width, doubled), and
//   - the patches' angle: the flux-weighted median, over the object's stored transfer entries
//     (j -> i -> k), of the larger of the angles P_j and P_k subtend from the reflecting patch
//     i (the incoming direction is known to within P_j, the outgoing one to within P_k).
// Mirrors (and GGX below Material::kDeltaRoughness) are skipped: a delta lobe lands on one
// point and the transfer is exact for it by construction.
//
//   auto checks = check_lobe_resolution(scene, patches, ff, transfer);
//   for (const auto& c : checks) if (c.smeared) warn(describe_smear(c));
//
// Cost: one pass over the stored transfer entries (an addition each) and one over the
// reflecting patches' form-factor rows (a square root and a logarithm each); no rays. Memory:
// one float per patch, and a small histogram per glossy object.
#pragma once

#include <string>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/scene/scene.h"
#include "polyrad/transport/form_factors.h"
#include "polyrad/transport/specular_transfer.h"

namespace polyrad {

// A lobe is smeared when its patches' angle exceeds this multiple of the lobe's width (both
// full angles). At 1 the cone holding half of the lobe's energy fits inside one target patch:
// the transfer then cannot represent the lobe's shape at all, only how much of it lands where.
inline constexpr double kLobeSmearRatio = 1.0;

struct LobeResolution {
  ObjectId object = 0;
  std::string object_name, material_name;
  std::string lobe;            // the lobe's parameter, e.g. "GGX alpha 0.05"
  double lobe_degrees = 0.0;   // full width of the cone holding half of the lobe's energy
  double patch_degrees = 0.0;  // flux-weighted median angle of the patches it exchanges with
  // The patch size at which those patches would subtend the lobe's width: the flux-weighted
  // geometric mean patch_size of the objects they belong to, scaled by the ratio of the tangents
  // of the half angles. About: patches that touch the object subtend a wide angle at any size.
  double resolving_patch_size = 0.0;
  double current_patch_size = 0.0;  // that mean patch_size, as meshed
  bool smeared = false;             // patch_degrees > kLobeSmearRatio * lobe_degrees
};

// The angle between the mirror direction and the edge of the cone that holds half of the
// lobe's energy, in radians; 0 for a delta lobe or a material without one.
double lobe_half_width(const Material& m);

// One entry per object whose material has a non-delta lobe and that has stored transfer
// entries, in object order.
std::vector<LobeResolution> check_lobe_resolution(const Scene& scene, const PatchSet& patches,
                                                  const FormFactors& ff,
                                                  const SpecularTransfer& transfer);

// One line for a smeared lobe: the object, the material, both angles and the patch size that
// would resolve it.
std::string describe_smear(const LobeResolution& r);

}  // namespace polyrad
