// Image comparison (image_compare.h).
#include "polyrad/render/image_compare.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "polyrad/util/error.h"

namespace polyrad {

namespace {

void check_same_size(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height)
    throw InputError("the images differ in size: " + std::to_string(a.width) + "x" +
                     std::to_string(a.height) + " and " + std::to_string(b.width) + "x" +
                     std::to_string(b.height));
}

double relative(double a, double b) {
  if (b != 0.0) return (a - b) / b;
  return a == 0.0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
}

Rgb image_mean(const Image& img) {
  Rgb s = Rgb::Zero();
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) s += img.at(x, y);
  double n = std::max(1.0, static_cast<double>(img.width) * img.height);
  return s / n;
}

double srgb_decode(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// Diverging colour map in sRGB, t in [-1, 1]: blue - white - red.
Rgb diverging(double t) {
  const Rgb white(1.0, 1.0, 1.0), red(0.70, 0.02, 0.15), blue(0.23, 0.30, 0.75);
  t = std::clamp(t, -1.0, 1.0);
  Rgb c = t >= 0.0 ? Rgb((1.0 - t) * white + t * red) : Rgb((1.0 + t) * white - t * blue);
  return Rgb(srgb_decode(c[0]), srgb_decode(c[1]), srgb_decode(c[2]));
}

}  // namespace

RegionMap object_regions(const World& world) {
  const Scene& scene = world.scene();
  const PatchSet& patches = world.patches();
  const RayCaster& caster = world.caster();
  const Camera& cam = scene.camera;
  RegionMap map;
  map.width = cam.width;
  map.height = cam.height;
  map.label.assign(static_cast<size_t>(cam.width) * cam.height, -1);
  for (const auto& o : scene.objects) map.names.push_back(o.name);
  // The object each pixel centre sees; then a pixel belongs to a region only if its 3 x 3
  // neighbourhood sees the same object. Pixels on an edge mix two objects however thin the
  // sliver (a lamp's edge pixel carries part of the lamp's radiance), and renderers that cover
  // a pixel differently would disagree there; the margin drops them whatever their coverage.
  std::vector<int> centre(map.label.size(), -1);
#pragma omp parallel for schedule(dynamic, 4)
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Ray r = cam.ray(x + 0.5, y + 0.5);
      Hit h = caster.intersect(r.origin, r.direction);
      if (h.valid() && h.front)
        centre[static_cast<size_t>(y) * cam.width + x] = patches[h.patch].object;
    }
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      int label = centre[static_cast<size_t>(y) * cam.width + x];
      for (int dy = -1; dy <= 1 && label >= 0; ++dy)
        for (int dx = -1; dx <= 1 && label >= 0; ++dx) {
          int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= cam.width || ny >= cam.height) continue;
          if (centre[static_cast<size_t>(ny) * cam.width + nx] != label) label = -1;
        }
      map.label[static_cast<size_t>(y) * cam.width + x] = label;
    }
  return map;
}

ImageComparison compare_images(const Image& a, const Image& b, const CompareOptions& options,
                               const RegionMap* regions) {
  check_same_size(a, b);
  if (!a.all_finite()) throw InputError("the first image has non-finite pixels");
  if (!b.all_finite()) throw InputError("the second image has non-finite pixels");
  if (regions && (regions->width != a.width || regions->height != a.height))
    throw InputError("the scene's camera is " + std::to_string(regions->width) + "x" +
                     std::to_string(regions->height) + " but the images are " +
                     std::to_string(a.width) + "x" + std::to_string(a.height));
  ImageComparison c;
  c.width = a.width;
  c.height = a.height;
  c.mean_a = image_mean(a);
  c.mean_b = image_mean(b);
  c.epsilon = options.epsilon_fraction * c.mean_b;
  const double lum_eps = options.epsilon_fraction * luminance(c.mean_b);
  const Rgb eps2 = c.epsilon.square();

  const size_t n = static_cast<size_t>(a.width) * a.height;
  size_t nregions = regions ? regions->names.size() : 0;
  std::vector<Rgb> sum_a(nregions, Rgb::Zero()), sum_b(nregions, Rgb::Zero());
  std::vector<long long> count(nregions, 0);
  std::vector<double> region_diff(nregions, 0.0), region_base(nregions, 0.0);
  double rel2 = 0.0, rel1 = 0.0, norm2 = 0.0, l1_diff = 0.0, l1_base = 0.0;
  std::vector<PixelError> pixels;
  pixels.reserve(n);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      Rgb va = a.at(x, y), vb = b.at(x, y), d = va - vb;
      for (int k = 0; k < 3; ++k) {
        if (eps2[k] > 0.0 || vb[k] != 0.0)
          rel2 += d[k] * d[k] / (vb[k] * vb[k] + eps2[k]);
        else if (d[k] != 0.0)
          rel2 = std::numeric_limits<double>::infinity();
        double den = std::abs(vb[k]) + c.epsilon[k];
        if (den > 0.0)
          rel1 += std::abs(d[k]) / den;
        else if (d[k] != 0.0)
          rel1 = std::numeric_limits<double>::infinity();
        l1_diff += std::abs(d[k]);
        l1_base += std::abs(vb[k]);
        if (c.mean_b[k] != 0.0)
          norm2 += d[k] * d[k] / (c.mean_b[k] * c.mean_b[k]);
        else if (d[k] != 0.0)
          norm2 = std::numeric_limits<double>::infinity();
      }
      double lb = luminance(vb), la = luminance(va);
      double den = lb + lum_eps;
      double e = den > 0.0 ? (la - lb) / den : (la == lb ? 0.0 : la - lb);
      pixels.push_back({x, y, va, vb, e});
      if (regions) {
        int label = regions->label[static_cast<size_t>(y) * a.width + x];
        if (label < 0 || static_cast<size_t>(label) >= nregions) {
          ++c.pixels_without_region;
        } else {
          sum_a[label] += va;
          sum_b[label] += vb;
          ++count[label];
          region_diff[label] += d.abs().sum();
          region_base[label] += vb.abs().sum();
        }
      }
    }
  double samples = 3.0 * std::max<size_t>(n, 1);
  c.relative_rmse = std::sqrt(rel2 / samples);
  c.mean_relative_error = rel1 / samples;
  c.normalized_rmse = std::sqrt(norm2 / samples);
  c.relative_l1 = l1_base > 0.0 ? l1_diff / l1_base : (l1_diff > 0.0 ? INFINITY : 0.0);

  for (size_t r = 0; r < nregions; ++r) {
    if (count[r] == 0) continue;
    RegionFigures f;
    f.name = regions->names[r];
    f.pixels = count[r];
    f.mean_a = sum_a[r] / count[r];
    f.mean_b = sum_b[r] / count[r];
    for (int k = 0; k < 3; ++k) f.relative_difference[k] = relative(f.mean_a[k], f.mean_b[k]);
    f.luminance_difference = relative(luminance(f.mean_a), luminance(f.mean_b));
    f.relative_l1 = region_base[r] > 0.0 ? region_diff[r] / region_base[r] : std::nan("");
    double m = std::abs(f.luminance_difference);
    if (std::isnan(m) || m > c.worst_region_difference)
      c.worst_region_difference = std::isnan(m) ? std::numeric_limits<double>::infinity() : m;
    c.regions.push_back(f);
  }

  size_t k =
      std::min<size_t>(pixels.size(), static_cast<size_t>(std::max(0, options.worst_pixels)));
  // Ties broken by position so that the list does not depend on the sort's implementation.
  auto worse = [](const PixelError& p, const PixelError& q) {
    double ep = std::abs(p.error), eq = std::abs(q.error);
    if (ep != eq) return ep > eq;
    return p.y != q.y ? p.y < q.y : p.x < q.x;
  };
  std::partial_sort(pixels.begin(), pixels.begin() + static_cast<std::ptrdiff_t>(k), pixels.end(),
                    worse);
  c.worst.assign(pixels.begin(), pixels.begin() + static_cast<std::ptrdiff_t>(k));
  return c;
}

Image error_picture(const Image& a, const Image& b, double scale, double epsilon_fraction) {
  check_same_size(a, b);
  if (!(scale > 0.0)) throw InputError("the error scale must be positive");
  const double lum_eps = epsilon_fraction * luminance(image_mean(b));
  Image out(a.width, a.height);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      Rgb va = a.at(x, y), vb = b.at(x, y);
      if ((va == 0.0).all() && (vb == 0.0).all()) continue;  // nothing to compare: black
      double la = luminance(va), lb = luminance(vb);
      double den = lb + lum_eps;
      double e = den > 0.0 ? (la - lb) / den : (la > lb ? 1.0 : -1.0) * scale;
      out.set(x, y, diverging(e / scale));
    }
  return out;
}

Image side_by_side(const Image& a, const Image& b, const Image& error, double exposure, int gap) {
  check_same_size(a, b);
  check_same_size(a, error);
  gap = std::max(0, gap);
  const int w = a.width, h = a.height;
  Image out(3 * w + 2 * gap, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      out.set(x, y, a.at(x, y) * exposure);
      out.set(w + gap + x, y, b.at(x, y) * exposure);
      out.set(2 * (w + gap) + x, y, error.at(x, y));
    }
  return out;
}

}  // namespace polyrad
