// Camera gather (camera_gather.h).
#include "polyrad/render/camera_gather.h"

#include <algorithm>
#include <cmath>

#include "polyrad/scene/brdf.h"
#include "polyrad/transport/hierarchy.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"
#include "polyrad/world/light_sampling.h"

namespace polyrad {

namespace {

struct Term {
  std::int32_t column;
  Rgbf w;
};

// For smooth shading: each patch corner as a weighted average of patches (same object, normals
// within 10 degrees) that share the welded corner.
class CornerAverages {
 public:
  // Weights are the exposed areas (flux weights / pi): a buried patch does not darken its
  // neighbours' corners.
  CornerAverages(const PatchSet& patches, const std::vector<double>& flux_weight)
      : patches_(patches) {
    std::vector<std::vector<PatchId>> by_vertex(patches.vertex_ids);
    for (PatchId p = 0; p < static_cast<PatchId>(patches.size()); ++p)
      for (int c = 0; c < patches[p].corners; ++c) {
        auto& list = by_vertex[patches[p].vertex_id[c]];
        if (list.empty() || list.back() != p) list.push_back(p);
      }
    start_.assign(4 * patches.size() + 1, 0);
    for (PatchId p = 0; p < static_cast<PatchId>(patches.size()); ++p) {
      for (int c = 0; c < 4; ++c) {
        const auto& list = by_vertex[patches[p].vertex_id[std::min(c, patches[p].corners - 1)]];
        double total = 0.0;
        size_t first = entries_.size();
        for (PatchId q : list) {
          if (patches[q].normal.dot(patches[p].normal) < std::cos(10.0 * kPi / 180.0)) continue;
          entries_.push_back({q, flux_weight[q]});
          total += flux_weight[q];
        }
        for (size_t e = first; e < entries_.size(); ++e)
          entries_[e].second = total > 0.0 ? entries_[e].second / total : 0.0;
        start_[4 * p + c + 1] = entries_.size();
      }
    }
  }

  // Adds w * (smoothly interpolated B at (u, v) on p) to terms.
  void add(PatchId p, double u, double v, const Rgbf& w, std::vector<Term>& terms) const {
    auto cw = patches_[p].corner_weights(u, v);
    for (int c = 0; c < 4; ++c) {
      if (cw[c] == 0.0) continue;
      for (auto e = start_[4 * p + c]; e < start_[4 * p + c + 1]; ++e) {
        float s = static_cast<float>(cw[c] * entries_[e].second);
        terms.push_back({entries_[e].first, {w[0] * s, w[1] * s, w[2] * s}});
      }
    }
  }

 private:
  const PatchSet& patches_;
  std::vector<std::size_t> start_;
  std::vector<std::pair<PatchId, double>> entries_;
};

Rgbf scaled(const Rgb& c, double s) {
  return {static_cast<float>(c[0] * s), static_cast<float>(c[1] * s), static_cast<float>(c[2] * s)};
}

class PixelGatherer {
 public:
  PixelGatherer(const Camera& camera, const PatchSet& patches,
                const std::vector<Material>& materials, const RayCaster& caster,
                const UnknownLayout& t, const GatherOptions& o, const CornerAverages& corners,
                const LightSampler& lights)
      : camera_(camera),
        patches_(patches),
        materials_(materials),
        caster_(caster),
        t_(t),
        o_(o),
        corners_(corners),
        lights_(lights) {}

  // The terms of pixel (x, y); returns the number of rays cast.
  long long gather(int x, int y, std::vector<Term>& terms) const {
    terms.clear();
    long long rays = 0;
    int n = o_.pixel_grid;
    double share = 1.0 / (n * n);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        Ray ray = camera_.ray(x + (a + 0.5) / n, y + (b + 0.5) / n);
        ++rays;
        Hit hit = caster_.intersect(ray.origin, ray.direction);
        if (!hit.valid() || !hit.front) continue;
        add_diffuse(hit.patch, hit.u, hit.v, Rgbf{float(share), float(share), float(share)}, terms);
        const Material& m = materials_[patches_[hit.patch].material];
        if (!m.has_lobe()) continue;
        const Frame frame = Frame::from_normal(patches_[hit.patch].normal);
        const Shading sh{
            hit.patch, m, frame, ray.origin + hit.t * ray.direction, frame.to_local(-ray.direction),
            share};
        Rng rng(o_.seed, static_cast<std::uint64_t>(y) * camera_.width + x, a * n + b);
        rays += add_lobe_samples(sh, rng, terms);
        rays += add_light_samples(sh, rng, terms);
      }
    return rays;
  }

 private:
  // A primary hit whose material has a lobe.
  struct Shading {
    PatchId i;
    const Material& m;
    Frame frame;
    Vec3 x, wo;    // the point, and the direction to the camera (local frame)
    double share;  // the sub-pixel ray's share of the pixel
  };

  bool light_sampled(const Material& m) const {
    return o_.light_samples > 0 && !lights_.empty() && !m.is_delta();
  }
  // The lobe samples form a side x side grid (one sample for a delta lobe).
  int lobe_side(const Material& m) const {
    return m.is_delta() ? 1
                        : std::max(1, static_cast<int>(std::lround(std::sqrt(o_.lobe_samples))));
  }

  void add_diffuse(PatchId p, double u, double v, const Rgbf& w, std::vector<Term>& terms) const {
    if (const ElementHierarchy* h =
            t_.hierarchy.get()) {  // the leaf (or its corners) under the hit
      thread_local std::vector<std::pair<std::int32_t, double>> weights;
      weights.clear();
      h->diffuse_weights(p, u, v, o_.diffuse == DiffuseMode::kSmooth, weights);
      for (const auto& [leaf, s] : weights)
        terms.push_back({leaf,
                         {static_cast<float>(w[0] * s), static_cast<float>(w[1] * s),
                          static_cast<float>(w[2] * s)}});
      return;
    }
    if (o_.diffuse == DiffuseMode::kSmooth)
      corners_.add(p, u, v, w, terms);
    else
      terms.push_back({p, w});
  }
  // Radiance arriving at i from point (u, v) of patch j, times w: w (B_j + S_{j->i}).
  void add_arriving(PatchId j, double u, double v, PatchId i, const Rgbf& w,
                    std::vector<Term>& terms) const {
    add_diffuse(j, u, v, w, terms);
    Eigen::Index link = t_.link_unknown(j, i);
    if (link >= 0) terms.push_back({static_cast<std::int32_t>(link), w});
  }

  // The lobe strategy: s_i beta (B_j + S_{j->i}) for j met along a stratified lobe sample. Where
  // lights are also sampled, a lobe sample that meets a light takes its power-heuristic weight.
  long long add_lobe_samples(const Shading& sh, Rng& rng, std::vector<Term>& terms) const {
    const int side = lobe_side(sh.m), count = side * side;
    const bool mis = light_sampled(sh.m);
    long long rays = 0;
    for (int s = 0; s < count; ++s) {
      // One draw a statement (a call's arguments are unsequenced), second coordinate first:
      // the order GCC gave the figures measured before the draws were written out.
      const double jy = rng.uniform(), jx = rng.uniform();
      Vec2 u((s % side + jx) / side, (s / side + jy) / side);
      LobeSample ls = sh.m.lobe_sample(sh.wo, u);
      if (ls.weight <= 0.0) continue;
      Vec3 dir = sh.frame.to_world(ls.wi);
      ++rays;
      Hit h = caster_.intersect_from(sh.x, sh.i, dir);
      if (!h.valid() || !h.front) continue;
      double w = ls.weight;
      if (mis && lights_.select_pdf(h.patch) > 0.0) {
        double dist2 = (h.position - sh.x).squaredNorm();
        double cos_y = -dir.dot(patches_[h.patch].normal);
        double light_pdf = lights_.area_pdf(h.patch, h.position) * dist2 / cos_y;
        w *= power_heuristic(count * ls.pdf, o_.light_samples * light_pdf);
      }
      add_arriving(h.patch, h.u, h.v, sh.i, scaled(sh.m.specular, sh.share * w / count), terms);
    }
    return rays;
  }

  // The light strategy (next-event estimation): points on the lights, stratified over their
  // total area, each s_i lobe cos / pdf (B_j + S_{j->i}) when unoccluded, with the
  // power-heuristic weight against the lobe samples (Veach's thesis, eq. 9.13).
  long long add_light_samples(const Shading& sh, Rng& rng, std::vector<Term>& terms) const {
    if (!light_sampled(sh.m)) return 0;
    const int count = o_.light_samples, side = lobe_side(sh.m), lobes = side * side;
    const Vec3& n = patches_[sh.i].normal;
    long long rays = 0;
    for (int s = 0; s < count; ++s) {
      const double u_select = (s + rng.uniform32()) / count;
      const double v = rng.uniform32(), u = rng.uniform32();  // (as the lobe samples' order)
      LightSample l = lights_.sample(u_select, Vec2(u, v));
      Vec3 d = l.point - sh.x;
      double dist2 = d.squaredNorm();
      if (!(dist2 > 0.0) || !(l.area_pdf > 0.0)) continue;
      Vec3 wi = d / std::sqrt(dist2);
      double cos_x = wi.dot(n), cos_y = -wi.dot(patches_[l.patch].normal);
      if (cos_x <= 0.0 || cos_y <= 0.0) continue;
      Vec3 wi_local = sh.frame.to_local(wi);
      double lobe = sh.m.lobe_eval(wi_local, sh.wo);
      if (!(lobe > 0.0)) continue;
      ++rays;
      if (caster_.segment_occluded(sh.x, sh.i, l.point, l.patch)) continue;
      double light_pdf = l.area_pdf * dist2 / cos_y;  // per unit solid angle
      double w = lobe * cos_x / (light_pdf * count) *
                 power_heuristic(count * light_pdf, lobes * sh.m.lobe_pdf(wi_local, sh.wo));
      add_arriving(l.patch, l.uv.x(), l.uv.y(), sh.i, scaled(sh.m.specular, sh.share * w), terms);
    }
    return rays;
  }

  const Camera& camera_;
  const PatchSet& patches_;
  const std::vector<Material>& materials_;
  const RayCaster& caster_;
  const UnknownLayout& t_;
  const GatherOptions& o_;
  const CornerAverages& corners_;
  const LightSampler& lights_;
};

void merge_terms(std::vector<Term>& terms) {
  std::sort(terms.begin(), terms.end(),
            [](const Term& a, const Term& b) { return a.column < b.column; });
  size_t w = 0;
  for (size_t r = 0; r < terms.size(); ++r) {
    if (w > 0 && terms[w - 1].column == terms[r].column) {
      for (int c = 0; c < 3; ++c) terms[w - 1].w[c] += terms[r].w[c];
    } else {
      terms[w++] = terms[r];
    }
  }
  terms.resize(w);
}

}  // namespace

Gather build_gather(const World& world, const UnknownLayout& t, const GatherOptions& options) {
  return build_gather(world, world.camera(), t, options);
}

Gather build_gather(const World& world, const Camera& camera, const UnknownLayout& t,
                    const GatherOptions& options) {
  const Stopwatch watch;
  const PatchSet& patches = world.patches();
  // A hierarchy's leaves have corner averages of their own; the patches' are then not read.
  static const PatchSet kNoPatches;
  const CornerAverages corners(t.hierarchy ? kNoPatches : patches, t.flux_weight);
  const LightSampler& lights = world.lights();
  const RayCaster& caster = world.caster();
  const std::vector<Material>& materials = world.materials();
  PixelGatherer gatherer(camera, patches, materials, caster, t, options, corners, lights);
  const int w = camera.width, h = camera.height;
  std::vector<std::vector<Term>> rows(static_cast<size_t>(w) * h);
  long long rays = 0;
  Progress progress("camera gather", h);
#pragma omp parallel
  {
    std::vector<Term> terms;
#pragma omp for schedule(dynamic, 1) reduction(+ : rays)
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        rays += gatherer.gather(x, y, terms);
        merge_terms(terms);
        rows[static_cast<size_t>(y) * w + x] = terms;
      }
      progress.advance();
    }
  }
  progress.finish();
  Gather g;
  g.width = w;
  g.height = h;
  g.options = options;
  g.g.cols = t.size();
  for (const auto& row : rows) {
    for (const auto& term : row) {
      g.g.column.push_back(term.column);
      g.g.value.push_back(term.w);
    }
    g.g.push_row();
  }
  g.rays = rays;
  g.seconds = watch.seconds();
  return g;
}

Image apply_gather(const Gather& gather, const Field& u) {
  Image img(gather.width, gather.height);
  std::vector<double> y(3 * static_cast<std::size_t>(gather.g.rows));
  gather.g.multiply(u.data(), 3, y.data());
  std::transform(y.begin(), y.end(), img.rgb.begin(),
                 [](double v) { return static_cast<float>(v); });
  return img;
}

}  // namespace polyrad
