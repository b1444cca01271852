// Camera gather (render/camera_gather.h): the patch gather, and the rows of either kind built
// in blocks of pixels.
#include "polyrad/render/camera_gather.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "gather_terms.h"
#include "polyrad/transport/hierarchy.h"
#include "polyrad/util/error.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/sampling.h"
#include "polyrad/util/timer.h"

namespace polyrad {

namespace gather_detail {

CornerAverages::CornerAverages(const PatchSet& patches, const std::vector<double>& flux_weight)
    : patches_(patches) {
  POLYRAD_CHECK(flux_weight.size() >= patches.size());
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

void CornerAverages::add(PatchId p, double u, double v, const Rgbf& w,
                         std::vector<Term>& terms) const {
  auto cw = patches_[p].corner_weights(u, v);
  for (int c = 0; c < 4; ++c) {
    if (cw[c] == 0.0) continue;
    for (auto e = start_[4 * p + c]; e < start_[4 * p + c + 1]; ++e) {
      float s = static_cast<float>(cw[c] * entries_[e].second);
      terms.push_back({entries_[e].first, {w[0] * s, w[1] * s, w[2] * s}});
    }
  }
}

void CornerAverages::subtract_emission(PatchId p, double u, double v, const Rgbf& w,
                                       std::vector<Term>& terms) const {
  auto cw = patches_[p].corner_weights(u, v);
  for (int c = 0; c < 4; ++c) {
    if (cw[c] == 0.0) continue;
    for (auto e = start_[4 * p + c]; e < start_[4 * p + c + 1]; ++e) {
      if (!patches_[entries_[e].first].emitter) continue;
      float s = -static_cast<float>(cw[c] * entries_[e].second);
      terms.push_back({entries_[e].first, {w[0] * s, w[1] * s, w[2] * s}});
    }
  }
}

DiffusePoint locate(const GatherContext& c, PatchId p, double u, double v) {
  if (const ElementHierarchy* h = c.layout.hierarchy.get()) {
    const LeafPoint leaf = h->leaf_at(p, u, v);
    return {p, u, v, leaf, leaf.diameter};
  }
  return {p, u, v, LeafPoint{}, c.diameters[static_cast<std::size_t>(p)]};
}

void add_diffuse(const GatherContext& c, const DiffusePoint& at, const Rgbf& w,
                 std::vector<Term>& terms, bool smooth) {
  if (const ElementHierarchy* h = c.layout.hierarchy.get()) {
    thread_local std::vector<std::pair<std::int32_t, double>> weights;
    weights.clear();
    h->diffuse_weights(at.leaf, smooth, weights);
    for (const auto& [leaf, s] : weights)
      terms.push_back({leaf,
                       {static_cast<float>(w[0] * s), static_cast<float>(w[1] * s),
                        static_cast<float>(w[2] * s)}});
    return;
  }
  if (smooth)
    c.corners.add(at.patch, at.u, at.v, w, terms);
  else
    terms.push_back({at.patch, w});
}

void TermMerger::merge(std::vector<Term>& terms) {
  // In place: the merged entry k lies at or before the term that made it.
  std::size_t n = 0;
  for (const Term& t : terms) {
    std::int32_t& s = slot_[static_cast<std::size_t>(t.column)];
    if (s < 0) {
      s = static_cast<std::int32_t>(n);
      terms[n++] = t;
    } else {
      for (int c = 0; c < 3; ++c) terms[static_cast<std::size_t>(s)].w[c] += t.w[c];
    }
  }
  terms.resize(n);
  for (const Term& t : terms) slot_[static_cast<std::size_t>(t.column)] = -1;
  std::sort(terms.begin(), terms.end(),
            [](const Term& a, const Term& b) { return a.column < b.column; });
}

namespace {

class PixelGatherer {
 public:
  explicit PixelGatherer(const GatherContext& c)
      : context_(c),
        camera_(c.camera),
        patches_(c.patches),
        materials_(c.materials),
        caster_(c.caster),
        t_(c.layout),
        o_(c.options),
        lights_(c.lights) {}

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
    gather_detail::add_diffuse(context_, p, u, v, w, terms);
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

  const GatherContext& context_;
  const Camera& camera_;
  const PatchSet& patches_;
  const std::vector<Material>& materials_;
  const RayCaster& caster_;
  const UnknownLayout& t_;
  const GatherOptions& o_;
  const LightSampler& lights_;
};

}  // namespace

long long patch_gather_pixel(const GatherContext& c, int x, int y, PixelTerms& terms) {
  terms.clear();
  return PixelGatherer(c).gather(x, y, terms.unknowns);
}

}  // namespace gather_detail

using namespace gather_detail;

namespace {
// The least number of pixels a thread takes at a time: a piece of a block, or a run of the
// coarse classes. Each pixel's rows are keyed by the pixel alone, so the pieces' size changes
// only how the threads share the work, never the rows.
constexpr std::int64_t kPiecePixels = 32;

// The display of a gather's progress, counted in pixels.
Progress gather_progress(const GatherOptions& o, std::int64_t pixels) {
  return Progress(o.kind == GatherKind::kFinal ? "final gather" : "camera gather", pixels);
}

// Whether the world has a light and a planar mirror for the final gather's mirror images.
bool has_mirror(const World& world) {
  if (world.lights().empty()) return false;
  for (const Patch& p : world.patches().patches)
    if (is_planar_mirror(p, world.materials()[p.material], world.patches().scene_diameter))
      return true;
  return false;
}
}  // namespace

// The rows of a gather, built for any range of pixels: the shared state (corner averages, light
// sampler) is made once. Both gathers key their random streams by (pixel, sub-pixel ray), so a
// row is the same whichever block, thread or call builds it.
class GatherRows {
 public:
  GatherRows(const World& world, const Camera& camera, const UnknownLayout& layout,
             const GatherOptions& options, std::shared_ptr<const MeshDirect> kept = nullptr,
             const MeshDirect* direct = nullptr)
      : kept_(std::move(kept)),
        camera_(camera),
        options_(drawn(options, world, kept_ ? kept_.get() : direct)),
        mirrors_(mirror_planes(
            world.patches(), world.materials(),
            options_.kind == GatherKind::kFinal && options_.mirror_image_samples > 0)),
        corners_(world.patches(), corner_weights(world, layout)),
        light_bounds_(world.patches()),
        reflectors_(world.patches(), reflector_weights(world, layout, options_, mirrors_)),
        diameters_(diameters(world.patches())),
        context_{camera_,       world.patches(), world.materials(), world.caster(),
                 layout,        options_,        corners_,          world.lights(),
                 light_bounds_, reflectors_,     diameters_,        kept_ ? kept_.get() : direct,
                 mirrors_},
        unknowns_(layout.size()),
        patches_(static_cast<std::int64_t>(world.patches().size())) {
    if (options.pixel_grid < 1 || options.pixel_grid > 16)
      throw InputError("gather: pixel_grid must be in [1, 16]");
    if (options.lobe_samples < 1) throw InputError("gather: lobe_samples must be at least 1");
    if (options.light_samples < 0) throw InputError("gather: light_samples must not be negative");
    if (options.kind == GatherKind::kFinal && options.gather_samples < 1)
      throw InputError("final gather: gather_samples must be at least 1");
    if (options.mirror_depth < 0 || options.mirror_depth > 64)
      throw InputError("final gather: mirror_depth must be in [0, 64]");
    if (options.emission_grid < 1 || options.emission_grid > 16)
      throw InputError("final gather: emission_grid must be in [1, 16]");
    if (options.near_samples < 0)
      throw InputError("final gather: near_samples must not be negative");
    if (!(options.near_distance >= 0.0))
      throw InputError("final gather: near_distance must not be negative");
    if (options.reflector_samples < 0)
      throw InputError("final gather: reflector_samples must not be negative");
    if (options.mirror_image_samples < 0)
      throw InputError("final gather: mirror_image_samples must not be negative");
    if (options.mirror_image_depth < 1 || options.mirror_image_depth > 64)
      throw InputError("final gather: mirror_image_depth must be in [1, 64]");
    if (options.mirror_chain_budget < 0)
      throw InputError("final gather: mirror_chain_budget must not be negative");
    if (!(options.mesh_near_distance >= 0.0 && options.mesh_near_distance < 1e300))
      throw InputError("final gather: mesh_near_distance must be finite and not negative");
    if (options.mesh_near_samples < 1)
      throw InputError("final gather: mesh_near_samples must be at least 1");
    if (options.kind == GatherKind::kFinal && options.indirect == IndirectMode::kMesh) {
      if (options.light_samples < 1)
        throw InputError(
            "final gather: --indirect mesh takes the direct light from light points; "
            "light_samples must be at least 1");
      const MeshDirect* d = context_.direct;
      if (!d || d->value.size() != static_cast<std::size_t>(layout.num_patches) *
                                       static_cast<std::size_t>(d->objects))
        throw InputError(
            "final gather: --indirect mesh needs the mesh's direct light of this "
            "operator (mesh_direct), which this gather was not given");
    }
    const MeshDirect* given = context_.direct;
    if (options_.mirror_image_samples > 0 && (given->link_row.size() != layout.links.size() ||
                                              (options_.indirect == IndirectMode::kMesh &&
                                               given->mirrored.size() != given->value.size())))
      throw InputError(
          "final gather: the mirror images need the mesh's direct light of this operator with "
          "its mirrors' links (mesh_direct_for), which this gather was not given");
  }

  int width() const { return camera_.width; }
  int height() const { return camera_.height; }
  const GatherOptions& options() const { return options_; }

  // A run of a block's pixels (kPiecePixels or more, across rows), built by one thread.
  struct Piece {
    Csr<Rgbf> g, e;
  };
  // A thread's own: a pixel's terms and their merger (a slot per column: 4 MB where the room
  // has a million unknowns). On a cache line of its own, since the terms' vectors write their
  // ends at every term (side by side, the room's gather took 15.5 s against 14.1 in paired runs).
  struct alignas(64) ThreadScratch {
    explicit ThreadScratch(std::int64_t columns) : merger(columns) {}
    PixelTerms terms;
    TermMerger merger;
  };
  // What build() works in: the pieces of a block, and each thread's scratch. A caller that
  // builds block after block keeps one, with g and e, and their storage is reused: freed and
  // mapped again for every block of 1,024 pixels, the pieces, g and e cost the mirror cube's
  // render 5 percent of its time in page faults and copies. keep_pieces = false frees each
  // piece once copied, for a gather built whole (else its entries would be held twice).
  struct Scratch {
    std::vector<Piece> pieces;
    std::vector<ThreadScratch> threads;
    CoarseClasses coarse;  // the final gather's, for the block's rows and one more each side
    bool keep_pieces = true;
    MirrorChainCount chains;  // over every row built with this scratch
  };

  // Rows [r0, r1) into g and e (replaced), in parallel over pieces of the range; returns the
  // rays cast. Each thread merges a pixel's terms in its own scratch and appends the merged row
  // to the piece of the block it is building, so nothing is allocated per pixel.
  long long build(std::int64_t r0, std::int64_t r1, Csr<Rgbf>& g, Csr<Rgbf>& e, Scratch& scratch,
                  Progress* progress = nullptr) const {
    const std::int64_t w = camera_.width;
    const bool final_gather = options_.kind == GatherKind::kFinal;
    // Pixels per piece: an eighth of an image row, so that the threads' last pieces of a block
    // end close together. With whole rows one thread could wait up to a row's time at the end of
    // every block: a block of the room's 320-pixel rows is three rows, two for one thread.
    const std::int64_t chunk = std::max<std::int64_t>(kPiecePixels, w / 8);
    const std::int64_t pieces = (r1 - r0 + chunk - 1) / chunk;
    std::vector<Piece>& piece = scratch.pieces;
    if (static_cast<std::int64_t>(piece.size()) < pieces) piece.resize(pieces);
    for (std::int64_t k = 0; k < pieces; ++k) {
      piece[k].g.clear();
      piece[k].e.clear();
    }
    const auto threads = static_cast<std::size_t>(omp_get_max_threads());
    while (scratch.threads.size() < threads)
      scratch.threads.emplace_back(std::max<std::int64_t>(unknowns_, patches_));
    const bool coarse =
        final_gather && options_.emission_grid >= 4 && !options_.emission_grid_everywhere;
    long long rays = coarse ? coarse_classes(r0, r1, scratch) : 0;
#pragma omp parallel
    {
      ThreadScratch& own = scratch.threads[static_cast<std::size_t>(omp_get_thread_num())];
      PixelTerms& terms = own.terms;
      TermMerger& merger = own.merger;
#pragma omp for schedule(dynamic, 1) reduction(+ : rays)
      for (std::int64_t k = 0; k < pieces; ++k) {
        Piece& out = piece[k];
        const std::int64_t begin = r0 + k * chunk, end = std::min(r1, begin + chunk);
        for (std::int64_t r = begin; r < end; ++r) {
          const int x = static_cast<int>(r % w), y = static_cast<int>(r / w);
          rays += final_gather
                      ? final_gather_pixel(context_, x, y, terms,
                                           coarse ? scratch.coarse.shared_around(x, y) : nullptr)
                      : patch_gather_pixel(context_, x, y, terms);
          merger.merge(terms.unknowns);
          merger.merge(terms.emission);
          append_row(terms.unknowns, out.g);
          if (final_gather) append_row(terms.emission, out.e);
        }
        if (progress) progress->advance(end - begin);
      }
    }
    for (ThreadScratch& t : scratch.threads) {
      scratch.chains.add(t.terms.chains);
      t.terms.chains = {};
    }
    g.clear();
    e.clear();
    g.cols = unknowns_;
    e.cols = final_gather ? patches_ : 0;
    std::size_t ng = 0, ne = 0;
    for (std::int64_t k = 0; k < pieces; ++k) {
      ng += piece[k].g.column.size();
      ne += piece[k].e.column.size();
    }
    g.column.reserve(ng);
    g.value.reserve(ng);
    e.column.reserve(ne);
    e.value.reserve(ne);
    for (std::int64_t k = 0; k < pieces; ++k) {
      append(piece[k].g, g);
      if (final_gather) append(piece[k].e, e);
      if (!scratch.keep_pieces) piece[k] = Piece{};
    }
    return rays;
  }

 private:
  // The coarse classes of the image rows that pixels [r0, r1) and their neighbours lie in, into
  // scratch.coarse, in parallel over runs of kPiecePixels pixels; returns the rays cast.
  long long coarse_classes(std::int64_t r0, std::int64_t r1, Scratch& scratch) const {
    const int w = camera_.width, h = camera_.height;
    CoarseClasses& c = scratch.coarse;
    c.width = w;
    c.height = h;
    c.first_row = static_cast<int>(std::max<std::int64_t>(0, r0 / w - 1));
    const int last = static_cast<int>(std::min<std::int64_t>(h, (r1 - 1) / w + 2));
    c.cls.resize(static_cast<std::size_t>(last - c.first_row) * static_cast<std::size_t>(w));
    long long rays = 0;
#pragma omp parallel
    {
      PixelTerms& terms = scratch.threads[static_cast<std::size_t>(omp_get_thread_num())].terms;
      const std::int64_t first = static_cast<std::int64_t>(c.first_row) * w;
      const std::int64_t count = static_cast<std::int64_t>(last - c.first_row) * w;
#pragma omp for schedule(dynamic, kPiecePixels) reduction(+ : rays)
      for (std::int64_t k = 0; k < count; ++k) {
        const int x = static_cast<int>((first + k) % w), y = static_cast<int>((first + k) / w);
        c.cls[c.index(x, y)] = final_gather_coarse(context_, x, y, terms, rays);
      }
    }
    return rays;
  }

  // The patches' weights in their corners' averages: their flux weights where they are the
  // unknowns, their areas under a hierarchy (whose leaves are read through the hierarchy; the
  // patches' averages then serve the emission's interpolation only).
  static std::vector<double> corner_weights(const World& world, const UnknownLayout& layout) {
    if (!layout.hierarchy) return layout.flux_weight;
    std::vector<double> weight(world.patches().size());
    for (size_t p = 0; p < weight.size(); ++p) weight[p] = world.patches()[p].area;
    return weight;
  }
  // The reflectors' weights for the final gather's reflector points: the areas of the patches
  // that send specular links (none unless options ask for the points), but for the planar
  // mirrors where the gather draws their images: what is left of their links, the lamps' light
  // taken out, changes little from patch to patch, and points on them no longer paid (mirror
  // cube, hierarchical: relative RMSE 0.0701 with them, 0.0699 without, gather 5.1 s and 4.3).
  static std::vector<double> reflector_weights(const World& world, const UnknownLayout& layout,
                                               const GatherOptions& options,
                                               const MirrorPlanes& mirrors) {
    std::vector<double> weight(world.patches().size(), 0.0);
    if (options.kind != GatherKind::kFinal || options.reflector_samples <= 0) return weight;
    for (size_t p = 0; p < weight.size(); ++p)
      if (layout.link_start[p + 1] > layout.link_start[p] &&
          (mirrors.empty() || mirrors.plane_of[p] < 0))
        weight[p] = world.patches()[p].area;
    return weight;
  }
  // The options as the rows are built: mirror images only where they can be drawn (a final
  // gather reading the indirect light by rays, a mirror in the world, and the links' part of
  // the mesh's direct light to leave out of the links' reads); the mesh's near points only where
  // the mesh is read (a final gather's kMesh).
  static GatherOptions drawn(GatherOptions o, const World& world, const MeshDirect* direct) {
    const bool can = o.kind == GatherKind::kFinal && direct && direct->has_links() &&
                     has_mirror(world) &&
                     (o.indirect == IndirectMode::kRays || !direct->mirrored.empty());
    if (!can) o.mirror_image_samples = 0;
    o.mirror_image_depth = mirror_chain_depth(o);
    if (o.kind != GatherKind::kFinal || o.indirect != IndirectMode::kMesh)
      o.mesh_near_distance = 0.0;
    return o;
  }
  static std::vector<double> diameters(const PatchSet& patches) {
    std::vector<double> d(patches.size());
    for (std::size_t p = 0; p < d.size(); ++p) d[p] = patches[p].diameter();
    return d;
  }
  // Appends one merged row, without the entries whose weights are all zero (a final-gather
  // shading ray whose path class no finer ray met is weighted zero).
  static void append_row(const std::vector<Term>& terms, Csr<Rgbf>& m) {
    for (const Term& t : terms) {
      if (t.w[0] == 0.0f && t.w[1] == 0.0f && t.w[2] == 0.0f) continue;
      m.column.push_back(t.column);
      m.value.push_back(t.w);
    }
    m.push_row();
  }
  // Appends the rows of `from` to `to`.
  static void append(const Csr<Rgbf>& from, Csr<Rgbf>& to) {
    const std::int64_t base = static_cast<std::int64_t>(to.column.size());
    to.column.insert(to.column.end(), from.column.begin(), from.column.end());
    to.value.insert(to.value.end(), from.value.begin(), from.value.end());
    for (std::int64_t r = 0; r < from.rows; ++r) to.start.push_back(base + from.start[r + 1]);
    to.rows += from.rows;
  }

  const std::shared_ptr<const MeshDirect> kept_;  // a deferred gather's MeshDirect
  const Camera camera_;
  const GatherOptions options_;
  const MirrorPlanes mirrors_;
  const CornerAverages corners_;
  const LightBounds light_bounds_;
  const LightSampler reflectors_;
  const std::vector<double> diameters_;
  const GatherContext context_;
  const Eigen::Index unknowns_;
  const std::int64_t patches_;
};

bool draws_mirror_images(const GatherOptions& o, const World& world, bool links) {
  return o.kind == GatherKind::kFinal && o.mirror_image_samples > 0 && links && has_mirror(world);
}

std::shared_ptr<const MeshDirect> mesh_direct_for(const GatherOptions& o,
                                                  const TransportOperator& t, const World& world) {
  if (o.kind != GatherKind::kFinal) return nullptr;
  const bool mesh = o.indirect == IndirectMode::kMesh;
  const bool images = draws_mirror_images(o, world, t.num_links() > 0);
  if (!mesh && !images) return nullptr;
  return std::make_shared<const MeshDirect>(
      mesh_direct(t, world.patches(), images ? &world.materials() : nullptr, images && mesh));
}

double link_tolerance_for(GatherKind kind, double chosen) {
  if (chosen > 0.0) return chosen;
  return kind == GatherKind::kFinal ? 0.07 : kDefaultLinkTolerance;
}

double link_tolerance_for(const GatherOptions& gather, double chosen) {
  if (gather.kind == GatherKind::kFinal && gather.indirect == IndirectMode::kMesh &&
      !(chosen > 0.0))
    return link_tolerance_for(GatherKind::kPatch);
  return link_tolerance_for(gather.kind, chosen);
}

Gather build_gather(const World& world, const UnknownLayout& layout, const GatherOptions& options,
                    const MeshDirect* direct) {
  return build_gather(world, world.camera(), layout, options, direct);
}

Gather build_gather(const World& world, const Camera& camera, const UnknownLayout& layout,
                    const GatherOptions& options, const MeshDirect* direct) {
  const Stopwatch watch;
  GatherRows rows(world, camera, layout, options, nullptr, direct);
  Gather g;
  g.width = camera.width;
  g.height = camera.height;
  g.options = rows.options();
  const std::int64_t pixels = static_cast<std::int64_t>(camera.width) * camera.height;
  Progress progress = gather_progress(options, pixels);
  GatherRows::Scratch scratch;
  scratch.keep_pieces = false;
  g.rays = rows.build(0, pixels, g.g, g.e, scratch, &progress);
  g.mirror_chains = scratch.chains;
  progress.finish();
  g.seconds = watch.seconds();
  return g;
}

Gather defer_gather(const World& world, const Camera& camera, const UnknownLayout& layout,
                    const GatherOptions& options, std::shared_ptr<const MeshDirect> direct) {
  Gather g;
  g.width = camera.width;
  g.height = camera.height;
  g.deferred =
      std::make_shared<const GatherRows>(world, camera, layout, options, std::move(direct));
  g.options = g.deferred->options();
  return g;
}

GatherWork for_each_gather_block(
    const Gather& gather, std::int64_t block_pixels,
    const std::function<void(std::int64_t, const Csr<Rgbf>&, const Csr<Rgbf>&)>& f) {
  GatherWork work;
  if (!gather.deferred) {
    work.nnz = gather.g.nnz() + gather.e.nnz();
    work.bytes = gather.bytes();
    f(0, gather.g, gather.e);
    return work;
  }
  const GatherRows& rows = *gather.deferred;
  const std::int64_t w = rows.width(), total = w * rows.height();
  // Whole image rows per block: the finer rays' coarse classes are kept by rows.
  const std::int64_t block = std::max<std::int64_t>(1, block_pixels / w) * w;
  Progress progress = gather_progress(rows.options(), total);
  Csr<Rgbf> g, e;
  GatherRows::Scratch scratch;  // with g and e, reused from block to block
  for (std::int64_t r0 = 0; r0 < total; r0 += block) {
    const std::int64_t r1 = std::min(total, r0 + block);
    const Stopwatch watch;
    work.rays += rows.build(r0, r1, g, e, scratch, &progress);
    work.seconds += watch.seconds();
    work.nnz += g.nnz() + e.nnz();
    work.bytes = std::max(work.bytes, g.bytes() + e.bytes());
    f(r0, g, e);
  }
  work.mirror_chains = scratch.chains;
  progress.finish();
  return work;
}

GatherWork gather_cost(const Gather& gather, const GatherWork& work) {
  GatherWork cost = work;
  cost.seconds += gather.seconds;
  if (gather.deferred) return cost;
  cost.rays = gather.rays;
  cost.nnz = gather.g.nnz() + gather.e.nnz();
  cost.bytes = gather.bytes();
  cost.mirror_chains = gather.mirror_chains;
  return cost;
}

double gather_memory(const GatherOptions& o, std::int64_t pixels, bool deferred) {
  const double rays = static_cast<double>(o.pixel_grid) * o.pixel_grid;
  // With the mesh's near points gathered by rays, as if half the points were (cornell-box on its
  // uniform mesh: 129 entries a pixel against 144).
  const bool near = o.kind == GatherKind::kFinal && o.indirect == IndirectMode::kMesh &&
                    o.mesh_near_distance > 0.0;
  const double samples = o.gather_samples + (near ? 0.5 * o.mesh_near_samples : 0.0);
  const double entries = o.kind == GatherKind::kFinal ? 0.75 * rays * samples : 1.75 * rays;
  const double per_pixel_buffers = 48.0;  // the image and the apply's double sums
  // The final gather's coarse classes (CoarseClass) of the pixels built at once.
  const double coarse = o.kind == GatherKind::kFinal ? 16.0 : 0.0;
  const auto p = static_cast<double>(pixels);
  if (deferred) {
    // One block of rows at a time, never more pixels than the image has.
    const double block_pixels = std::min(static_cast<double>(kGatherBlockPixels), p);
    const double block = block_pixels * (entries * 16.0 * 3.0 + coarse);
    // The image and the block's bookkeeping: cornell-box at 1024 and 2048 pixels a side, 12 to
    // 15 bytes a pixel between the two peaks (24 counted before, 1.5 times the peak at 2048).
    return block + 16.0 * p;
  }
  return p * (2.0 * 16.0 * entries + per_pixel_buffers + coarse);
}

std::vector<Rgb> scene_emission(const PatchSet& patches) {
  std::vector<Rgb> e(patches.size());
  for (size_t p = 0; p < patches.size(); ++p) e[p] = patches[p].emission;
  return e;
}

Image apply_gather(const Gather& gather, const Field& u, const std::vector<Rgb>& emission,
                   GatherWork* work) {
  Image img(gather.width, gather.height);
  const GatherWork done = for_each_gather_block(
      gather, kGatherBlockPixels, [&](std::int64_t r0, const Csr<Rgbf>& g, const Csr<Rgbf>& e) {
        if (e.nnz() > 0 && emission.size() != static_cast<size_t>(e.cols))
          throw InputError("apply_gather: the final gather needs one emission per patch (" +
                           std::to_string(e.cols) + "), given " + std::to_string(emission.size()));
#pragma omp parallel for schedule(static)
        for (std::int64_t p = 0; p < g.rows; ++p) {
          double a[3] = {0.0, 0.0, 0.0};
          for (auto k = g.start[p]; k < g.start[p + 1]; ++k)
            for (int c = 0; c < 3; ++c) a[c] += g.value[k][c] * u(g.column[k], c);
          if (p < e.rows)
            for (auto k = e.start[p]; k < e.start[p + 1]; ++k)
              for (int c = 0; c < 3; ++c) a[c] += e.value[k][c] * emission[e.column[k]][c];
          for (int c = 0; c < 3; ++c) img.rgb[3 * (r0 + p) + c] = static_cast<float>(a[c]);
        }
      });
  if (work) *work = done;
  return img;
}

}  // namespace polyrad
