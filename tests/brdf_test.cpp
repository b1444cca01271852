// Materials (brdf.h): reciprocity, energy conservation by quadrature, sampling against pdf by
// chi-square, the GGX-to-mirror limit and the local frame.
//
// Every integral over directions here is a deterministic product Gauss-Legendre rule in a polar
// chart that resolves the lobe; none of it calls the sampler under test:
// - around a direction p (the mirror direction for Phong, the normal for Lambert):
//     wi = cos(b) p + sin(b) (cos(phi) e1 + sin(phi) e2),  e1 toward +z,  dw_i = sin(b) db dphi;
// - over the half vector (GGX):
//     h = cos(t) z + sin(t) (cos(phi) e1 + sin(phi) e2),  e1 the azimuth of wo,
//     wi = 2 (wo.h) h - wo,  dw_i = 4 (wo.h) dw_h.
// In both charts the horizon wi.z > 0 is |phi| < phimax(angle), in closed form, so no rule
// straddles the cut. A radial warp a -> angle (the lobe's own CDF) spreads the nodes over the
// lobe; the angles where phimax changes regime split the radial range, and each segment gets a
// smoothstep substitution that removes the square-root behaviour at its ends, and panels graded
// toward both ends. The error estimate of a quadrature is its difference to a coarser rule plus
// 1e-12 for summation rounding; the tests assert that it is small before using it as a tolerance.
#include "polyrad/scene/brdf.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "polyrad/util/sampling.h"
#include "statistics.h"

namespace polyrad {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

double deg(double d) { return d * kPi / 180.0; }

// A unit direction with polar angle theta (degrees) and azimuth phi (radians). The default
// azimuth is off the axes so that a frame mix-up cannot hide behind a symmetry.
Vec3 polar_dir(double theta_deg, double phi = 0.7) {
  double t = deg(theta_deg);
  return Vec3(std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t));
}

double angle_between(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

Vec3 uniform_hemisphere(const Vec2& u) {
  double z = u.x(), r = std::sqrt(std::max(0.0, 1.0 - z * z)), phi = 2.0 * kPi * u.y();
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

double rel_diff(double a, double b) {
  double m = std::max(std::abs(a), std::abs(b));
  return m > 0.0 ? std::abs(a - b) / m : 0.0;
}

// ---- quadrature ------------------------------------------------------------------------------

// Radial coordinate a in [0, 1] -> polar angle of a chart. sin_dtheta(a) = sin(theta) dtheta/da.
struct Warp {
  enum class Kind { kCap, kPhong, kGgx };
  Kind kind = Kind::kCap;
  double p = 1.0;    // kCap: power q; kPhong: exponent n; kGgx: alpha
  double cap = 1.0;  // kCap: 1 - cos(theta_max)

  // 1 - cos(theta) = cap * a^q.
  static Warp cap_power(double theta_max, double q) {
    return {Kind::kCap, q, 2.0 * std::pow(std::sin(0.5 * theta_max), 2)};
  }
  // The CDF of cos^n around the pole: cos(theta) = (1 - a)^(1/(n+1)).
  static Warp phong(double n) { return {Kind::kPhong, n, 1.0}; }
  // The CDF of D(h) cos(h) for GGX: tan(theta) = alpha sqrt(a / (1 - a)).
  static Warp ggx(double alpha) { return {Kind::kGgx, alpha, 1.0}; }

  double theta(double a) const {
    switch (kind) {
      case Kind::kCap:
        return 2.0 * std::asin(std::min(1.0, std::sqrt(0.5 * cap * std::pow(a, p))));
      case Kind::kPhong: {
        double omc = -std::expm1(std::log1p(-a) / (p + 1.0));  // 1 - cos, without cancellation
        return 2.0 * std::asin(std::min(1.0, std::sqrt(0.5 * omc)));
      }
      case Kind::kGgx:
        return std::atan(p * std::sqrt(a / (1.0 - a)));
    }
    return 0.0;
  }
  double sin_dtheta(double a) const {
    if (kind != Kind::kCap && !(a < 1.0)) return 0.0;  // a rounded to 1: a set of measure 0
    switch (kind) {
      case Kind::kCap:
        return cap * p * std::pow(a, p - 1.0);
      case Kind::kPhong: {
        double k = 1.0 / (p + 1.0);
        return k * std::pow(1.0 - a, k - 1.0);
      }
      case Kind::kGgx:
        return std::sin(theta(a)) * p / (2.0 * std::sqrt(a * (1.0 - a)) * ((1.0 - a) + p * p * a));
    }
    return 0.0;
  }
  double inverse(double th) const {
    switch (kind) {
      case Kind::kCap: {
        double omc = 2.0 * std::pow(std::sin(0.5 * th), 2);
        return std::min(1.0, std::pow(omc / cap, 1.0 / p));
      }
      case Kind::kPhong:
        if (th >= 0.5 * kPi) return 1.0;
        return -std::expm1((p + 1.0) * std::log(std::cos(th)));
      case Kind::kGgx: {
        if (th >= 0.5 * kPi) return 1.0;
        double t = std::tan(th);
        return t * t / (p * p + t * t);
      }
    }
    return 0.0;
  }
};

struct Chart {
  enum class Kind { kAround, kHalfVector };
  Kind kind = Kind::kAround;
  Vec3 wo = Vec3::UnitZ();
  Vec3 pole = Vec3::UnitZ(), e1 = Vec3::UnitX(), e2 = Vec3::UnitY();
  double c = 1.0, s = 0.0;  // cos, sin of the polar angle of the pole (kAround) or of wo
  Warp warp;
  double a_end = 1.0;          // radial domain [0, a_end]
  std::vector<double> breaks;  // radial values inside (0, a_end) where phimax changes regime

  void add_break(double th) {
    double a = warp.inverse(th);
    if (a > 0.0 && a < a_end) breaks.push_back(a);
  }

  static Chart around(const Vec3& p, const Warp& w) {
    Chart ch;
    ch.kind = Kind::kAround;
    ch.pole = p;
    ch.warp = w;
    ch.c = p.z();
    ch.s = std::hypot(p.x(), p.y());
    ch.e1 = ch.s > 1e-12 ? Vec3((Vec3::UnitZ() - ch.c * p) / ch.s) : Vec3::UnitX();
    ch.e2 = p.cross(ch.e1);
    double th1 = std::atan2(ch.c, ch.s);  // pi/2 - polar angle of p: the whole circle ends
    double th2 = kPi - th1;               // nothing above the horizon beyond
    ch.a_end = w.inverse(th2);
    ch.add_break(th1);
    return ch;
  }

  static Chart half_vector(const Vec3& w_o, const Warp& w) {
    Chart ch;
    ch.kind = Kind::kHalfVector;
    ch.wo = w_o;
    ch.warp = w;
    ch.c = w_o.z();
    ch.s = std::hypot(w_o.x(), w_o.y());
    ch.e1 = ch.s > 0.0 ? Vec3(w_o.x() / ch.s, w_o.y() / ch.s, 0.0) : Vec3::UnitX();
    ch.e2 = Vec3::UnitZ().cross(ch.e1);
    double theta_o = std::atan2(ch.s, ch.c);
    ch.a_end = w.inverse(0.5 * (0.5 * kPi + theta_o));
    ch.add_break(0.5 * (0.5 * kPi - theta_o));
    return ch;
  }

  // Half-width of the azimuth range whose directions lie above the horizon.
  double phi_max(double th) const {
    double num, den;
    if (kind == Kind::kAround) {  // wi.z = cos(th) c + sin(th) s cos(phi)
      num = -std::cos(th) * c;
      den = std::sin(th) * s;
    } else {  // wi.z > 0  <=>  s sin(2 th) cos(phi) > -c cos(2 th)
      num = -c * std::cos(2.0 * th);
      den = s * std::sin(2.0 * th);
    }
    if (den <= 0.0) return num < 0.0 ? kPi : 0.0;
    double x = num / den;
    if (x <= -1.0) return kPi;
    if (x >= 1.0) return 0.0;
    return std::acos(x);
  }

  // wi at (th, phi) and the factor dw_i / (sin(th) dth dphi).
  Vec3 direction(double th, double phi, double* jac) const {
    Vec3 v = std::cos(th) * pole + std::sin(th) * (std::cos(phi) * e1 + std::sin(phi) * e2);
    if (kind == Kind::kAround) {
      *jac = 1.0;
      return v;
    }
    double d = wo.dot(v);
    *jac = 4.0 * d;
    return 2.0 * d * v - wo;
  }

  void locate(const Vec3& wi, double* a, double* phi) const {
    Vec3 v = kind == Kind::kAround ? wi : Vec3((wi + wo).normalized());
    double x = v.dot(e1), y = v.dot(e2);
    *a = warp.inverse(std::atan2(std::hypot(x, y), v.dot(pole)));
    *phi = std::atan2(y, x);
  }
};

// Panel boundaries on [0, 1]: `panels` equal panels, the first and the last split again
// geometrically toward the ends (ratio 1/5, `levels` times). The integrands of the charts have
// their near-singularities at the ends of a range: a break where phimax changes regime lies
// close to the pole of cot(), the GGX warp lies close to its pole at a = 1, and G2 varies on the
// scale alpha next to the horizon.
std::vector<double> graded_panels(int panels, int levels) {
  std::vector<double> b{0.0};
  double h = 1.0 / panels;
  for (int l = levels; l >= 1; --l) b.push_back(h * std::pow(0.2, l));
  for (int k = 1; k < panels; ++k) b.push_back(k * h);
  for (int l = 1; l <= levels; ++l) b.push_back(1.0 - h * std::pow(0.2, l));
  b.push_back(1.0);
  return b;
}

struct Rule {
  int panels = 4, levels = 6, order = 12;  // order: Gauss-Legendre nodes per panel
};

// Integral of g(wi) dw_i over the part of the cell [a0, a1] x [p0, p1] of the chart that lies
// above the horizon: Gauss-Legendre on graded panels, per radial segment (between breaks) and per
// azimuth range.
template <class G>
double integrate_cell(const Chart& ch, const G& g, double a0, double a1, double p0, double p1,
                      Rule rule_size) {
  const GaussRule& rule = gauss_legendre(rule_size.order);
  const std::vector<double> panel = graded_panels(rule_size.panels, rule_size.levels);
  std::vector<double> cuts{a0};
  for (double b : ch.breaks)
    if (b > a0 && b < a1) cuts.push_back(b);
  cuts.push_back(a1);
  std::sort(cuts.begin(), cuts.end());
  double sum = 0.0;
  for (size_t k = 0; k + 1 < cuts.size(); ++k) {
    double left = cuts[k], width = cuts[k + 1] - cuts[k];
    for (size_t pa = 0; pa + 1 < panel.size(); ++pa) {
      double t0 = panel[pa], dt = panel[pa + 1] - panel[pa];
      for (size_t i = 0; i < rule.node.size(); ++i) {
        double t = t0 + dt * rule.node[i];
        double a = left + width * t * t * (3.0 - 2.0 * t);  // smoothstep: flat at both ends
        double wa = rule.weight[i] * dt * width * 6.0 * t * (1.0 - t);
        double th = ch.warp.theta(a);
        double pm = ch.phi_max(th);
        double lo = std::max(p0, -pm), hi = std::min(p1, pm);
        if (hi <= lo || wa <= 0.0) continue;
        double inner = 0.0;
        for (size_t pp = 0; pp + 1 < panel.size(); ++pp) {
          double s0 = panel[pp], ds = panel[pp + 1] - panel[pp];
          for (size_t j = 0; j < rule.node.size(); ++j) {
            double phi = lo + (hi - lo) * (s0 + ds * rule.node[j]);
            double jac;
            Vec3 wi = ch.direction(th, phi, &jac);
            if (wi.z() <= 0.0) continue;  // rounding right at the cut
            inner += rule.weight[j] * ds * jac * g(wi);
          }
        }
        sum += wa * ch.warp.sin_dtheta(a) * inner * (hi - lo);
      }
    }
  }
  return sum;
}

struct Estimate {
  double value = 0.0, error = 0.0;
};

// The whole chart, with the difference to a coarser rule (half the panels, fewer levels) as the
// error estimate.
template <class G>
Estimate integrate(const Chart& ch, const G& g, Rule fine = {4, 6}) {
  Rule coarse{std::max(1, fine.panels / 2), fine.levels - 2};
  double qc = integrate_cell(ch, g, 0.0, ch.a_end, -kPi, kPi, coarse);
  double qf = integrate_cell(ch, g, 0.0, ch.a_end, -kPi, kPi, fine);
  return {qf, std::abs(qf - qc) + 1e-12};
}

// The chart that resolves a material's lobe for outgoing direction wo.
Chart lobe_chart(const Material& m, const Vec3& wo) {
  if (m.type == MaterialType::kGlossy) return Chart::half_vector(wo, Warp::ggx(m.roughness));
  return Chart::around(reflect_about_normal(wo), Warp::phong(m.exponent));
}

// Directional albedo of the lobe, the integral of lobe(wi, wo) cos(wi) dw_i.
Estimate lobe_albedo_quadrature(const Material& m, const Vec3& wo) {
  return integrate(lobe_chart(m, wo), [&](const Vec3& wi) { return m.lobe_eval(wi, wo) * wi.z(); });
}

Estimate lobe_pdf_quadrature(const Material& m, const Vec3& wo) {
  return integrate(lobe_chart(m, wo), [&](const Vec3& wi) { return m.lobe_pdf(wi, wo); });
}

// ---- statistics ------------------------------------------------------------------------------

// Every chi-square test below must reach this p-value. 56 of them run, so the chance that a
// correct sampler fails any is about 6e-4 (and the seeds are fixed, so a pass stays a pass).
constexpr double kChiSquareSignificance = 1e-5;

// Grids of valid parameters.
const std::vector<double> kRoughness = {0.01, 0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0};
const std::vector<double> kExponent = {1, 2, 5, 10, 20, 50, 100, 200, 500, 1000};
const std::vector<double> kThetaDeg = {0, 15, 30, 45, 60, 75, 85, 89, 89.9};

Material ggx(double alpha, double d = 0.0, double s = 1.0) {
  return Material::glossy("ggx", Rgb::Constant(d), Rgb::Constant(s), alpha);
}
Material phong(double n, double d = 0.0, double s = 1.0) {
  return Material::phong("phong", Rgb::Constant(d), Rgb::Constant(s), n);
}

// ---- the helpers themselves ------------------------------------------------------------------

// Reference values from mpmath.gammainc(a, x, inf, regularized=True).
TEST(TestStatistics, GammaQMatchesKnownValues) {
  EXPECT_NEAR(test::gamma_q(1.0, 2.0), std::exp(-2.0), 1e-14);            // Q(1, x) = e^-x
  EXPECT_NEAR(test::gamma_q(5.0, 9.153519), 0.0500000008247323, 1e-12);   // chi2(10), 95%
  EXPECT_NEAR(test::gamma_q(199.5, 223.815), 0.0465269716662569, 1e-12);  // continued fraction
  EXPECT_NEAR(test::gamma_q(199.5, 180.0), 0.919917784183903, 1e-12);     // series
}

// The quadrature integrates cos/pi to 1 and 1 to 2 pi over the hemisphere in every chart and
// warp used below, for any pole: this checks the cut handling, the warps and the Jacobians.
TEST(BrdfTestHelpers, QuadratureIntegratesKnownFunctions) {
  auto cosine = [](const Vec3& wi) { return wi.z() * kInvPi; };
  auto one = [](const Vec3&) { return 1.0; };
  for (double th : kThetaDeg) {
    SCOPED_TRACE(testing::Message() << "theta_o " << th);
    Vec3 wo = polar_dir(th);
    Vec3 r = reflect_about_normal(wo);
    double th2 = kPi - std::atan2(r.z(), std::hypot(r.x(), r.y()));
    for (double q : {1.0, 2.0}) {
      Chart ch = Chart::around(r, Warp::cap_power(th2, q));
      EXPECT_NEAR(integrate(ch, cosine).value, 1.0, 1e-10);
      EXPECT_NEAR(integrate(ch, one).value, 2.0 * kPi, 1e-10);
    }
    // The half-vector chart maps the hemisphere of wi one to one; smooth integrands converge.
    for (double alpha : {0.3, 1.0}) {
      Chart ch = Chart::half_vector(wo, Warp::ggx(alpha));
      Estimate e = integrate(ch, cosine);
      EXPECT_NEAR(e.value, 1.0, 1e-10) << "alpha " << alpha;
      EXPECT_LT(e.error, 1e-10);
    }
    // Chart::locate inverts Chart::direction.
    Chart ch = Chart::half_vector(wo, Warp::ggx(0.2));
    double jac, a, phi;
    Vec3 wi = ch.direction(ch.warp.theta(0.3), 0.4, &jac);
    ch.locate(wi, &a, &phi);
    EXPECT_NEAR(a, 0.3, 1e-9);
    EXPECT_NEAR(phi, 0.4, 1e-9);
  }
}

// ---- frame -----------------------------------------------------------------------------------

TEST(Frame, FromNormalIsOrthonormalAndRightHanded) {
  std::vector<Vec3> normals = {
      Vec3(0, 0, 1),         Vec3(0, 0, -1),         Vec3(1, 0, 0),           Vec3(0, 1, 0),
      Vec3(0, -1, 0),        Vec3(-1, 0, 0),         Vec3(1e-8, 0, -1),       Vec3(0, 1e-8, -1),
      Vec3(1e-4, -2e-4, -1), Vec3(3e-10, 1e-10, -1), Vec3(-1e-15, 1e-15, -1), Vec3(1e-3, 1e-3, -1),
      Vec3(1, 1, -1e-12),    Vec3(1, 1, 1e-12),      Vec3(0.6, 0.8, -0.0)};
  Rng rng(7, 1);
  for (int i = 0; i < 20000; ++i) {
    Vec2 u = rng.uniform2();
    double z = 2.0 * u.x() - 1.0;
    if (i % 4 == 0) z = -1.0 + std::pow(10.0, -16.0 * u.x());  // crowd the south pole
    double r = std::sqrt(std::max(0.0, 1.0 - z * z)), phi = 2.0 * kPi * u.y();
    normals.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  // Rounding of a handful of products and sums: a few dozen ulps.
  const double tol = 64 * kEps;
  int bad = 0;
  double worst = 0.0;
  for (Vec3 n : normals) {
    n.normalize();
    Frame f = Frame::from_normal(n);
    double err = std::max({std::abs(f.s.norm() - 1.0), std::abs(f.t.norm() - 1.0),
                           std::abs(f.s.dot(f.t)), std::abs(f.s.dot(n)), std::abs(f.t.dot(n)),
                           (f.s.cross(f.t) - n).norm(), (f.n - n).norm()});
    Vec3 v(0.3, -0.5, 0.81);
    err = std::max(err, (f.to_local(f.to_world(v)) - v).norm());
    err = std::max(err, (f.to_world(Vec3::UnitZ()) - n).norm());
    if (!(err <= tol)) {
      if (++bad < 5) ADD_FAILURE() << "normal " << n.transpose() << " error " << err;
    }
    worst = std::max(worst, err);
  }
  EXPECT_EQ(bad, 0) << "worst error " << worst;
}

// ---- reciprocity -----------------------------------------------------------------------------

TEST(Brdf, LobeAndBsdfAreReciprocal) {
  std::vector<Material> materials;
  for (double a : kRoughness) materials.push_back(ggx(a, 0.3, 0.6));
  for (double n : kExponent) materials.push_back(phong(n, 0.3, 0.6));
  materials.push_back(Material::lambert("white", Rgb(0.9, 0.5, 0.1)));
  materials.push_back(Material::mirror("mirror", Rgb::Constant(0.9)));
  Rng rng(11, 2);
  for (const Material& m : materials) {
    SCOPED_TRACE(testing::Message()
                 << enum_name(m.type) << " alpha " << m.roughness << " n " << m.exponent);
    int bad = 0, nonzero = 0;
    for (int i = 0; i < 4000; ++i) {
      Vec3 a = uniform_hemisphere(rng.uniform2());
      if (i % 8 == 0) a = polar_dir(89.9, 2 * kPi * rng.uniform());  // grazing
      Vec3 b = uniform_hemisphere(rng.uniform2());
      if (i % 2 == 0 && m.has_lobe() && !m.is_delta()) {  // half the pairs inside the lobe
        LobeSample ls = m.lobe_sample(a, rng.uniform2());
        if (ls.weight > 0.0) b = ls.wi;
      }
      double fab = m.lobe_eval(a, b), fba = m.lobe_eval(b, a);
      // The GGX terms are computed per direction and combined in a different order: a few
      // roundings. Phong raises a rounded cosine c to the power n: relative error n * 3 eps / c.
      double tol = 16 * kEps;
      if (m.type == MaterialType::kPhong) {
        double c = std::max(1e-300, b.dot(reflect_about_normal(a)));
        tol += 3 * m.exponent * kEps / c;
      }
      nonzero += fab > 0.0;
      Rgb eab = m.eval(a, b), eba = m.eval(b, a);
      double err = rel_diff(fab, fba);
      for (int k = 0; k < 3; ++k) err = std::max(err, rel_diff(eab[k], eba[k]));
      // eq. 1: f = diffuse / pi + specular * lobe
      Rgb expect = m.diffuse * kInvPi + m.specular * fab;
      for (int k = 0; k < 3; ++k) err = std::max(err, rel_diff(eab[k], expect[k]) / 4);
      if (!(err <= tol) && ++bad < 4)
        ADD_FAILURE() << "a " << a.transpose() << " b " << b.transpose() << " lobe " << fab
                      << " vs " << fba << " rel " << err;
    }
    EXPECT_EQ(bad, 0);
    if (m.type == MaterialType::kGlossy || m.type == MaterialType::kPhong) {
      EXPECT_GT(nonzero, 1000);  // the pairs did exercise the lobe
    }
  }
}

// ---- energy ----------------------------------------------------------------------------------

// The lobe's directional albedo, integral of lobe * cos, by quadrature: never above 1, for the
// whole grid of parameters and angles down to 0.1 degree above the horizon. Also its pdf
// integrates to at most 1, and lobe_albedo() (importance sampling on a midpoint grid) agrees.
TEST(Brdf, LobeAlbedoNeverAboveOneAndLobeAlbedoAgrees) {
  std::vector<Material> materials;
  for (double a : kRoughness) materials.push_back(ggx(a));
  for (double n : kExponent) materials.push_back(phong(n));
  double worst_quad_error = 0.0, max_albedo = 0.0, max_pdf = 0.0, worst_midpoint = 0.0;
  for (const Material& m : materials) {
    for (double th : kThetaDeg) {
      SCOPED_TRACE(testing::Message() << enum_name(m.type) << " alpha " << m.roughness << " n "
                                      << m.exponent << " theta_o " << th);
      Vec3 wo = polar_dir(th);
      Estimate q = lobe_albedo_quadrature(m, wo);
      Estimate p = lobe_pdf_quadrature(m, wo);
      EXPECT_LT(q.error, 1e-5) << "quadrature did not converge: " << q.value;
      EXPECT_LT(p.error, 1e-5) << "quadrature did not converge: " << p.value;
      worst_quad_error = std::max({worst_quad_error, q.error, p.error});
      max_albedo = std::max(max_albedo, q.value);
      max_pdf = std::max(max_pdf, p.value);
      EXPECT_LE(q.value, 1.0 + q.error);
      EXPECT_GT(q.value, 0.0);
      EXPECT_LE(p.value, 1.0 + p.error);
      // Valid materials: diffuse + specular <= 1. With d = 1 - s the bound is tight.
      for (double spec : {0.25, 0.7, 1.0})
        EXPECT_LE((1.0 - spec) + spec * q.value, 1.0 + spec * q.error) << "specular " << spec;
      // lobe_albedo() is a midpoint rule over side x side strata of the sampler's unit square,
      // not a random estimate, so its error has no variance to derive a bound from. Its
      // integrand, the sample weight, lies in [0, W] (W = 1 for GGX, (n+2)/(n+1) for Phong) and
      // is smooth except across the curve where the sampled direction crosses the horizon. Two
      // monotone pieces of that curve cross at most 4 side strata, each wrong by at most
      // W / side^2: |error| <= 4 W / side, plus the smooth part's O(side^-2).
      const int side = 256;
      double w_max = m.type == MaterialType::kPhong ? (m.exponent + 2) / (m.exponent + 1) : 1.0;
      double mid = m.lobe_albedo(wo, side * side);
      EXPECT_NEAR(mid, q.value, 4 * w_max / side + w_max / (side * side) + q.error);
      worst_midpoint = std::max(worst_midpoint, std::abs(mid - q.value));
      // Phong at normal incidence has no failed samples (the cos^n cap is the hemisphere): the
      // weight is continuous in the square, only its derivative is singular at u = 0 (the
      // sampler's u^(1/(n+1))), and the rule converges at least as 1/side. From side 64 to 256
      // the error then shrinks at least fourfold; asking only twofold, the error at 256 is at
      // most the difference of the two.
      if (m.type == MaterialType::kPhong && th == 0.0) {
        double coarse = m.lobe_albedo(wo, 64 * 64);
        EXPECT_NEAR(mid, q.value, std::abs(mid - coarse) + q.error) << "coarse " << coarse;
      }
    }
  }
  std::printf(
      "lobe albedo grid: max albedo %.12f, max integral of pdf %.12f, worst quadrature "
      "error estimate %.2e, worst |lobe_albedo(256^2) - quadrature| %.2e\n",
      max_albedo, max_pdf, worst_quad_error, worst_midpoint);
}

// ---- sampling --------------------------------------------------------------------------------

struct BinnedTest {
  test::ChiSquare chi;
  double prob_total = 0.0;  // integral of the density over the hemisphere
  double bins_vs_whole = 0.0;
};

// Chi-square of sampled directions (from `draw`, which returns false for a failed sample) against
// `density` integrated over na x np cells of the chart, plus one cell for failed samples.
template <class Draw, class Density>
BinnedTest binned_test(const Chart& ch, const Draw& draw, const Density& density, long n, int na,
                       int np, double extra_prob = 0.0, long extra_count = 0) {
  std::vector<double> prob(static_cast<size_t>(na * np) + 2, 0.0);
  std::vector<long> count(prob.size(), 0);
  for (int i = 0; i < na; ++i)
    for (int j = 0; j < np; ++j)
      prob[static_cast<size_t>(i * np + j)] =
          integrate_cell(ch, density, ch.a_end * i / na, ch.a_end * (i + 1) / na,
                         -kPi + 2 * kPi * j / np, -kPi + 2 * kPi * (j + 1) / np, Rule{1, 4, 8});
  BinnedTest r;
  for (int k = 0; k < na * np; ++k) r.prob_total += prob[static_cast<size_t>(k)];
  r.bins_vs_whole = std::abs(r.prob_total - integrate(ch, density).value);
  prob[prob.size() - 2] = extra_prob;  // e.g. delta samples, counted by the caller
  count[prob.size() - 2] = extra_count;
  prob.back() = std::max(0.0, 1.0 - r.prob_total - extra_prob);  // failed samples
  for (long s = 0; s < n - extra_count; ++s) {
    Vec3 wi;
    if (!draw(&wi)) {
      ++count.back();
      continue;
    }
    double a, phi;
    ch.locate(wi, &a, &phi);
    int i = std::clamp(static_cast<int>(a / ch.a_end * na), 0, na - 1);
    int j = std::clamp(static_cast<int>((phi + kPi) / (2 * kPi) * np), 0, np - 1);
    ++count[static_cast<size_t>(i * np + j)];
  }
  r.chi = test::chi_square(prob, count, n);
  return r;
}

// lobe_sample against lobe_pdf: chi-square over cells of the lobe's chart; every sample's weight
// is lobe_eval * cos / pdf and its pdf is lobe_pdf; the failure rate is 1 - integral of pdf; the
// mean weight is the quadrature albedo within 4 standard errors.
TEST(Brdf, LobeSamplingMatchesPdf) {
  struct Case {
    Material m;
    double theta;
  };
  std::vector<Case> cases;
  for (double a : {0.02, 0.1, 0.4, 1.0})
    for (double th : {0.0, 45.0, 80.0, 89.0}) cases.push_back({ggx(a), th});
  for (double n : {1.0, 8.0, 100.0, 1000.0})
    for (double th : {0.0, 45.0, 80.0, 89.0}) cases.push_back({phong(n), th});
  const long n_samples = 200000;
  int index = 0;
  double min_p = 1.0;
  for (const Case& cs : cases) {
    const Material& m = cs.m;
    SCOPED_TRACE(testing::Message() << enum_name(m.type) << " alpha " << m.roughness << " n "
                                    << m.exponent << " theta_o " << cs.theta);
    Vec3 wo = polar_dir(cs.theta);
    Rng rng(21, static_cast<std::uint64_t>(index++));
    test::Moments weight;
    int bad_weight = 0;
    auto draw = [&](Vec3* wi) {
      LobeSample ls = m.lobe_sample(wo, rng.uniform2());
      weight.add(ls.weight);
      if (ls.delta) ++bad_weight;
      if (ls.weight <= 0.0) return false;
      double pdf = m.lobe_pdf(ls.wi, wo);
      double expect = m.lobe_eval(ls.wi, wo) * ls.wi.z() / pdf;
      if (!(pdf > 0.0 && rel_diff(ls.pdf, pdf) <= 16 * kEps &&
            rel_diff(ls.weight, expect) <= 64 * kEps && std::abs(ls.wi.norm() - 1.0) < 1e-12)) {
        if (++bad_weight < 4)
          ADD_FAILURE() << "wi " << ls.wi.transpose() << " weight " << ls.weight << " vs " << expect
                        << " pdf " << ls.pdf << " vs " << pdf;
      }
      *wi = ls.wi;
      return true;
    };
    Chart ch = lobe_chart(m, wo);
    BinnedTest bt = binned_test(
        ch, draw, [&](const Vec3& wi) { return m.lobe_pdf(wi, wo); }, n_samples, 20, 20);
    EXPECT_EQ(bad_weight, 0);
    EXPECT_LT(bt.bins_vs_whole, 1e-7);  // the cells' rules agree with the whole-domain rule
    EXPECT_LE(bt.prob_total, 1.0 + 1e-7);
    EXPECT_GE(bt.chi.p_value, kChiSquareSignificance)
        << "chi2 " << bt.chi.statistic << " dof " << bt.chi.dof;
    min_p = std::min(min_p, bt.chi.p_value);
    Estimate q = lobe_albedo_quadrature(m, wo);
    EXPECT_NEAR(weight.mean(), q.value, 4 * weight.std_error() + q.error);
  }
  std::printf("lobe sampling: %zu cases, smallest chi-square p-value %.3g\n", cases.size(), min_p);
}

TEST(Brdf, PhongLobeVanishesBeyondTheMirrorHemisphere) {
  // lobe_sample draws only around the mirror direction r, so eval and pdf must be zero where
  // wi . r < 0, for n = 0 too (pow(0, 0) = 1 once made them 1/pi and 1/(2 pi) there).
  const Vec3 wo = polar_dir(60.0);
  const Vec3 wi = wo;  // back toward the viewer: wi . r = cos(120 deg)
  ASSERT_GT(wi.z(), 0.0);
  ASSERT_LT(wi.dot(reflect_about_normal(wo)), 0.0);
  for (double n : {0.0, 1.0, 8.0}) {
    Material m = phong(n);
    EXPECT_EQ(m.lobe_eval(wi, wo), 0.0) << n;
    EXPECT_EQ(m.lobe_pdf(wi, wo), 0.0) << n;
  }
}

// The whole BRDF: sample() against pdf() (plus the delta cell), weights eval * cos / pdf, the mean
// weight equals diffuse + specular * lobe albedo per channel, and eval integrates to the same.
TEST(Brdf, BsdfSamplingMatchesPdf) {
  const Rgb d(0.5, 0.3, 0.2), s(0.4, 0.6, 0.3);  // coloured: selection goes by luminance
  std::vector<Material> materials = {
      Material::lambert("white", Rgb(0.8, 0.6, 0.4)),
      Material::glossy("gloss", d, s, 0.3),
      Material::glossy("gloss", d, s, 0.6),
      Material::phong("phong", d, s, 5),
      Material::phong("phong", d, s, 40),
      Material::mirror("mirror", Rgb(0.9, 0.8, 0.7)),
      Material::glossy("near-mirror", d, s, 0.5 * Material::kDeltaRoughness),
      Material::glossy("dark-diffuse", Rgb::Zero(), s, 0.3),
  };
  const long n_samples = 200000;
  int index = 0;
  double min_p = 1.0;
  for (const Material& m : materials) {
    for (double th : {0.0, 50.0, 85.0}) {
      SCOPED_TRACE(testing::Message() << m.name << " alpha " << m.roughness << " n " << m.exponent
                                      << " theta_o " << th);
      Vec3 wo = polar_dir(th);
      Vec3 r = reflect_about_normal(wo);
      double p_lobe = m.lobe_probability();
      // brdf.h: the lobe is picked by luminance of the two reflectances.
      double ls = luminance(m.specular), ld = luminance(m.diffuse);
      EXPECT_NEAR(p_lobe, m.has_lobe() ? ls / (ls + ld) : 0.0, 4 * kEps);
      Chart ch = Chart::around(Vec3::UnitZ(), Warp::cap_power(0.5 * kPi, 1.0));
      if (!m.is_delta() && m.type == MaterialType::kGlossy)
        ch = Chart::half_vector(wo, Warp::ggx(m.roughness));
      if (m.type == MaterialType::kPhong)
        ch = Chart::around(r,
                           Warp::cap_power(kPi - std::atan2(r.z(), std::hypot(r.x(), r.y())), 2.0));
      Rng rng(31, static_cast<std::uint64_t>(index++));
      // Delta samples first, so that the binned test knows their count.
      std::vector<BsdfSample> samples(static_cast<size_t>(n_samples));
      long n_delta = 0;
      for (auto& bs : samples) {
        double u_select = rng.uniform();
        bs = m.sample(wo, u_select, rng.uniform2());
        n_delta += bs.delta;
      }
      test::Moments w[3];
      int bad = 0;
      for (const BsdfSample& bs : samples) {
        for (int k = 0; k < 3; ++k) w[k].add(bs.weight[k]);
        bool ok = true;
        if (bs.delta) {
          ok = m.is_delta() && (bs.wi - r).norm() < 1e-15 && bs.pdf == p_lobe &&
               ((bs.weight - m.specular / p_lobe).abs() <= 4 * kEps).all();
        } else if (bs.pdf > 0.0) {
          Rgb expect = m.eval(bs.wi, wo) * bs.wi.z() / m.pdf(bs.wi, wo);
          for (int k = 0; k < 3; ++k) ok = ok && rel_diff(bs.weight[k], expect[k]) <= 16 * kEps;
          ok = ok && rel_diff(bs.pdf, m.pdf(bs.wi, wo)) <= 16 * kEps && bs.wi.z() > 0.0 &&
               std::abs(bs.wi.norm() - 1.0) < 1e-12;
        } else {
          ok = (bs.weight == 0.0).all();
        }
        if (!ok && ++bad < 4)
          ADD_FAILURE() << "wi " << bs.wi.transpose() << " weight " << bs.weight.transpose()
                        << " pdf " << bs.pdf << " delta " << bs.delta;
      }
      EXPECT_EQ(bad, 0);
      size_t next = 0;
      auto draw = [&](Vec3* wi) {
        while (samples[next].delta) ++next;
        const BsdfSample& bs = samples[next++];
        *wi = bs.wi;
        return bs.pdf > 0.0;
      };
      BinnedTest bt = binned_test(
          ch, draw, [&](const Vec3& wi) { return m.pdf(wi, wo); }, n_samples, 20, 20,
          m.is_delta() ? p_lobe : 0.0, n_delta);
      EXPECT_LT(bt.bins_vs_whole, 1e-7);
      EXPECT_LE(bt.prob_total, 1.0 - (m.is_delta() ? p_lobe : 0.0) + 1e-7);
      EXPECT_GE(bt.chi.p_value, kChiSquareSignificance)
          << "chi2 " << bt.chi.statistic << " dof " << bt.chi.dof;
      min_p = std::min(min_p, bt.chi.p_value);
      // Albedo: diffuse + specular * lobe albedo, the lobe by its own chart.
      double lobe = m.is_delta() ? 1.0 : 0.0;
      double lobe_err = 0.0;
      if (m.has_lobe() && !m.is_delta()) {
        Estimate q = lobe_albedo_quadrature(m, wo);
        lobe = q.value;
        lobe_err = q.error;
      }
      Rgb albedo = m.diffuse;
      if (m.has_lobe()) albedo += m.specular * lobe;
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(w[k].mean(), albedo[k],
                    4 * w[k].std_error() + lobe_err + n_samples * kEps)  // + rounding of the sum
            << "channel " << k;
        EXPECT_LE(albedo[k], 1.0 + lobe_err);
        // eval() integrated in the binning chart gives the same (the delta part aside).
        Estimate e = integrate(ch, [&](const Vec3& wi) { return m.eval(wi, wo)[k] * wi.z(); });
        double expect = albedo[k] - (m.is_delta() ? m.specular[k] : 0.0);
        EXPECT_LT(e.error, 1e-6);
        EXPECT_NEAR(e.value, expect, e.error + m.specular[k] * lobe_err) << "channel " << k;
      }
    }
  }
  std::printf("bsdf sampling: %zu cases, smallest chi-square p-value %.3g\n", 3 * materials.size(),
              min_p);
}

// ---- the mirror limit ------------------------------------------------------------------------

// Tail of the GGX visible-normal distribution: P(tan(theta_h) > t) is at most
// (1 / cos(theta_o)) * integral over tan(theta_h) > t of D dw_h
//   = (1 / cos(theta_o)) * int_t^inf 2 a^2 x sqrt(1 + x^2) / (a^2 + x^2)^2 dx
//  <= (a^2 / (a^2 + t^2) + 2 a^2 / t) / cos(theta_o)        (sqrt(1 + x^2) <= 1 + x),
// since G1 <= 1 and wo.h <= 1.
double vndf_tail_bound(double alpha, double cos_o, double t) {
  return (alpha * alpha / (alpha * alpha + t * t) + 2 * alpha * alpha / t) / cos_o;
}

// Reflection about h is reflection about z followed by a rotation by 2 theta_h, so
// angle(wi, mirror direction) <= 2 theta_h. Samples farther than eps from the mirror direction,
// failed ones included when eps < 90 deg - theta_o, have tan(theta_h) > tan(eps / 2).
TEST(Brdf, GgxSamplesConcentrateOnTheMirrorDirection) {
  const long n = 20000;
  int index = 0;
  for (double alpha : {0.03, 0.01, 0.003, 0.001}) {
    for (double th : {0.0, 30.0, 60.0}) {
      SCOPED_TRACE(testing::Message() << "alpha " << alpha << " theta_o " << th);
      Material m = ggx(alpha);
      ASSERT_FALSE(m.is_delta());
      Vec3 wo = polar_dir(th);
      Vec3 r = reflect_about_normal(wo);
      Rng rng(41, static_cast<std::uint64_t>(index++));
      const double eps = 0.05;  // a fixed cone of about 3 degrees
      ASSERT_LT(std::max(eps, 10 * alpha), deg(90 - th));
      long outside = 0, outside_rel = 0;
      for (long i = 0; i < n; ++i) {
        LobeSample ls = m.lobe_sample(wo, rng.uniform2());
        double ang = ls.weight > 0.0 ? angle_between(ls.wi, r) : kPi;
        outside += ang > eps;
        outside_rel += ang > 10 * alpha;
      }
      for (auto [cone, count] : {std::pair{eps, outside}, std::pair{10 * alpha, outside_rel}}) {
        double bound = std::min(1.0, vndf_tail_bound(alpha, wo.z(), std::tan(0.5 * cone)));
        double frac = static_cast<double>(count) / n;
        EXPECT_LE(frac, bound + 4 * std::sqrt(bound * (1 - bound) / n))
            << "cone " << cone << " bound " << bound;
      }
      // In the fixed cone the bound itself goes to 0 with alpha.
      if (alpha <= 0.001) {
        EXPECT_LT(static_cast<double>(outside) / n, 0.005);
      }
    }
  }
}

// 1 - albedo <= P(theta_h > theta_c) + max over theta_h <= theta_c of (1 - G2/G1(wo)), and
// 1 - G2/G1 = Lambda_i / (1 + Lambda_i + Lambda_o) <= Lambda_i <= alpha^2 tan^2(theta_i) / 4
// with theta_i <= theta_o + 2 theta_c. With theta_c = sqrt(alpha) (once below a quarter of the
// angle to the horizon) the bound goes to 0.
TEST(Brdf, GgxAlbedoTendsToOneAsRoughnessVanishes) {
  for (double th : {0.0, 30.0, 60.0}) {
    double previous_deficit = 1.0;
    for (double alpha : {0.1, 0.03, 0.01, 0.003, 0.001}) {
      SCOPED_TRACE(testing::Message() << "alpha " << alpha << " theta_o " << th);
      Vec3 wo = polar_dir(th);
      Estimate q = lobe_albedo_quadrature(ggx(alpha), wo);
      ASSERT_LT(q.error, 1e-5);
      double theta_c = std::min(std::sqrt(alpha), 0.25 * (0.5 * kPi - deg(th)));
      double theta_i = deg(th) + 2 * theta_c;
      ASSERT_LT(theta_i, 0.5 * kPi);
      double bound = vndf_tail_bound(alpha, wo.z(), std::tan(theta_c)) +
                     alpha * alpha * std::pow(std::tan(theta_i), 2) / 4;
      double deficit = 1.0 - q.value;
      EXPECT_GE(deficit, -q.error);
      EXPECT_LE(deficit, bound + q.error);
      EXPECT_LE(deficit, previous_deficit + q.error);  // monotone toward the mirror
      previous_deficit = deficit;
    }
  }
}

TEST(Brdf, RoughnessBelowThresholdIsDelta) {
  Rng rng(51);
  for (double alpha :
       {0.0, 1e-6, 0.5 * Material::kDeltaRoughness, 0.999 * Material::kDeltaRoughness}) {
    Material m = ggx(alpha, 0.2, 0.7);
    EXPECT_TRUE(m.is_delta()) << alpha;
    for (double th : {0.0, 30.0, 70.0, 89.9}) {
      Vec3 wo = polar_dir(th);
      LobeSample ls = m.lobe_sample(wo, rng.uniform2());
      EXPECT_TRUE(ls.delta);
      EXPECT_LT((ls.wi - reflect_about_normal(wo)).norm(), 1e-15);
      EXPECT_EQ(ls.weight, 1.0);
      EXPECT_EQ(m.lobe_albedo(wo, 16), 1.0);
      Vec3 wi = uniform_hemisphere(rng.uniform2());
      EXPECT_EQ(m.lobe_eval(wi, wo), 0.0);
      EXPECT_EQ(m.lobe_eval(reflect_about_normal(wo), wo), 0.0);
      EXPECT_EQ(m.lobe_pdf(reflect_about_normal(wo), wo), 0.0);
      // The whole BRDF keeps only its diffuse part off the delta.
      EXPECT_NEAR(m.eval(wi, wo)[0], 0.2 * kInvPi, 1e-15);
    }
  }
  // At the threshold the lobe is a real, very narrow GGX lobe whose albedo is that of the mirror
  // up to the bound of GgxAlbedoTendsToOneAsRoughnessVanishes (about 2e-3 at 45 degrees).
  Material m = ggx(Material::kDeltaRoughness);
  EXPECT_FALSE(m.is_delta());
  Vec3 wo = polar_dir(45);
  LobeSample ls = m.lobe_sample(wo, Vec2(0.3, 0.6));
  EXPECT_FALSE(ls.delta);
  EXPECT_GT(ls.weight, 0.0);
  Estimate q = lobe_albedo_quadrature(m, wo);
  // theta_c = sqrt(0.001), theta_i <= 45 deg + 2 theta_c, tan^2(theta_i) < 2.
  EXPECT_NEAR(
      q.value, 1.0,
      vndf_tail_bound(0.001, wo.z(), std::tan(std::sqrt(0.001))) + 0.001 * 0.001 * 2 / 4 + q.error);
}

}  // namespace
}  // namespace polyrad
