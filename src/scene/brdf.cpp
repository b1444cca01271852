// The lobes of brdf.h. Equation numbers refer to papers/glossy-radiosity.md.
#include "polyrad/scene/brdf.h"

#include <algorithm>
#include <cmath>

namespace polyrad {

Material Material::lambert(std::string name, Rgb reflectance) {
  Material m;
  m.name = std::move(name);
  m.type = MaterialType::kDiffuse;
  m.diffuse = reflectance;
  return m;
}

Material Material::mirror(std::string name, Rgb reflectance) {
  Material m;
  m.name = std::move(name);
  m.type = MaterialType::kMirror;
  m.specular = reflectance;
  return m;
}

Material Material::glossy(std::string name, Rgb diffuse, Rgb specular, double roughness) {
  Material m;
  m.name = std::move(name);
  m.type = MaterialType::kGlossy;
  m.diffuse = diffuse;
  m.specular = specular;
  m.roughness = roughness;
  return m;
}

Material Material::phong(std::string name, Rgb diffuse, Rgb specular, double exponent) {
  Material m;
  m.name = std::move(name);
  m.type = MaterialType::kPhong;
  m.diffuse = diffuse;
  m.specular = specular;
  m.exponent = exponent;
  return m;
}

const Material* brightest_material(const std::vector<Material>& materials) {
  const Material* best = nullptr;
  for (const Material& m : materials) {
    const bool reflects = m.diffuse.maxCoeff() > 0.0 || m.has_lobe();
    if (reflects && m.albedo_bound().maxCoeff() > (best ? best->albedo_bound().maxCoeff() : 0.0))
      best = &m;
  }
  return best;
}

Frame Frame::from_normal(const Vec3& n) {
  // Orthonormal basis (Duff et al. 2017): one formula whose sign switches at n.z = 0, accurate
  // for every unit normal including n = -z.
  double sign = std::copysign(1.0, n.z());
  double a = -1.0 / (sign + n.z());
  double b = n.x() * n.y() * a;
  Frame f;
  f.s = Vec3(1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
  f.t = Vec3(b, sign + n.y() * n.y() * a, -n.y());
  f.n = n;
  return f;
}

Vec3 sample_cosine_hemisphere(const Vec2& u) {
  double r = std::sqrt(u.x());
  double phi = 2.0 * kPi * u.y();
  return Vec3(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1.0 - u.x())));
}

namespace {

// ---- GGX / Trowbridge-Reitz (eq. 2) ----------------------------------------------------------

double ggx_d(double cos_h, double alpha) {
  double a2 = alpha * alpha;
  double t = cos_h * cos_h * (a2 - 1.0) + 1.0;
  return a2 / (kPi * t * t);
}

// Smith Lambda; G1 = 1 / (1 + Lambda), height-correlated G2 = 1 / (1 + Lambda_i + Lambda_o).
double ggx_lambda(const Vec3& w, double alpha) {
  double c2 = w.z() * w.z();
  if (c2 >= 1.0) return 0.0;
  double tan2 = (1.0 - c2) / c2;
  return 0.5 * (-1.0 + std::sqrt(1.0 + alpha * alpha * tan2));
}

double ggx_eval(const Vec3& wi, const Vec3& wo, double alpha) {
  Vec3 h = (wi + wo).normalized();
  double g2 = 1.0 / (1.0 + ggx_lambda(wi, alpha) + ggx_lambda(wo, alpha));
  return ggx_d(h.z(), alpha) * g2 / (4.0 * wi.z() * wo.z());
}

double ggx_pdf(const Vec3& wi, const Vec3& wo, double alpha) {
  // Visible-normal density transformed to wi: G1(wo) D(h) / (4 cos(wo)).
  Vec3 h = (wi + wo).normalized();
  double g1 = 1.0 / (1.0 + ggx_lambda(wo, alpha));
  return g1 * ggx_d(h.z(), alpha) / (4.0 * wo.z());
}

// Visible normal of the GGX surface seen from wo (Heitz 2018, "Sampling the GGX distribution of
// visible normals"): stretch to the unit-roughness configuration, pick a point on the projected
// hemisphere, unstretch.
Vec3 ggx_sample_visible_normal(const Vec3& wo, double alpha, const Vec2& u) {
  Vec3 v = Vec3(alpha * wo.x(), alpha * wo.y(), wo.z()).normalized();
  double len2 = v.x() * v.x() + v.y() * v.y();
  Vec3 t1 = len2 > 0.0 ? Vec3(-v.y(), v.x(), 0.0) / std::sqrt(len2) : Vec3(1.0, 0.0, 0.0);
  Vec3 t2 = v.cross(t1);
  double r = std::sqrt(u.x());
  double phi = 2.0 * kPi * u.y();
  double p1 = r * std::cos(phi);
  double p2 = r * std::sin(phi);
  double s = 0.5 * (1.0 + v.z());
  p2 = (1.0 - s) * std::sqrt(std::max(0.0, 1.0 - p1 * p1)) + s * p2;
  Vec3 nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0, 1.0 - p1 * p1 - p2 * p2)) * v;
  return Vec3(alpha * nh.x(), alpha * nh.y(), std::max(1e-12, nh.z())).normalized();
}

// ---- normalised modified Phong (eq. 3) -------------------------------------------------------

// The lobe lives on the hemisphere around the mirror direction r, where the sampler draws:
// zero beyond it even for n = 0 (where pow(0, 0) = 1 would leave it non-zero but never drawn).
double phong_cos_alpha(const Vec3& wi, const Vec3& wo) { return wi.dot(reflect_about_normal(wo)); }

double phong_eval(const Vec3& wi, const Vec3& wo, double n) {
  double c = phong_cos_alpha(wi, wo);
  return c > 0.0 ? (n + 2.0) / (2.0 * kPi) * std::pow(c, n) : 0.0;
}

double phong_pdf(const Vec3& wi, const Vec3& wo, double n) {
  double c = phong_cos_alpha(wi, wo);
  return c > 0.0 ? (n + 1.0) / (2.0 * kPi) * std::pow(c, n) : 0.0;
}

}  // namespace

double Material::lobe_eval(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0.0 || wo.z() <= 0.0 || is_delta()) return 0.0;
  switch (type) {
    case MaterialType::kGlossy:
      return ggx_eval(wi, wo, roughness);
    case MaterialType::kPhong:
      return phong_eval(wi, wo, exponent);
    default:
      return 0.0;
  }
}

double Material::lobe_pdf(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0.0 || wo.z() <= 0.0 || is_delta()) return 0.0;
  switch (type) {
    case MaterialType::kGlossy:
      return ggx_pdf(wi, wo, roughness);
    case MaterialType::kPhong:
      return phong_pdf(wi, wo, exponent);
    default:
      return 0.0;
  }
}

LobeSample Material::lobe_sample(const Vec3& wo, const Vec2& u) const {
  LobeSample s;
  if (wo.z() <= 0.0 || type == MaterialType::kDiffuse) return s;
  if (is_delta()) {
    s.wi = reflect_about_normal(wo);
    s.weight = 1.0;
    s.pdf = 1.0;
    s.delta = true;
    return s;
  }
  if (type == MaterialType::kGlossy) {
    Vec3 h = ggx_sample_visible_normal(wo, roughness, u);
    s.wi = 2.0 * wo.dot(h) * h - wo;
    if (s.wi.z() <= 0.0) return s;
    s.pdf = ggx_pdf(s.wi, wo, roughness);
    // lobe * cos / pdf = G2 / G1(wo) <= 1: the sampler never creates energy.
    double li = ggx_lambda(s.wi, roughness);
    double lo = ggx_lambda(wo, roughness);
    s.weight = (1.0 + lo) / (1.0 + li + lo);
    return s;
  }
  // Phong: cos^n lobe around the mirror direction of wo.
  double cos_a = std::pow(u.x(), 1.0 / (exponent + 1.0));
  double sin_a = std::sqrt(std::max(0.0, 1.0 - cos_a * cos_a));
  double phi = 2.0 * kPi * u.y();
  Frame f = Frame::from_normal(reflect_about_normal(wo));
  s.wi = f.to_world(Vec3(sin_a * std::cos(phi), sin_a * std::sin(phi), cos_a));
  if (s.wi.z() <= 0.0) return s;
  s.pdf = phong_pdf(s.wi, wo, exponent);
  s.weight = (exponent + 2.0) / (exponent + 1.0) * s.wi.z();
  return s;
}

double Material::lobe_albedo(const Vec3& wo, int samples) const {
  if (type == MaterialType::kDiffuse) return 0.0;
  if (is_delta()) return wo.z() > 0.0 ? 1.0 : 0.0;
  int side = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(samples))));
  double sum = 0.0;
  for (int a = 0; a < side; ++a)
    for (int b = 0; b < side; ++b)
      sum += lobe_sample(wo, Vec2((a + 0.5) / side, (b + 0.5) / side)).weight;
  return sum / (side * side);
}

Rgb Material::eval(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0.0 || wo.z() <= 0.0) return Rgb::Zero();
  Rgb f = diffuse * kInvPi;
  if (has_lobe()) f += specular * lobe_eval(wi, wo);
  return f;
}

double Material::lobe_probability() const {
  if (!has_lobe()) return 0.0;
  double ls = luminance(specular), ld = luminance(diffuse);
  if (ld <= 0.0) return 1.0;
  return ls / (ls + ld);
}

double Material::pdf(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0.0 || wo.z() <= 0.0) return 0.0;
  double p = lobe_probability();
  return (1.0 - p) * wi.z() * kInvPi + p * lobe_pdf(wi, wo);
}

BsdfSample Material::sample(const Vec3& wo, double u_select, const Vec2& u) const {
  BsdfSample s;
  if (wo.z() <= 0.0) return s;
  double p = lobe_probability();
  bool pick_lobe = u_select < p;
  if (pick_lobe && is_delta()) {
    LobeSample l = lobe_sample(wo, u);
    s.wi = l.wi;
    s.weight = specular * (l.weight / p);
    s.pdf = p;
    s.delta = true;
    return s;
  }
  if (pick_lobe) {
    LobeSample l = lobe_sample(wo, u);
    if (l.weight <= 0.0) return s;
    s.wi = l.wi;
  } else {
    s.wi = sample_cosine_hemisphere(u);
  }
  s.pdf = pdf(s.wi, wo);
  if (s.pdf <= 0.0) return BsdfSample{};
  s.weight = eval(s.wi, wo) * (s.wi.z() / s.pdf);
  return s;
}

}  // namespace polyrad
