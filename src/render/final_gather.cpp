// The final gather (render/camera_gather.h, GatherKind::kFinal; papers/glossy-radiosity.md,
// section 7.1).
//
// Per pixel, a grid of finer rays finds the emission Le it sees along chains of delta lobes
// (mirrors, up to mirror_depth bounces) (E). They are cast only where a pixel may need them:
// where 4 coarse ones in it or in a neighbour (CoarseClasses) meet more than one path class or
// a lamp, a shading ray meets another class than theirs, or the pixel lies on the image's
// border; elsewhere each is taken to add the one class and no Le (an approximation: a feature
// thinner than the coarse rays' spacing can lie between them all). Per shading ray, along the same
// kind of chain, at each surface point met, for the non-delta parts of its BRDF, the direct light
// and the first bounce (eq. 11):
//   - light samples: a stratified grid of points on the lights, drawn by area (LightSampler),
//     each f Le_j cos_x / p_light with a shadow ray, weighted against the BRDF samples;
//   - BRDF samples: cosine samples for the diffuse part d (weight d each), lobe samples for the
//     glossy part s (weight s beta each). Where one lands on patch j at y it reads the reflected
//     radiance toward i, B~_j(y) - E~_j(y) + S_{j->i} (G, and -E), and, when j is a light, its
//     weighted share of Le_j (E).
// The multiple-importance weights are the power heuristic over each part's own pair of
// strategies (Veach's thesis, eq. 9.13, with the sample counts): for the diffuse part, light
// points against cosine samples; for the glossy part, light points against lobe samples. Each
// part is then estimated without bias on its own, and the weights of a direction sum to one.
// With reflector_samples, the diffuse part's S_{j->i} has a pair of its own: points drawn by
// area on the patches that send specular links against the cosine samples.
// With mirror_image_samples, the lamps' light that a planar mirror reflects to the point is taken
// from the lamps' images behind the mirrors' planes (mirror_images), and the diffuse part's reads
// of a mirror's links leave that part out (subtract_mirrored_lights); with mirror_image_depth,
// through chains of facing mirrors too (mirror_chains; which chains: transport/mirror_chains.h).
// With through_mirrors, a cosine sample or reflector point that meets a delta mirror (kImaged:
// one whose images are drawn, where no reflector points are) reads no link there: it follows its
// ray through the mirror and reads what the mirrored ray meets (through_mirror); the lamps'
// light it meets there is left to the mirror images where they are drawn; it goes on through the
// chain's further mirrors as the images do. Both strategies of
// the diffuse part's pair decide by the mirror met, so their weights still sum to one.
// With IndirectMode::kMesh, the diffuse part's reflected light is read at the hit itself from
// the mesh, its direct part taken out (mesh_reflected); cosine samples that meet a light still
// carry their weighted share of Le, and read nothing else (so one whose ray passes no light's
// box, LightBounds, is not cast). A hit near another surface (near_surface) is gathered by rays
// instead, as without kMesh.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>

#include "gather_terms.h"
#include "polyrad/transport/hierarchy.h"
#include "polyrad/transport/mirror_chains.h"
#include "polyrad/util/sampling.h"

namespace polyrad::gather_detail {

namespace {

// A grid of side x side strata on the unit square, as close to `count` points as a square gets.
int grid_side(int count) { return std::max(1, static_cast<int>(std::lround(std::sqrt(count)))); }

class FinalGatherer {
 public:
  explicit FinalGatherer(const GatherContext& c)
      : c_(c),
        o_(c.options),
        diffuse_side_(grid_side(o_.gather_samples)),
        lobe_side_(grid_side(o_.lobe_samples)),
        light_count_(c.lights.empty() ? 0 : o_.light_samples),
        light_side_(static_cast<int>(std::sqrt(static_cast<double>(light_count_)))),
        reflector_count_(c.reflectors.empty() ? 0 : o_.reflector_samples),
        reflector_side_(static_cast<int>(std::sqrt(static_cast<double>(reflector_count_)))),
        near_side_(o_.near_samples > 0 ? grid_side(o_.near_samples) : 0),
        near_count_(near_side_ * near_side_),
        // GatherRows leaves the count only where the world has lights and planar mirrors.
        mirror_count_(o_.mirror_image_samples),
        mirror_side_(static_cast<int>(std::sqrt(static_cast<double>(mirror_count_)))),
        chain_depth_(mirror_chain_depth(o_)),
        mesh_indirect_(o_.indirect == IndirectMode::kMesh),
        mesh_near_side_(grid_side(o_.mesh_near_samples)) {}

  // The pixel: Le of what its emission_grid^2 finer rays see along their mirror chains, and the
  // light reflected there from its pixel_grid^2 shading rays. Each shading ray stands for the
  // finer rays whose chain meets the same objects (a chain's "path class"), weighted by their
  // share of the pixel: the emission and the reflected light of every part of the pixel then
  // come from the same area, which a furnace checks to the pixel (with the two estimated
  // separately, a pixel across the edge between a mirror and a diffuse wall was off by several
  // percent). A path class no shading ray found is shaded once from one of its finer rays.
  // shared (CoarseClasses::shared_around): the class the finer rays are taken to meet, cast
  // only if a shading ray meets another; null: cast them.
  long long gather(int x, int y, PixelTerms& terms, const std::uint64_t* shared) const {
    terms.clear();
    long long rays = 0;
    const int n = o_.pixel_grid, g = o_.emission_grid;
    const auto pixel = static_cast<std::uint64_t>(y) * c_.camera.width + x;
    std::array<std::uint64_t, kMaxFineRays> fine;
    if (!shared) rays += fine_rays(x, y, pixel, terms, fine.data());
    std::array<Shaded, kMaxShadingRays> shaded;
    for (int k = 0; k < n * n; ++k) {
      Rng rng(o_.seed, pixel, static_cast<std::uint64_t>(k));
      const Ray ray = pixel_ray(x, y, pixel, n, k, &rng);
      shaded[k] = {terms.unknowns.size(), terms.emission.size(), 0, 0, 0};
      rays += follow(ray, SubPixel{pixel, k}, rng, terms, &shaded[k].key);
      shaded[k].unknowns_end = terms.unknowns.size();
      shaded[k].emission_end = terms.emission.size();
    }
    // A shading ray outside the class the neighbourhood shares: the finer rays after all, their
    // terms moved ahead of the shading rays' as if cast first (the same sums in the same order).
    if (shared && std::any_of(shaded.begin(), shaded.begin() + n * n,
                              [&](const Shaded& s) { return s.key != *shared; })) {
      const std::size_t mid = terms.emission.size();
      rays += fine_rays(x, y, pixel, terms, fine.data());
      const std::size_t moved = terms.emission.size() - mid;
      std::rotate(terms.emission.begin(), terms.emission.begin() + static_cast<std::ptrdiff_t>(mid),
                  terms.emission.end());
      for (int k = 0; k < n * n; ++k) {
        shaded[k].emission_begin += moved;
        shaded[k].emission_end += moved;
      }
      shared = nullptr;
    }
    PathClasses classes;
    for (int m = 0; m < g * g; ++m) classes.add_fine(shared ? *shared : fine[m], m);
    for (int k = 0; k < n * n; ++k) classes.add_shading(shaded[k].key);
    for (int k = 0; k < n * n; ++k) {
      const PathClasses::Class& c = classes.find(shaded[k].key);
      const double w = c.fine > 0 ? static_cast<double>(c.fine) / (g * g) / c.shading : 0.0;
      scale(terms.unknowns, shaded[k].unknowns_begin, shaded[k].unknowns_end, w);
      scale(terms.emission, shaded[k].emission_begin, shaded[k].emission_end, w);
    }
    for (int c = 0; c < classes.size(); ++c) {
      const PathClasses::Class& cl = classes[c];
      if (cl.shading > 0 || cl.fine == 0) continue;
      const int m = cl.first_fine;
      Rng rng(o_.seed, pixel, static_cast<std::uint64_t>(n * n + m));
      const Ray ray = pixel_ray(x, y, pixel, g, n * n + m, &rng);
      const std::size_t u0 = terms.unknowns.size(), e0 = terms.emission.size();
      std::uint64_t key = 0;
      rays += follow(ray, SubPixel{pixel, m % (n * n)}, rng, terms, &key);
      const double w = static_cast<double>(cl.fine) / (g * g);
      scale(terms.unknowns, u0, terms.unknowns.size(), w);
      scale(terms.emission, e0, terms.emission.size(), w);
    }
    return rays;
  }

  // The path class that the pixel's coarse finer rays (kCoarseSide^2 of the emission grid's,
  // spread over the pixel) all meet, or none where they differ or one meets an emitter.
  static constexpr int kCoarseSide = 2;  // CoarseClasses speaks of 4 rays
  std::optional<std::uint64_t> coarse_class(int x, int y, PixelTerms& scratch,
                                            long long& rays) const {
    const int n = o_.pixel_grid, g = o_.emission_grid;
    const auto pixel = static_cast<std::uint64_t>(y) * c_.camera.width + x;
    std::optional<std::uint64_t> shared;
    for (int a = 0; a < kCoarseSide; ++a)
      for (int b = 0; b < kCoarseSide; ++b) {
        // Fine ray m takes cell (n^2 + m) mod g^2 (pixel_ray).
        const int cell = coarse_cell(g, a) * g + coarse_cell(g, b);
        const int m = ((cell - n * n) % (g * g) + g * g) % (g * g);
        const Ray ray = pixel_ray(x, y, pixel, g, n * n + m, nullptr);
        scratch.clear();
        std::uint64_t key = 0;
        rays += emission_along(ray, 1.0, scratch, &key);
        if (!scratch.emission.empty() || (shared && *shared != key)) return std::nullopt;
        shared = key;
      }
    return shared;
  }

 private:
  // Cell a of kCoarseSide spread evenly over g, so that with the neighbours' the coarse rays
  // lie about g / kCoarseSide cells apart across pixel boundaries too (g = 8: cells 2 and 6).
  static int coarse_cell(int g, int a) { return (2 * a + 1) * g / (2 * kCoarseSide); }

  // The pixel's emission_grid^2 finer rays: their Le (appended to terms) and path classes.
  long long fine_rays(int x, int y, std::uint64_t pixel, PixelTerms& terms,
                      std::uint64_t* key) const {
    const int n = o_.pixel_grid, g = o_.emission_grid;
    long long rays = 0;
    for (int m = 0; m < g * g; ++m) {
      const Ray ray = pixel_ray(x, y, pixel, g, n * n + m, nullptr);
      rays += emission_along(ray, 1.0 / (g * g), terms, &key[m]);
    }
    return rays;
  }

  // Which shading ray of which pixel is being followed.
  struct SubPixel {
    std::uint64_t pixel;
    int index;  // in [0, pixel_grid^2)
  };
  // A surface point being shaded.
  struct Shading {
    PatchId i;
    const Material& m;
    Frame frame;
    Vec3 x, wo;  // the point, and the direction it is seen from (local frame)
    Rgb weight;  // the mirrors' reflectances along the chain (gather() scales the whole ray)
    SubPixel sub;
    double u, v;  // the point on patch i
    // The chains of facing mirrors from x (mirror_chains): the images' and the reads' through them.
    const MirrorChains* chains;
  };
  // At most four: stratum() keys its hash by pixel * 4 + strategy.
  enum Strategy { kLightPoints = 0, kCosine = 1, kLobe = 2, kReflectorPoints = 3 };

  // Sample s of a side x side grid on the unit square, jittered by (j1, j2), stratified over the
  // whole pixel: each cell of the grid is cut into pixel_grid^2 finer cells and each shading
  // ray takes one of them, so that the pixel's rays together cover a grid pixel_grid times
  // finer per side. Which ray takes which finer cell is turned by a hash of (pixel, strategy,
  // cell), so each ray's own sample is still uniform over its cell: every ray's estimator stays
  // unbiased, and their mean is stratified pixel_grid^2 times finer.
  Vec2 stratum(const SubPixel& sub, int strategy, int s, int side, double j1, double j2) const {
    const int n = o_.pixel_grid, cells = n * n;
    const int cx = s % side, cy = s / side;
    const std::uint64_t h =
        mix64(o_.seed ^ mix64(sub.pixel * 4 + static_cast<std::uint64_t>(strategy)) ^
              static_cast<std::uint64_t>(s));
    const int f = static_cast<int>((static_cast<std::uint64_t>(sub.index) + h % cells) % cells);
    const double fine = static_cast<double>(side) * n;
    return Vec2((cx * n + f % n + j1) / fine, (cy * n + f / n + j2) / fine);
  }
  // Sample s of count points drawn on a sampler's patches: a side x side grid (stratum) when
  // count is a square, else count strata along the first coordinate (which picks the patch).
  Vec2 point_stratum(const SubPixel& sub, int strategy, int s, int count, int side, double j1,
                     double j2) const {
    return side * side == count ? stratum(sub, strategy, s, side, j1, j2)
                                : Vec2((s + j1) / count, j2);
  }

  // A point drawn on a sampler's patches (LightSampler), seen from x of normal n: its direction,
  // the cosine at x and the density of drawing it per unit solid angle; none where x or the
  // point faces away from the other.
  struct SeenPoint {
    Vec3 wi;
    double cos_x, pdf;
  };
  std::optional<SeenPoint> seen_from(const Vec3& x, const Vec3& n, const LightSample& p) const {
    const Vec3 to = p.point - x;
    const double dist2 = to.squaredNorm();
    if (!(dist2 > 0.0) || !(p.area_pdf > 0.0)) return std::nullopt;
    const Vec3 wi = to / std::sqrt(dist2);
    const double cos_x = wi.dot(n), cos_y = -wi.dot(c_.patches[p.patch].normal);
    if (cos_x <= 0.0 || cos_y <= 0.0) return std::nullopt;
    return SeenPoint{wi, cos_x, p.area_pdf * dist2 / cos_y};
  }
  // The density per unit solid angle with which `sampler` draws the point h that a BRDF sample
  // from x along dir met (the other strategy's density in a power heuristic).
  double solid_angle_pdf(const LightSampler& sampler, const Hit& h, const Vec3& x,
                         const Vec3& dir) const {
    const double cos_y = -dir.dot(c_.patches[h.patch].normal);
    return sampler.area_pdf(h.patch, h.position) * (h.position - x).squaredNorm() / cos_y;
  }

  static constexpr int kMaxShadingRays = 16 * 16;  // pixel_grid <= 16
  static constexpr int kMaxFineRays = 16 * 16;     // emission_grid <= 16

  // Where a shading ray's terms lie in the pixel's lists, and its path class.
  struct Shaded {
    std::size_t unknowns_begin, emission_begin, unknowns_end, emission_end;
    std::uint64_t key;
  };

  // The path classes met by a pixel's rays: how many finer and shading rays each has. At most
  // one class per ray, so fixed arrays and a linear search (a pixel meets a handful).
  class PathClasses {
   public:
    struct Class {
      std::uint64_t key;
      int fine, shading, first_fine;
    };
    void add_fine(std::uint64_t key, int m) {
      Class& c = at(key);
      if (c.fine++ == 0) c.first_fine = m;
    }
    void add_shading(std::uint64_t key) { ++at(key).shading; }
    const Class& find(std::uint64_t key) { return at(key); }
    int size() const { return n_; }
    const Class& operator[](int i) const { return classes_[i]; }

   private:
    Class& at(std::uint64_t key) {
      for (int i = 0; i < n_; ++i)
        if (classes_[i].key == key) return classes_[i];
      classes_[n_] = {key, 0, 0, -1};
      return classes_[n_++];
    }
    std::array<Class, kMaxShadingRays + kMaxFineRays> classes_;
    int n_ = 0;
  };

  static void scale(std::vector<Term>& terms, std::size_t begin, std::size_t end, double w) {
    const auto f = static_cast<float>(w);
    for (std::size_t t = begin; t < end; ++t)
      for (float& v : terms[t].w) v *= f;
  }

  // Cell (ray mod side^2) of a side x side grid over the pixel, at a jittered point: the pixel's
  // mean over its area, as the path-traced reference takes it (and no ray that meets an edge of the
  // scene exactly for every pixel along a line of symmetry: a point exactly on an edge lies, to
  // rounding, behind the wall it meets, and its gather rays see only back sides). The jitter is
  // the first two draws of the stream keyed by (pixel, ray); rng, when given, continues it.
  Ray pixel_ray(int x, int y, std::uint64_t pixel, int side, int ray, Rng* rng) const {
    Rng own(o_.seed, pixel, static_cast<std::uint64_t>(ray));
    Rng& r = rng ? *rng : own;
    const double ja = r.uniform32(), jb = r.uniform32();
    const int cell = ray % (side * side);
    return c_.camera.ray(x + (cell / side + ja) / side, y + (cell % side + jb) / side);
  }

  // The path class of a hit sequence: the objects a ray meets along its chain of delta lobes.
  static std::uint64_t add_to_key(std::uint64_t key, std::int64_t object) {
    return mix64(key ^ static_cast<std::uint64_t>(object + 2));
  }

  // Le along a finer ray's chain (the hits follow() shades: depth 0 to mirror_depth along the
  // delta lobes), w each times the mirrors' reflectances; *key its path class.
  long long emission_along(const Ray& ray, double w, PixelTerms& terms, std::uint64_t* key) const {
    Rgb weight = Rgb::Constant(w);
    long long rays = 1;
    Hit hit = c_.caster.intersect(ray.origin, ray.direction);
    Vec3 dir = ray.direction;
    *key = 0;
    for (int depth = 0;; ++depth) {
      if (!hit.valid() || !hit.front) {
        *key = add_to_key(*key, -1);
        return rays;
      }
      const Patch& p = c_.patches[hit.patch];
      *key = add_to_key(*key, p.object);
      if (p.emitter) terms.emission.push_back({hit.patch, scaled(weight, 1.0)});
      const Material& m = c_.materials[p.material];
      if (depth >= o_.mirror_depth || !m.has_lobe() || !m.is_delta()) return rays;
      weight *= m.specular;
      const Frame frame = Frame::from_normal(p.normal);
      dir = frame.to_world(reflect_about_normal(frame.to_local(-dir)));
      ++rays;
      hit = c_.caster.intersect_from(hit.position, hit.patch, dir);
    }
  }

  // A shading ray and its mirror chain, with unit weight (gather() scales it): the light
  // reflected at each hit, Le left to the finer rays; *key its path class.
  long long follow(const Ray& ray, const SubPixel& sub, Rng& rng, PixelTerms& terms,
                   std::uint64_t* key) const {
    Rgb weight = Rgb::Ones();
    long long rays = 1;
    Hit hit = c_.caster.intersect(ray.origin, ray.direction);
    Vec3 dir = ray.direction;
    *key = 0;
    for (int depth = 0;; ++depth) {
      if (!hit.valid() || !hit.front) {  // left the scene, or met a back side: black
        *key = add_to_key(*key, -1);
        return rays;
      }
      const Patch& p = c_.patches[hit.patch];
      *key = add_to_key(*key, p.object);
      const Material& m = c_.materials[p.material];
      const Frame frame = Frame::from_normal(p.normal);
      const Vec3 wo = frame.to_local(-dir);
      // Only where the diffuse part draws mirror images (shade(), mirror_images), at a front.
      const bool chained = chain_depth_ > 1 && o_.mirror_chain_budget > 0 &&
                           m.diffuse.maxCoeff() > 0.0 && wo.z() > 0.0;
      const MirrorChains chains =
          chained ? polyrad::mirror_chains(c_.mirrors, hit.position, chain_depth_,
                                           static_cast<std::size_t>(o_.mirror_chain_budget))
                  : MirrorChains{};
      if (chained && chains.roots > 0) terms.chains.count(chains.cut, chains.depth);
      const Shading sh{hit.patch, m, frame, hit.position, wo, weight, sub, hit.u, hit.v, &chains};
      if (sh.wo.z() > 0.0) rays += shade(sh, rng, terms);
      if (depth >= o_.mirror_depth || !m.has_lobe() || !m.is_delta()) {
        if (depth >= o_.mirror_depth && m.has_lobe() && m.is_delta())
          rays += read_reflected(sh, weight * m.specular, terms);
        return rays;
      }
      // The delta lobe: the reflected ray carries s times the radiance it meets.
      weight *= m.specular;
      dir = frame.to_world(reflect_about_normal(sh.wo));
      ++rays;
      hit = c_.caster.intersect_from(sh.x, sh.i, dir);
    }
  }

  // Deep enough in a mirror chain: the radiance arriving along the mirror direction, read as the
  // patch gather does, w L_{j->i} = w (B~_j + S_{j->i}) (emission included: nothing of j was
  // counted yet).
  long long read_reflected(const Shading& sh, const Rgb& w, PixelTerms& terms) const {
    const Vec3 dir = sh.frame.to_world(reflect_about_normal(sh.wo));
    const Hit next = c_.caster.intersect_from(sh.x, sh.i, dir);
    if (next.valid() && next.front) {
      const Rgbf wf = scaled(w, 1.0);
      add_diffuse(next.patch, next.u, next.v, wf, terms);
      add_link(next.patch, sh.i, wf, terms);
    }
    return 1;
  }

  // The non-delta parts of the BRDF at a point: direct light and first bounce.
  long long shade(const Shading& sh, Rng& rng, PixelTerms& terms) const {
    const Rgb d = sh.m.diffuse;
    const bool diffuse = d.maxCoeff() > 0.0;
    const bool lobe = sh.m.has_lobe() && !sh.m.is_delta();
    if (!diffuse && !lobe) return 0;
    long long rays = 0;
    // Where the diffuse part's indirect light comes from: with kMesh the unknown under x, unless
    // x lies near a surface; then, as without kMesh, rays (with their own count).
    bool from_mesh = diffuse && mesh_indirect_;
    int side = diffuse_side_;
    // The unknown under x, located once for both the probes' reach and the mesh's read.
    const DiffusePoint at = from_mesh ? locate(c_, sh.i, sh.u, sh.v) : DiffusePoint{};
    if (from_mesh && near_surface(sh, probe_size(at), rng, rays)) {
      from_mesh = false;
      side = mesh_near_side_;
    }
    const int nd = diffuse ? side * side : 0;
    const int ns = lobe ? lobe_side_ * lobe_side_ : 0;
    if (light_count_ > 0) rays += light_samples(sh, diffuse, lobe, nd, ns, rng, terms);
    if (from_mesh) mesh_reflected(sh, at, terms);
    if (diffuse) rays += cosine_samples(sh, side, from_mesh, rng, terms);
    if (lobe) rays += lobe_samples(sh, ns, rng, terms);
    // After this hit's other samples, so that they draw the same numbers with or without these
    // (a mirror chain's later hits do not: the chain shares one stream).
    if (diffuse && !from_mesh && reflector_count_ > 0) rays += reflector_points(sh, nd, rng, terms);
    if (diffuse && mirror_count_ > 0) rays += mirror_images(sh, rng, terms);
    return rays;
  }

  // The lamps' light that planar mirrors reflect to x, for the diffuse part: mirror_count_
  // points drawn on the lights by area, each seen at its image in every mirror plane that x and
  // the point both face (chain_image of one mirror), then the chains of facing mirrors.
  long long mirror_images(const Shading& sh, Rng& rng, PixelTerms& terms) const {
    const int side = mirror_side_, count = mirror_count_;
    const Rgb wd = sh.weight * sh.m.diffuse * (kInvPi / count);
    long long rays = 0;
    for (int s = 0; s < count; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      const Vec2 u = side * side == count ? Vec2((s % side + j1) / side, (s / side + j2) / side)
                                          : Vec2((s + j1) / count, j2);
      const LightSample l = c_.lights.sample(u);
      if (!(l.area_pdf > 0.0)) continue;
      for (std::int32_t q = 0; q < static_cast<std::int32_t>(c_.mirrors.planes.size()); ++q)
        rays += chain_image(sh, l, &q, 1, wd, terms);
    }
    if (sh.chains) rays += mirror_chains(sh, rng, terms);
    return rays;
  }

  // The chains of facing mirrors from x (sh.chains, transport/mirror_chains.h): each of n >= 2
  // mirrors, those after the first with no light on them, drawn with
  // mirror_image_samples / n^2 light points of its own, at least one (a lamp seen through many
  // mirrors is far and small, and each of its points costs n + 1 rays), cast only where the
  // point's image lies in the chain's beam. Chains longer than the budget holds
  // (GatherOptions::mirror_chain_budget), or in a scene of more than kMaxFacingPlanes planes,
  // leave their light to the links.
  long long mirror_chains(const Shading& sh, Rng& rng, PixelTerms& terms) const {
    const MirrorChains& chains = *sh.chains;
    long long rays = 0;
    std::array<std::int32_t, 64> chain{};
    for (std::int32_t at = chains.roots; at < static_cast<std::int32_t>(chains.chains.size());
         ++at) {
      const int n = chains.chains[static_cast<std::size_t>(at)].length;
      chains.planes_of(at, chain.data());
      const int count = std::max(1, mirror_count_ / (n * n));
      const Rgb wd = sh.weight * sh.m.diffuse * (kInvPi / count);
      for (int s = 0; s < count; ++s) {
        const double j1 = rng.uniform32(), j2 = rng.uniform32();
        const LightSample l = c_.lights.sample(Vec2(j1, j2));
        if (l.area_pdf > 0.0) rays += chain_image(sh, l, chain.data(), n, wd, terms, at);
      }
    }
    return rays;
  }

  // One light point l seen from x through the mirror planes chain[0, n) in turn (x -> chain[0]
  // -> ... -> chain[n-1] -> l), weight wd per unit of the estimate: at its image through them
  // all, l' = R_0(R_1(...R_{n-1}(l))), d s_0...s_{n-1} Le cos_x cos_l / (pi |x - l'|^2 pdf_A),
  // where the segment to l' crosses the first plane inside its box, a ray from x meets each
  // plane in turn and a shadow ray from the last reaches l (a path through the mirrors has that
  // length and those cosines). With n = 1 the image in one mirror (mirror_images); with a chain
  // of sh.chains (`kept`), the crossing must lie in its beam too, or no ray is cast.
  long long chain_image(const Shading& sh, const LightSample& l, const std::int32_t* chain, int n,
                        const Rgb& wd, PixelTerms& terms, std::int32_t kept = -1) const {
    const auto plane = [&](int t) -> const MirrorPlanes::Plane& {
      return c_.mirrors.planes[static_cast<std::size_t>(chain[t])];
    };
    Vec3 inner = l.point;  // l's image through chain[1, n)
    Rgb s = plane(n - 1).specular;
    for (int t = n - 1; t >= 1; --t) {
      inner = plane(t).image(inner);
      s *= plane(t - 1).specular;
    }
    const double hx = plane(0).height(sh.x), hp = plane(0).height(inner);
    if (!(hx > 0.0) || !(hp > 0.0) || !(plane(n - 1).height(l.point) > 0.0)) return 0;
    const Vec3 image = inner - 2.0 * hp * plane(0).normal;
    const Vec3 y = sh.x + (hx / (hx + hp)) * (image - sh.x);
    if (!plane(0).in_box(y)) return 0;
    if (kept >= 0 && !sh.chains->in_beam(kept, plane(0).coords(y))) return 0;
    const Vec3 to = image - sh.x;
    const double dist2 = to.squaredNorm();
    const Vec3 wi = to / std::sqrt(dist2);
    Vec3 onward = wi;  // from the last mirror to l
    for (int t = 0; t < n; ++t) onward = reflect_in_plane(onward, plane(t).normal);
    const double cos_x = wi.dot(sh.frame.n);
    const double cos_p = -onward.dot(c_.patches[l.patch].normal);
    if (!(cos_x > 0.0) || !(cos_p > 0.0)) return 0;
    long long rays = 1;
    Hit h = c_.caster.intersect(c_.caster.origin_from(sh.x, c_.patches[sh.i], wi), wi);
    Vec3 dir = wi;
    for (int t = 0;; ++t) {
      if (!h.valid() || !h.front || c_.mirrors.plane_of[h.patch] != chain[t]) return rays;
      if (t + 1 == n) break;
      dir = reflect_in_plane(dir, plane(t).normal);
      h = c_.caster.intersect_from(h.position, h.patch, dir);
      ++rays;
    }
    ++rays;
    if (c_.caster.segment_occluded(h.position, h.patch, l.point, l.patch)) return rays;
    terms.emission.push_back({l.patch, scaled(wd * s, cos_x * cos_p / (dist2 * l.area_pdf))});
    return rays;
  }

  // With mirror images, w times the part of S_{j->i} that the lamps' light reflected once by
  // mirror j puts there (its D, render/mesh_direct.h), taken out of a read of the diffuse part:
  // the mirror images gave that part at x.
  void subtract_mirrored_lights(PatchId j, PatchId i, const Rgbf& w, PixelTerms& terms) const {
    if (mirror_count_ == 0 || c_.mirrors.plane_of[j] < 0) return;
    const Eigen::Index link = c_.layout.link_unknown(j, i);
    if (link < 0) return;
    const MeshDirect& md = *c_.direct;
    const std::int32_t row = md.link_row_of(link, c_.layout.num_patches);
    if (row < 0) return;
    for (int o = 0; o < md.objects; ++o) {
      const auto& v = md.link_at(row, o);
      if (v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f) continue;
      terms.emission.push_back(
          {md.column[static_cast<std::size_t>(o)], {-w[0] * v[0], -w[1] * v[1], -w[2] * v[2]}});
    }
  }

  // IndirectMode::kMesh: the diffuse part's light beyond the direct light, from the unknown(s)
  // l under x (mesh_read: the one under it, or smooth, bilinear in its corners' averages):
  // B_l - E_l - sum_o D(l, o) e_o (render/mesh_direct.h). B_l = E_l + d (mean
  // arriving radiance), so this is d times what arrives at l from everything but the lights
  // themselves, with no d to apply again: each channel's weight is the chain's where d > 0.
  void mesh_reflected(const Shading& sh, const DiffusePoint& at, PixelTerms& terms) const {
    const Rgb& d = sh.m.diffuse;
    Rgb w = sh.weight;
    for (int c = 0; c < 3; ++c)
      if (!(d[c] > 0.0)) w[c] = 0.0;
    const std::size_t first = terms.unknowns.size();
    add_reflected(at, scaled(w, 1.0), terms, o_.mesh_read);
    const MeshDirect& md = *c_.direct;
    for (std::size_t k = first; k < terms.unknowns.size(); ++k) {
      const Term t = terms.unknowns[k];
      for (int o = 0; o < md.objects; ++o) {
        std::array<float, 3> v = md.at(t.column, o);
        if (mirror_count_ > 0) {  // the mirror images give the light the mirrors send l
          const auto& m = md.mirrored_at(t.column, o);
          for (int c = 0; c < 3; ++c) v[c] += m[c];
        }
        if (v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f) continue;
        terms.emission.push_back({md.column[static_cast<std::size_t>(o)],
                                  {-t.w[0] * v[0], -t.w[1] * v[1], -t.w[2] * v[2]}});
      }
    }
  }

  // The specular light the reflectors send x, S_{j->i}, from points on them (drawn by area),
  // weighted by the power heuristic against the nd cosine samples, which read the rest.
  long long reflector_points(const Shading& sh, int nd, Rng& rng, PixelTerms& terms) const {
    const int count = reflector_count_;
    long long rays = 0;
    for (int s = 0; s < count; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      const LightSample r = c_.reflectors.sample(
          point_stratum(sh.sub, kReflectorPoints, s, count, reflector_side_, j1, j2));
      const auto seen = seen_from(sh.x, sh.frame.n, r);
      if (!seen) continue;
      ++rays;
      if (c_.caster.segment_occluded(sh.x, sh.i, r.point, r.patch)) continue;
      const double cos_x = seen->cos_x, pdf = seen->pdf;
      const double w =
          kInvPi * cos_x * power_heuristic(count * pdf, nd * cos_x * kInvPi) / (pdf * count);
      rays += read_specular(sh, r.patch, r.point, seen->wi, sh.weight * sh.m.diffuse * w, true, rng,
                            terms);
    }
    return rays;
  }

  // What reflector j sends x along dir (met at p), w times: the diffuse part's (`diffuse`: a
  // cosine sample or reflector point) reads through a mirror that passes_through, or the link
  // S_{j->i} less the lamps' part the images gave; a lobe sample reads the link whole. Returns
  // the rays cast.
  long long read_specular(const Shading& sh, PatchId j, const Vec3& p, const Vec3& dir,
                          const Rgb& w, bool diffuse, Rng& rng, PixelTerms& terms) const {
    if (diffuse && (passes_through(j) || imaged_by_links(j, sh.i)))
      return through_mirror(sh.x, j, p, dir, w, rng, terms, imaged(j), true, sh.chains);
    const Rgbf wl = scaled(w, 1.0);
    add_link(j, sh.i, wl, terms);
    if (diffuse) subtract_mirrored_lights(j, sh.i, wl, terms);
    return 0;
  }

  // Whether a cosine sample or reflector point that meets patch j follows its ray through it:
  // j a delta mirror whose lamps' light the images give, or any with kAlways.
  bool passes_through(PatchId j) const {
    if (o_.through_mirrors == ThroughMirrors::kNever) return false;
    if (o_.through_mirrors == ThroughMirrors::kImaged && !imaged(j)) return false;
    const Material& m = c_.materials[c_.patches[j].material];
    return m.has_lobe() && m.is_delta();
  }
  // Whether the mirror images gave a diffuse part the lamps' light that mirror j reflects.
  bool imaged(PatchId j) const { return mirror_count_ > 0 && c_.mirrors.plane_of[j] >= 0; }
  // Whether the link S_{j->i} of a hierarchy leaves what mirror j shows i to its image links
  // (transport/hierarchy.h, eq. H4): the gathers at i then read through j instead.
  bool imaged_by_links(PatchId j, PatchId i) const {
    const auto& h = c_.layout.hierarchy;
    if (!h || h->mirrors().empty()) return false;
    const Eigen::Index link = c_.layout.link_unknown(j, i);
    const RootSpecular* sp = h->op()->specular();
    return link >= 0 && sp && sp->links_only[link - c_.layout.num_patches];
  }

  // A sample from x along dir met delta mirror j at p: w s_j times the radiance arriving at p
  // along the mirrored direction, read where that ray meets patch k at z: Le_k whole (no light
  // point draws that path), unless `images` (the mirror images gave it); the reflected light
  // B~_k - E~_k, or where z lies near x along the path the second gather there (`deeper`); and
  // the link S_{k->j}. The mirror's link S_{j->i} is one value per pair of patches (of roots, on
  // a hierarchy); this reads what the mirror shows at the sample. Returns the rays cast.
  //
  // With images, the ray follows on through the mirrors while the planes it meets are a chain
  // the images draw (`chains`, from x: each a facing one with no light on it, up to the budget's
  // length), reading the reflected light of those with a diffuse part as it passes them, and
  // reads where it leaves them; a lamp met there is the images'.
  long long through_mirror(const Vec3& x, PatchId j, Vec3 p, const Vec3& dir, const Rgb& w,
                           Rng& rng, PixelTerms& terms, bool images, bool deeper,
                           const MirrorChains* chains = nullptr) const {
    Rgb ws = w * c_.materials[c_.patches[j].material].specular;
    Vec3 out = reflect_in_plane(dir, c_.patches[j].normal);
    double behind = (p - x).norm();  // the path's length from x to the last mirror
    long long rays = 1;
    Hit z = c_.caster.intersect_from(p, j, out);
    // The chain of facing mirrors the ray has passed, as mirror_chains draws them.
    std::int32_t chain = images && chains ? chains->next(-1, c_.mirrors.plane_of[j]) : -1;
    while (chain >= 0 && z.valid() && z.front) {
      const std::int32_t q = c_.mirrors.plane_of[z.patch];
      chain = q >= 0 ? chains->next(chain, q) : -1;
      if (chain < 0) break;
      behind += z.t;
      p = z.position;
      j = z.patch;
      // A mirror with a diffuse part sends its reflected light B~_j too (no light lies on a
      // chain's plane): read here, as the link it stands for would have carried it.
      const Material& mj = c_.materials[c_.patches[j].material];
      if (mj.diffuse.maxCoeff() > 0.0)
        rays += read_along(z, p - behind * out, out, ws, deeper, rng, terms);
      ws *= mj.specular;
      out = reflect_in_plane(out, c_.patches[j].normal);
      z = c_.caster.intersect_from(p, j, out);
      ++rays;
    }
    if (!z.valid() || !z.front) return rays;
    const PatchId k = z.patch;
    if (c_.patches[k].emitter && !images) terms.emission.push_back({k, scaled(ws, 1.0)});
    add_link(k, j, scaled(ws, 1.0), terms);
    // x unfolded behind the last mirror's plane, as far from p as the path to it is long: the
    // near share then measures the length of the path x -> p -> z.
    return rays + read_along(z, p - behind * out, out, ws, deeper, rng, terms);
  }

  // The reflected light B~ at z, met along `in` by a path through mirrors from x (`unfolded`: x
  // where the path would be a straight line to z), w times: read from the unknown there, or
  // where the path is short against it and `deeper`, gathered again at z (near_share). Returns
  // the rays cast.
  long long read_along(const Hit& z, const Vec3& unfolded, const Vec3& in, const Rgb& w,
                       bool deeper, Rng& rng, PixelTerms& terms) const {
    const DiffusePoint at = locate(c_, z.patch, z.u, z.v);
    const double near = deeper ? near_share(unfolded, z.position, at.diameter) : 0.0;
    if (near < 1.0) add_reflected(at, scaled(w, 1.0 - near), terms, o_.diffuse);
    return near > 0.0 ? near_gather(z, -in, w * near, rng, terms) : 0;
  }

  // Next-event estimation: points on the lights; only their emission is read here (the light a
  // lamp reflects reaches x through the BRDF samples, as every other patch's does).
  long long light_samples(const Shading& sh, bool diffuse, bool lobe, int nd, int ns, Rng& rng,
                          PixelTerms& terms) const {
    const int count = light_count_;
    long long rays = 0;
    for (int s = 0; s < count; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      const LightSample l =
          c_.lights.sample(point_stratum(sh.sub, kLightPoints, s, count, light_side_, j1, j2));
      const auto seen = seen_from(sh.x, sh.frame.n, l);
      if (!seen) continue;
      const double cos_x = seen->cos_x;
      const Vec3 wi_local = sh.frame.to_local(seen->wi);
      const double lobe_value = lobe ? sh.m.lobe_eval(wi_local, sh.wo) : 0.0;
      if (!diffuse && !(lobe_value > 0.0)) continue;
      ++rays;
      if (c_.caster.segment_occluded(sh.x, sh.i, l.point, l.patch)) continue;
      const double light_pdf = seen->pdf;
      Rgb f = Rgb::Zero();  // f cos_x times each part's weight
      if (diffuse)
        f += sh.m.diffuse *
             (kInvPi * cos_x * power_heuristic(count * light_pdf, nd * cos_x * kInvPi));
      if (lobe_value > 0.0)
        f += sh.m.specular *
             (lobe_value * cos_x *
              power_heuristic(count * light_pdf, ns * sh.m.lobe_pdf(wi_local, sh.wo)));
      terms.emission.push_back({l.patch, scaled(sh.weight * f, 1.0 / (light_pdf * count))});
    }
    return rays;
  }

  // kMesh: the length the probes' reach is measured in at `at`: the diameter of the unknown
  // there, but on a hierarchy at least half its root's. A leaf's light from the many sources that
  // each bring it little comes on links at or near its root, each spread linearly over its
  // receiver: a surface within the root's size shadows a part of it that those links cannot
  // follow, however fine the leaf (on the room, with the leaf's own diameter, the refinement passes
  // made more leaves and fewer near points: the north wall's region 1.6 percent dark against
  // Cycles, the bookcase's 3.1; with half the root's 0.9 and 1.6; with the whole root's 0.7
  // and 1.5, but on the mirror cube 0.0702 against 0.0694 in 1.6 s more, the near points' noise).
  double probe_size(const DiffusePoint& at) const {
    return std::max(at.diameter, 0.5 * c_.diameters[static_cast<std::size_t>(at.patch)]);
  }

  // kMesh: whether a surface lies within mesh_near_distance times `size` (probe_size) of x, by up
  // to kNearProbes cosine rays (the first that finds one ends the search; each adds to rays).
  // The unknown's B is its mean over its area: near another surface the light arriving changes
  // across it, and the mean is the wrong value at x (on the mirror cube's hierarchy, with a grid of
  // 4 elevations by 2 azimuths, 4, 8 and 16 probes gave relative RMSE 0.0695, 0.0694 and 0.0691).
  static constexpr int kNearProbes = 8;
  bool near_surface(const Shading& sh, double size, Rng& rng, long long& rays) const {
    if (!(o_.mesh_near_distance > 0.0)) return false;
    const double reach = o_.mesh_near_distance * size;
    for (int s = 0; s < kNearProbes; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      // 2 strata of the radius (elevation) by 4 of the azimuth: a wall on one side lies in one
      // azimuth more than in one elevation.
      const Vec3 wi = sample_cosine_hemisphere(Vec2((s / 4 + j1) / 2, (s % 4 + j2) / 4));
      if (!(wi.z() > 0.0)) continue;
      ++rays;
      const Vec3 dir = sh.frame.to_world(wi);  // a short ray, asked only whether it meets any
      if (c_.caster.occluded(c_.caster.origin_from(sh.x, c_.patches[sh.i], dir), dir, 0.0, reach))
        return true;
    }
    return false;
  }

  // The diffuse part: d (cosine-weighted mean of the arriving radiance), by a stratified grid
  // of side x side cosine samples; from_mesh: the mesh gave the indirect light (kMesh), so they
  // only find the lights.
  long long cosine_samples(const Shading& sh, int side, bool from_mesh, Rng& rng,
                           PixelTerms& terms) const {
    const int count = side * side;
    long long rays = 0;
    const Rgb w = sh.weight * sh.m.diffuse / count;
    for (int s = 0; s < count; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      const Vec3 wi = sample_cosine_hemisphere(stratum(sh.sub, kCosine, s, side, j1, j2));
      if (!(wi.z() > 0.0)) continue;
      const Vec3 dir = sh.frame.to_world(wi);
      // With the mesh's indirect light such a sample can only add a light's Le: one that no
      // light's box lies along finds nothing, and is not traced.
      const Vec3 origin = c_.caster.origin_from(sh.x, c_.patches[sh.i], dir);
      if (from_mesh && !c_.light_bounds.may_meet(origin, dir)) continue;
      ++rays;
      const Hit h = c_.caster.intersect(origin, dir);
      if (!h.valid() || !h.front) continue;
      if (from_mesh) {  // the mesh gave the rest: only a light's weighted share of Le
        add_emission(sh, h, dir, w, wi.z() * kInvPi, count, terms);
        continue;
      }
      rays += add_arriving(sh, h, dir, w, wi.z() * kInvPi, count, rng, terms, true);
    }
    return rays;
  }

  // The glossy part: s times the mean of beta L over a stratified grid of lobe samples.
  long long lobe_samples(const Shading& sh, int count, Rng& rng, PixelTerms& terms) const {
    const int side = lobe_side_;
    long long rays = 0;
    for (int s = 0; s < count; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      const LobeSample ls = sh.m.lobe_sample(sh.wo, stratum(sh.sub, kLobe, s, side, j1, j2));
      if (!(ls.weight > 0.0)) continue;
      const Vec3 dir = sh.frame.to_world(ls.wi);
      ++rays;
      const Hit h = c_.caster.intersect_from(sh.x, sh.i, dir);
      if (!h.valid() || !h.front) continue;
      rays += add_arriving(sh, h, dir, sh.weight * sh.m.specular * (ls.weight / count), ls.pdf,
                           count, rng, terms);
    }
    return rays;
  }

  // A BRDF sample from x along dir met h: w times the reflected radiance there toward i, and,
  // at a light, w times its emission with this strategy's weight against the light points
  // (pdf: this sample's solid-angle density, count: its strategy's sample count). Returns the
  // rays a near hit's second gather cast. A cosine sample (`cosine`) that meets a reflector
  // weights its link against the reflector points.
  long long add_arriving(const Shading& sh, const Hit& h, const Vec3& dir, const Rgb& w, double pdf,
                         int count, Rng& rng, PixelTerms& terms, bool cosine = false) const {
    const PatchId j = h.patch;
    add_emission(sh, h, dir, w, pdf, count, terms);
    // The specular link toward i (or, at a delta mirror, what it shows: through_mirror), and
    // the diffuse part's reflected light: from the mesh, B~ - E~, or, where y is near x, by a
    // second gather at y (with a blend between the two).
    double link_mis = 1.0;
    if (cosine && reflector_count_ > 0 && c_.reflectors.select_pdf(j) > 0.0)
      link_mis = power_heuristic(count * pdf,
                                 reflector_count_ * solid_angle_pdf(c_.reflectors, h, sh.x, dir));
    long long rays = read_specular(sh, j, h.position, dir, w * link_mis, cosine, rng, terms);
    const DiffusePoint at = locate(c_, j, h.u, h.v);
    const double near = near_share(sh.x, h.position, at.diameter);
    if (near < 1.0) add_reflected(at, scaled(w, 1.0 - near), terms, o_.diffuse);
    if (near > 0.0) rays += near_gather(h, -dir, w * near, rng, terms);
    return rays;
  }

  // Where a BRDF sample met a light: w times its Le, weighted against the light points.
  void add_emission(const Shading& sh, const Hit& h, const Vec3& dir, const Rgb& w, double pdf,
                    int count, PixelTerms& terms) const {
    const PatchId j = h.patch;
    if (!c_.patches[j].emitter) return;
    double mis = 1.0;
    if (light_count_ > 0)
      mis = power_heuristic(count * pdf, light_count_ * solid_angle_pdf(c_.lights, h, sh.x, dir));
    if (mis > 0.0) terms.emission.push_back({j, scaled(w, mis)});
  }

  // w (B~_j - E~_j) at (u, v) of j (flat: w (B_j - E_j)): the diffuse light j reflects, read
  // smooth or flat as the options' diffuse mode says, or for kMesh's read at the shading point
  // as its mesh_read says.
  void add_reflected(const DiffusePoint& at, const Rgbf& w, PixelTerms& terms,
                     DiffuseMode read) const {
    const bool smooth = read == DiffuseMode::kSmooth;
    gather_detail::add_diffuse(c_, at, w, terms.unknowns, smooth);
    const PatchId j = at.patch;
    if (smooth) {
      c_.corners.subtract_emission(j, at.u, at.v, w, terms.emission);
    } else if (c_.patches[j].emitter) {
      terms.emission.push_back({j, {-w[0], -w[1], -w[2]}});
    }
  }

  // How much of the diffuse light reflected at a hit y is gathered again there instead of read
  // from the mesh: 1 within near_distance diameters (size) of the unknown read at y (its patch,
  // or the leaf under it) from x, 0 beyond twice that, linear between. An unknown's B averages
  // its light over its area: seen from closer than its size, the average is the wrong value (a
  // floor patch half in a block's contact shadow, read from the block's base), which a gather
  // one bounce further does not suffer.
  double near_share(const Vec3& x, const Vec3& y, double size) const {
    if (near_count_ == 0 || o_.near_distance <= 0.0) return 0.0;
    if (!(size > 0.0)) return 0.0;  // a degenerate patch: read it
    const double d = (y - x).norm() / o_.near_distance;
    return std::clamp(2.0 - d / size, 0.0, 1.0);
  }

  // The second gather at a near hit h on j, seen from direction wo (world): w d_j times the
  // cosine-weighted mean of the radiance arriving at y, by near_samples light points (direct,
  // emission) and near_samples cosine samples (emission with their weight, and the reflected
  // light B~ - E~ + S_{k->j} where they land), combined as at the first hit.
  long long near_gather(const Hit& h, const Vec3& wo, const Rgb& w, Rng& rng,
                        PixelTerms& terms) const {
    const PatchId j = h.patch;
    const Patch& pj = c_.patches[j];
    const Rgb wd = w * c_.materials[pj.material].diffuse;
    if (!(wd.maxCoeff() > 0.0) || !(wo.dot(pj.normal) > 0.0)) return 0;
    const Frame frame = Frame::from_normal(pj.normal);
    const Vec3& y = h.position;
    const int side = near_side_, count = near_count_;
    const int lights = c_.lights.empty() ? 0 : count;
    long long rays = 0;
    for (int s = 0; s < lights; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      const LightSample l = c_.lights.sample(Vec2((s % side + j1) / side, (s / side + j2) / side));
      const auto seen = seen_from(y, pj.normal, l);
      if (!seen) continue;
      ++rays;
      if (c_.caster.segment_occluded(y, j, l.point, l.patch)) continue;
      const double cos_y = seen->cos_x, light_pdf = seen->pdf;
      const double f = kInvPi * cos_y * power_heuristic(lights * light_pdf, count * cos_y * kInvPi);
      terms.emission.push_back({l.patch, scaled(wd, f / (light_pdf * lights))});
    }
    for (int s = 0; s < count; ++s) {
      const double j1 = rng.uniform32(), j2 = rng.uniform32();
      const Vec3 wi =
          sample_cosine_hemisphere(Vec2((s % side + j1) / side, (s / side + j2) / side));
      if (!(wi.z() > 0.0)) continue;
      const Vec3 dir = frame.to_world(wi);
      ++rays;
      const Hit z = c_.caster.intersect_from(y, j, dir);
      if (!z.valid() || !z.front) continue;
      const Rgb wz = wd / count;
      const PatchId k = z.patch;
      if (c_.patches[k].emitter) {
        double mis = 1.0;
        if (lights > 0)
          mis = power_heuristic(count * wi.z() * kInvPi,
                                lights * solid_angle_pdf(c_.lights, z, y, dir));
        if (mis > 0.0) terms.emission.push_back({k, scaled(wz, mis)});
      }
      add_reflected(locate(c_, k, z.u, z.v), scaled(wz, 1.0), terms, o_.diffuse);
      if (imaged_by_links(k, j))  // no images drawn at y: the lamps beyond are read too
        rays += through_mirror(y, k, z.position, dir, wz, rng, terms, false, false);
      else
        add_link(k, j, scaled(wz, 1.0), terms);
    }
    return rays;
  }

  // w times B at (u, v) of patch j, flat or smooth (or from the leaves under it).
  void add_diffuse(PatchId j, double u, double v, const Rgbf& w, PixelTerms& terms) const {
    gather_detail::add_diffuse(c_, j, u, v, w, terms.unknowns);
  }
  // w times S_{j->i}, where that link is an unknown.
  void add_link(PatchId j, PatchId i, const Rgbf& w, PixelTerms& terms) const {
    const Eigen::Index link = c_.layout.link_unknown(j, i);
    if (link >= 0) terms.unknowns.push_back({static_cast<std::int32_t>(link), w});
  }

  const GatherContext& c_;
  const GatherOptions& o_;
  const int diffuse_side_, lobe_side_, light_count_, light_side_, reflector_count_, reflector_side_,
      near_side_, near_count_, mirror_count_, mirror_side_, chain_depth_;
  const bool mesh_indirect_;
  const int mesh_near_side_;
};

}  // namespace

long long final_gather_pixel(const GatherContext& c, int x, int y, PixelTerms& terms,
                             const std::uint64_t* shared) {
  return FinalGatherer(c).gather(x, y, terms, shared);
}

CoarseClass final_gather_coarse(const GatherContext& c, int x, int y, PixelTerms& scratch,
                                long long& rays) {
  const std::optional<std::uint64_t> k = FinalGatherer(c).coarse_class(x, y, scratch, rays);
  return {k.value_or(0), k.has_value()};
}

const std::uint64_t* CoarseClasses::shared_around(int x, int y) const {
  const CoarseClass& centre = at(x, y);
  if (!centre.uniform) return nullptr;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int u = x + dx, v = y + dy;
      // At the image's border the neighbours beyond it are not there to guard: the finer rays.
      if (u < 0 || v < 0 || u >= width || v >= height) return nullptr;
      const CoarseClass& c = at(u, v);
      if (!c.uniform || c.key != centre.key) return nullptr;
    }
  return &centre.key;
}

}  // namespace polyrad::gather_detail
