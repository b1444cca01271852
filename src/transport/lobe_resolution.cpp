// Whether the patches resolve each glossy lobe (lobe_resolution.h).
#include "polyrad/transport/lobe_resolution.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace polyrad {

namespace {

// Angles are binned on a log scale from kMinAngle to pi: 1024 bins are 1.2 percent wide.
constexpr int kBins = 1024;
constexpr double kMinAngle = 1e-5;  // radians

double degrees(double radians) { return radians * 180.0 / kPi; }

int angle_bin(double angle) {
  const double scale = kBins / std::log(kPi / kMinAngle);
  int bin = static_cast<int>(std::floor(std::log(std::max(angle, kMinAngle) / kMinAngle) * scale));
  return std::clamp(bin, 0, kBins - 1);
}

// What an entry's patch contributes: the bin of the angle it subtends from the reflecting patch,
// and the log of its object's patch_size.
struct PatchScale {
  int bin = 0;
  double log_size = 0.0;
};

// The flux-weighted distribution of the entries' angles for one object, and the flux-weighted
// mean of log(patch_size) of the patches that set them.
class AngleHistogram {
 public:
  void add(const PatchScale& s, double weight) {
    weight_[s.bin] += weight;
    total_ += weight;
    log_size_ += weight * s.log_size;
  }
  bool empty() const { return !(total_ > 0.0); }
  // The weighted median, interpolated log-linearly inside its bin.
  double median() const {
    const double step = std::log(kPi / kMinAngle) / kBins;
    double below = 0.0;
    for (int b = 0; b < kBins; ++b) {
      if (below + weight_[b] >= 0.5 * total_ && weight_[b] > 0.0)
        return kMinAngle * std::exp(step * (b + (0.5 * total_ - below) / weight_[b]));
      below += weight_[b];
    }
    return kPi;
  }
  double mean_patch_size() const { return std::exp(log_size_ / total_); }

 private:
  std::vector<double> weight_ = std::vector<double>(kBins, 0.0);
  double total_ = 0.0, log_size_ = 0.0;
};

// The full angle patch k subtends from the centre of patch i: 2 atan(s / 2r) for a patch of
// projected width s = sqrt(A'_k cos(theta_k)) at distance r.
double subtended_angle(const PatchSet& patches, const FormFactors& ff, PatchId i, PatchId k) {
  const Patch& pk = patches[k];
  const Vec3 d = pk.centroid - patches[i].centroid;
  const double r = d.norm();
  const double cos_k = std::max(0.0, -pk.normal.dot(d) / r);
  const double area = ff.area[k] > 0.0 ? ff.area[k] : pk.area;
  return 2.0 * std::atan(std::sqrt(area * cos_k) / (2.0 * r));
}

// Adds reflector i's entries to h. Both patches of an entry (j -> i -> k) lie in row i of F, so
// their scales are measured once per row. An entry resolves the lobe no better than the coarser
// of its two patches (the incoming direction is known to within P_j, the outgoing one to within
// P_k), and it carries the flux tau_ij R_jik, tau_ij = pi A'_i F_ij, under unit radiance
// everywhere: that is its weight.
void add_reflector(const Scene& scene, const PatchSet& patches, const FormFactors& ff,
                   const SpecularTransfer& t, PatchId i, std::vector<PatchScale>& scale,
                   AngleHistogram& h) {
  for (auto [k, f_ik] : ff.f.row(i)) {
    scale[k] = {angle_bin(subtended_angle(patches, ff, i, k)),
                std::log(scene.objects[patches[k].object].patch_size)};
  }
  PatchId last_j = -1;
  double tau = 0.0;
  for (auto e = t.start[i]; e < t.start[i + 1]; ++e) {
    if (t.from[e] != last_j) {
      last_j = t.from[e];
      tau = kPi * ff.area[i] * ff.at(i, last_j);
    }
    const PatchScale& a = scale[t.from[e]];
    const PatchScale& b = scale[t.to[e]];
    h.add(a.bin >= b.bin ? a : b, tau * t.fraction[e]);
  }
}

// "GGX alpha 0.05", "Phong exponent 40".
std::string lobe_parameter(const Material& m) {
  char text[64];
  if (m.type == MaterialType::kPhong)
    std::snprintf(text, sizeof text, "Phong exponent %g", m.exponent);
  else
    std::snprintf(text, sizeof text, "GGX alpha %g", m.roughness);
  return text;
}

LobeResolution verdict(const Scene& scene, ObjectId o, const AngleHistogram& h) {
  const SceneObject& object = scene.objects[o];
  const Material& m = scene.materials[object.material];
  LobeResolution r;
  r.object = o;
  r.object_name = object.name;
  r.material_name = m.name;
  r.lobe = lobe_parameter(m);
  const double lobe = 2.0 * lobe_half_width(m);
  const double patch = h.median();
  r.lobe_degrees = degrees(lobe);
  r.patch_degrees = degrees(patch);
  r.current_patch_size = h.mean_patch_size();
  // A patch's angle grows about linearly with its size (tan(angle / 2) exactly, away from
  // contact), so the size at which the median patch subtends the lobe's width is:
  r.resolving_patch_size =
      r.current_patch_size * std::tan(0.5 * std::min(lobe, 3.0)) / std::tan(0.5 * patch);
  r.smeared = patch > kLobeSmearRatio * lobe;
  return r;
}

}  // namespace

// Half of the lobe's energy lies within this angle of the mirror direction:
// - GGX: the projected microfacet normals (D(h) cos(theta_h)) have the distribution
//   P(theta_h < t) = tan^2(t) / (alpha^2 + tan^2(t)), the one GGX sampling inverts (Walter et
//   al. 2007, eq. 35-36), so their median is tan(theta_h) = alpha. A microfacet tilted by
//   theta_h turns the reflected direction by 2 theta_h (exactly at normal incidence), so half of
//   the reflected energy lies within 2 atan(alpha), before masking. Masking (G2) weighs the
//   tail down: the weighted median of the sampler's own directions is within 3 percent of this
//   for alpha <= 0.15 and 12 percent narrower at alpha = 0.3 (tests/lobe_resolution_test.cpp),
//   so the check errs toward fewer warnings only for rough lobes, which patches rarely smear.
//   D falls to half its peak at tan^2(theta_h) ~= (sqrt(2) - 1) alpha^2, i.e. 1.29 alpha in the
//   reflected direction: the half-energy cone is the wider, tail-aware measure.
// - Phong: lobe ~ cos^n(a) about the mirror direction, so the energy within a is proportional to
//   int_0^a cos^n sin = (1 - cos^(n+1)(a)) / (n + 1), the distribution the Phong sampler inverts
//   (cos a = u^(1/(n+1)), brdf.cpp). Half of it lies within acos(2^(-1/(n+1))); the half-maximum
//   angle acos(2^(-1/n)) is wider by about 1/(2n) of it (2.5 percent at n = 20).
double lobe_half_width(const Material& m) {
  if (!m.has_lobe() || m.is_delta()) return 0.0;
  if (m.type == MaterialType::kGlossy) return 2.0 * std::atan(m.roughness);
  if (m.type == MaterialType::kPhong) return std::acos(std::pow(2.0, -1.0 / (m.exponent + 1.0)));
  return 0.0;
}

std::vector<LobeResolution> check_lobe_resolution(const Scene& scene, const PatchSet& patches,
                                                  const FormFactors& ff,
                                                  const SpecularTransfer& transfer) {
  if (transfer.start.size() != patches.size() + 1) return {};  // no stored transfer
  std::vector<AngleHistogram> histograms(scene.objects.size());
  std::vector<PatchScale> scale(patches.size());
  for (PatchId i = 0; i < static_cast<PatchId>(patches.size()); ++i) {
    if (lobe_half_width(scene.materials[patches[i].material]) <= 0.0) continue;
    add_reflector(scene, patches, ff, transfer, i, scale, histograms[patches[i].object]);
  }
  std::vector<LobeResolution> out;
  for (ObjectId o = 0; o < static_cast<ObjectId>(scene.objects.size()); ++o)
    if (!histograms[o].empty()) out.push_back(verdict(scene, o, histograms[o]));
  return out;
}

std::string describe_smear(const LobeResolution& r) {
  char text[640];
  std::snprintf(text, sizeof text,
                "object '%s' (material '%s', %s): its lobe is %.1f degrees wide (the cone holding "
                "half its energy) but the patches it exchanges specular light with subtend "
                "%.1f degrees (flux-weighted median), so the transfer averages the lobe over "
                "each patch and the light it reflects is smeared; patches of about %.3g or "
                "smaller (now %.3g) would resolve it",
                r.object_name.c_str(), r.material_name.c_str(), r.lobe.c_str(), r.lobe_degrees,
                r.patch_degrees, r.resolving_patch_size, r.current_patch_size);
  return text;
}

}  // namespace polyrad
