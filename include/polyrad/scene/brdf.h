// Materials: the BRDFs patches reflect with, split into a Lambertian part and one non-diffuse lobe.
//
// f(wi, wo) = diffuse / pi + specular * lobe(wi, wo)          (papers/glossy-radiosity.md, eq. 1)
//
// The lobe is the geometric part of the non-diffuse reflection, per unit `specular` colour:
// a perfect mirror (delta), GGX / Trowbridge-Reitz microfacets with constant Fresnel, or the
// normalised modified Phong lobe. Factoring the colour out keeps the stored transfer scalar:
// one weight per link pair serves all three channels.
//
// Directions live in the local frame (z = the patch normal), unit length, pointing away from
// the surface. Every lobe is reciprocal, lobe(a, b) == lobe(b, a), so "the direction light came
// from" and "the direction it leaves to" may swap roles in any routine.
//
//   Material m = Material::glossy("gloss", Rgb(0.2,0.2,0.2), Rgb(0.6,0.6,0.6), 0.15);
//   LobeSample s = m.lobe_sample(wo, Vec2(u1, u2));   // s.wi with s.weight = lobe*cos/pdf
//
// Cost: every routine is O(1); lobe_albedo integrates numerically (O(samples)).
#pragma once

#include <string>
#include <vector>

#include "polyrad/types.h"
#include "polyrad/util/enum_names.h"

namespace polyrad {

enum class MaterialType { kDiffuse, kMirror, kGlossy, kPhong };
template <>
struct EnumNames<MaterialType> {
  static constexpr const char* kind = "material type";
  static constexpr std::array<std::pair<MaterialType, const char*>, 4> table{
      {{MaterialType::kDiffuse, "diffuse"},
       {MaterialType::kMirror, "mirror"},
       {MaterialType::kGlossy, "glossy"},
       {MaterialType::kPhong, "phong"}}};
};

// One sample of the non-diffuse lobe for a fixed direction.
struct LobeSample {
  Vec3 wi = Vec3::Zero();  // the sampled direction (local frame)
  double weight = 0.0;     // lobe(wi, wo) * cos(wi) / pdf, colour excluded; 0 if the sample failed
  double pdf = 0.0;        // solid-angle density; meaningless for a delta lobe
  bool delta = false;
};

// One sample of the whole BRDF (diffuse part and lobe), as the path tracer needs it.
struct BsdfSample {
  Vec3 wi = Vec3::Zero();
  Rgb weight = Rgb::Zero();  // f(wi, wo) * cos(wi) / pdf
  double pdf = 0.0;          // mixture density; for a delta sample the lobe's selection probability
  bool delta = false;
};

struct Material {
  std::string name;
  MaterialType type = MaterialType::kDiffuse;
  Rgb diffuse = Rgb::Zero();   // Lambertian reflectance d
  Rgb specular = Rgb::Zero();  // reflectance of the lobe (mirror reflectance, GGX F0, Phong k_s)
  double roughness = 0.0;      // GGX alpha
  double exponent = 0.0;       // Phong exponent n

  static Material lambert(std::string name, Rgb reflectance);
  static Material mirror(std::string name, Rgb reflectance);
  static Material glossy(std::string name, Rgb diffuse, Rgb specular, double roughness);
  static Material phong(std::string name, Rgb diffuse, Rgb specular, double exponent);

  // Below this GGX alpha the lobe is treated as the perfect mirror it tends to.
  static constexpr double kDeltaRoughness = 1e-3;

  bool has_lobe() const { return type != MaterialType::kDiffuse && specular.maxCoeff() > 0.0; }
  bool is_delta() const {
    return type == MaterialType::kMirror ||
           (type == MaterialType::kGlossy && roughness < kDeltaRoughness);
  }
  // An upper bound of the directional albedo per channel: diffuse + specular. Loading rejects a
  // material whose bound exceeds 1 (the lobes are normalised so that their own albedo <= 1).
  Rgb albedo_bound() const { return diffuse + specular; }

  // The lobe alone (colour excluded). eval and pdf are 0 for a delta lobe.
  double lobe_eval(const Vec3& wi, const Vec3& wo) const;
  double lobe_pdf(const Vec3& wi, const Vec3& wo) const;
  LobeSample lobe_sample(const Vec3& wo, const Vec2& u) const;
  // Directional albedo of the lobe, integral of lobe * cos over the hemisphere, by `samples`
  // importance samples (exact for the mirror).
  double lobe_albedo(const Vec3& wo, int samples) const;

  // The whole BRDF.
  Rgb eval(const Vec3& wi, const Vec3& wo) const;
  double pdf(const Vec3& wi, const Vec3& wo) const;
  BsdfSample sample(const Vec3& wo, double u_select, const Vec2& u) const;
  // Probability with which sample() picks the lobe (by luminance of the two reflectances).
  double lobe_probability() const;
};

// The reflecting material (diffuse or with a lobe) of the largest albedo bound, the first of
// equals; nullptr if none reflects. Its bound's largest channel is a_max, section 5's bound.
const Material* brightest_material(const std::vector<Material>& materials);

// Local frame helpers.
struct Frame {
  Vec3 s, t, n;
  static Frame from_normal(const Vec3& n);  // any orthonormal frame with z = n
  Vec3 to_local(const Vec3& v) const { return Vec3(v.dot(s), v.dot(t), v.dot(n)); }
  Vec3 to_world(const Vec3& v) const { return v.x() * s + v.y() * t + v.z() * n; }
};

inline Vec3 reflect_about_normal(const Vec3& w) { return Vec3(-w.x(), -w.y(), w.z()); }
// A world direction d after a mirror of unit normal n: d reflected in the mirror's plane.
inline Vec3 reflect_in_plane(const Vec3& d, const Vec3& n) { return d - 2.0 * d.dot(n) * n; }
Vec3 sample_cosine_hemisphere(const Vec2& u);

}  // namespace polyrad
