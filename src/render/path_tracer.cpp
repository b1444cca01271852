// The path-traced reference (path_tracer.h).
#include "polyrad/render/path_tracer.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "polyrad/util/error.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace {

// The path tracer draws lights by emitted power: luminance(emission) * area.
std::vector<double> emitted_power(const PatchSet& patches, const std::vector<Material>& materials) {
  std::vector<double> weight(patches.size(), 0.0);
  for (size_t p = 0; p < patches.size(); ++p) {
    const Patch& q = patches[p];
    POLYRAD_CHECK(q.material >= 0 && q.material < static_cast<MaterialId>(materials.size()));
    weight[p] = std::max(0.0, luminance(q.emission.max(0.0)) * q.area);
  }
  return weight;
}

}  // namespace

PathTracer::PathTracer(const World& world)
    : patches_(world.patches()),
      materials_(world.materials()),
      caster_(world.caster()),
      lights_(world.patches(), emitted_power(world.patches(), world.materials())) {}

Rgb PathTracer::radiance(const Vec3& origin, const Vec3& direction, Rng& rng,
                         const PathTraceOptions& o, PathStats* stats) const {
  PathStats local;
  local.paths = 1;
  Rgb sum = Rgb::Zero();
  Rgb beta = Rgb::Ones();  // path throughput: product of f cos / pdf (and 1 / roulette survival)
  Vec3 ray_origin = origin, ray_dir = direction;
  PatchId from = -1;         // the patch the ray leaves (-1: the camera)
  bool delta_before = true;  // the camera ray counts emission fully, as a delta bounce does
  double bsdf_pdf = 0.0;     // solid-angle density of the BSDF sample that made this ray
  const bool nee = o.next_event && !lights_.empty();

  for (int segments = 1;; ++segments) {
    Hit hit = from < 0 ? caster_.intersect(ray_origin, ray_dir)
                       : caster_.intersect_from(ray_origin, from, ray_dir);
    ++local.rays;
    if (!hit.valid() || !hit.front) break;  // left the scene, or met a back side (black)
    const Patch& p = patches_[hit.patch];
    const Vec3 x = hit.position;

    // Emission met by the ray. After a non-delta bounce this path could also have come from
    // the light sample at the previous vertex, so it takes the BSDF strategy's MIS weight.
    if (lights_.select_pdf(hit.patch) > 0.0) {
      double w = 1.0;
      if (nee && !delta_before) {
        double cos_y = -ray_dir.dot(p.normal);
        double light_pdf = lights_.area_pdf(hit.patch, x) * hit.t * hit.t / cos_y;
        w = power_heuristic(bsdf_pdf, light_pdf);
      }
      sum += beta * p.emission * w;
    }
    const Material& m = materials_[p.material];
    if (segments >= o.max_depth) {
      // Cut while it could still gather light: a black surface would have ended it anyway.
      if (beta.maxCoeff() > 0.0 && m.albedo_bound().maxCoeff() > 0.0) ++local.truncated;
      break;
    }

    const Frame frame = Frame::from_normal(p.normal);
    const Vec3 wo = frame.to_local(-ray_dir);
    if (wo.z() <= 0.0) break;

    // Next-event estimation of the non-delta part of the BRDF (a delta lobe cannot meet a
    // sampled light point with non-zero probability).
    bool smooth = m.diffuse.maxCoeff() > 0.0 || (m.has_lobe() && !m.is_delta());
    if (nee && smooth) {
      double u_select = rng.uniform();
      Vec2 u_point = rng.uniform2();
      const LightSample ls = lights_.sample(u_select, u_point);
      const PatchId lp = ls.patch;
      const Patch& light = patches_[lp];
      const Vec3& y = ls.point;
      Vec3 d = y - x;
      double dist2 = d.squaredNorm();
      double dist = std::sqrt(dist2);
      Vec3 wi = d / dist;
      double cos_x = wi.dot(p.normal), cos_y = -wi.dot(light.normal);
      if (dist > 0.0 && cos_x > 0.0 && cos_y > 0.0 && ls.area_pdf > 0.0) {
        Vec3 wi_local = frame.to_local(wi);
        Rgb f = m.eval(wi_local, wo);
        if (f.maxCoeff() > 0.0) {
          ++local.rays;
          if (!caster_.segment_occluded(x, hit.patch, y, lp)) {
            // The area density of y in solid angle: times dist^2 / cos_y.
            double light_pdf = ls.area_pdf * dist2 / cos_y;
            double w = power_heuristic(light_pdf, m.pdf(wi_local, wo));
            sum += beta * f * light.emission * (cos_x * w / light_pdf);
          }
        }
      }
    }

    // Continue the path by sampling the whole BRDF.
    // The point first, then the choice of lobe (one draw a statement: a call's arguments are
    // unsequenced; this is the order GCC gave every reference measured before).
    const Vec2 u_point = rng.uniform2();
    const double u_lobe = rng.uniform();
    BsdfSample s = m.sample(wo, u_lobe, u_point);
    if (!(s.weight.maxCoeff() > 0.0)) break;
    beta *= s.weight;
    delta_before = s.delta;
    bsdf_pdf = s.pdf;
    ray_origin = x;
    ray_dir = frame.to_world(s.wi).normalized();
    from = hit.patch;

    // Russian roulette: continue with probability q and divide by it, E[beta'] = beta.
    if (segments >= o.roulette_depth) {
      double q = std::min(1.0, beta.maxCoeff());
      if (rng.uniform() >= q) break;
      beta /= q;
    }
  }
  if (stats) stats->add(local);
  return sum;
}

PathTraceResult PathTracer::render(const Camera& camera, const PathTraceOptions& o) const {
  if (o.spp < 1) throw InputError("path tracer: spp must be at least 1");
  if (o.max_depth < 1) throw InputError("path tracer: max_depth must be at least 1");
  if (o.tile < 1) throw InputError("path tracer: tile must be at least 1");
  const Stopwatch watch;
  const int w = camera.width, h = camera.height;
  PathTraceResult result;
  result.image = Image(w, h);
  const bool want_error = o.standard_error && o.spp > 1;
  if (want_error) result.standard_error = Image(w, h);

  const int tiles_x = (w + o.tile - 1) / o.tile, tiles_y = (h + o.tile - 1) / o.tile;
  const int tiles = tiles_x * tiles_y;
  std::unique_ptr<Progress> progress;
  if (o.progress) progress = std::make_unique<Progress>("path tracing", tiles);
  long long paths = 0, rays = 0, truncated = 0;

#pragma omp parallel for schedule(dynamic, 1) reduction(+ : paths, rays, truncated)
  for (int tile = 0; tile < tiles; ++tile) {
    const int x0 = (tile % tiles_x) * o.tile, y0 = (tile / tiles_x) * o.tile;
    const int x1 = std::min(w, x0 + o.tile), y1 = std::min(h, y0 + o.tile);
    PathStats stats;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const std::uint64_t pixel = static_cast<std::uint64_t>(y) * w + x;
        // Welford's running mean and sum of squared deviations, per channel.
        Rgb mean = Rgb::Zero(), m2 = Rgb::Zero();
        for (int s = 0; s < o.spp; ++s) {
          Rng rng(o.seed, pixel, static_cast<std::uint64_t>(s));
          double jx = rng.uniform(), jy = rng.uniform();
          Ray ray = camera.ray(x + jx, y + jy);
          Rgb l = radiance(ray.origin, ray.direction, rng, o, &stats);
          Rgb delta = l - mean;
          mean += delta / (s + 1);
          m2 += delta * (l - mean);
        }
        result.image.set(x, y, mean);
        if (want_error) result.standard_error.set(x, y, (m2 / ((o.spp - 1.0) * o.spp)).sqrt());
      }
    paths += stats.paths;
    rays += stats.rays;
    truncated += stats.truncated;
    if (progress) progress->advance();
  }
  if (progress) progress->finish();
  result.stats.paths = paths;
  result.stats.rays = rays;
  result.stats.truncated = truncated;
  result.seconds = watch.seconds();
  return result;
}

}  // namespace polyrad
