// The path-traced reference: unidirectional Monte Carlo over the same patches, materials, ray
// caster and camera as the radiosity solution, sharing none of its discretisation.
//
// Estimator, per path vertex x with outgoing direction wo (the rendering equation,
// papers/glossy-radiosity.md, (R1), integrated over directions):
//   - next-event estimation: one point y on an emitter patch, the patch chosen with probability
//     proportional to luminance(emission) * area, y from Patch::sample; area density
//     P(patch) / (area * density(y)), turned into solid angle by |x - y|^2 / cos(theta_y);
//   - BSDF sampling through Material::sample; an emitter met by that ray counts with the other
//     half of the multiple-importance weight (power heuristic, exponent 2), so every path of
//     light is counted once with weights that sum to 1;
//   - a delta (mirror) bounce has no light sample; the emitter it meets counts fully;
//   - Russian roulette on every segment after the third: the path goes on with probability
//     q = min(1, max channel of its weight) and the weight is divided by q, so the expectation
//     is unchanged.
// Patches are one-sided: a ray that meets a back side ends there (black, as in the radiosity
// model); emission is Lambertian from the front only.
//
// The one bias is max_depth: paths of more than max_depth segments are dropped. With albedo at
// most a, what is lost is at most a^max_depth / (1 - a) of the emission scale: 1e-10 relative at
// a = 0.7 and 64 segments, but half the furnace at a = 0.99 (facing mirrors of 0.99 at 64: a
// tenth of the paths cut, the image 10.7 percent dark against 4096), hence the default 1024,
// which costs nothing where no path is that long (roulette ends them: the Cornell box's image
// and time are the same as at 64) and 10 percent more time on those mirrors; `truncated` counts
// the paths it cut, and the render command warns when they are one in 10,000 or more.
//
// Deterministic: the random stream of a sample is keyed by (seed, pixel, sample index), never by
// thread, so an image is the same on any number of threads.
//
//   PathTracer pt(world);
//   PathTraceOptions o;
//   o.spp = 256;
//   PathTraceResult r = pt.render(scene.camera, o);   // r.image: mean radiance per pixel
//
// Cost: spp x pixels x (mean path length) x 2 rays (one extension, one shadow ray a vertex);
// memory: the image (and the error image when asked for), nothing per path.
#pragma once

#include <cstdint>
#include <vector>

#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/render/image.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/scene/camera.h"
#include "polyrad/util/sampling.h"
#include "polyrad/world/light_sampling.h"
#include "polyrad/world/world.h"

namespace polyrad {

struct PathTraceOptions {
  int spp = 64;  // samples per pixel, each a uniformly jittered point of the pixel
  std::uint64_t seed = 1;
  int max_depth = 1024;         // most segments a path may have (camera -> ... -> emitter)
  int roulette_depth = 3;       // Russian roulette starts after this many segments
  bool next_event = true;       // false: BSDF sampling only (for tests of the MIS weights)
  bool standard_error = false;  // also estimate each pixel's standard error
  bool progress = true;         // show a Progress display (when enabled at all)
  int tile = 16;                // tile side in pixels; work is scheduled tile by tile
};

// Counters of one render or radiance() call; summed over threads.
struct PathStats {
  long long paths = 0;
  long long rays = 0;       // extension and shadow rays
  long long truncated = 0;  // paths cut by max_depth with weight, on a surface that reflects
  void add(const PathStats& o) {
    paths += o.paths;
    rays += o.rays;
    truncated += o.truncated;
  }
};

struct PathTraceResult {
  Image image;           // linear radiance: the mean over the pixel's samples
  Image standard_error;  // per pixel and channel, sample standard deviation / sqrt(spp); empty
                         // unless options.standard_error (and spp > 1)
  PathStats stats;
  double seconds = 0.0;
};

class PathTracer {
 public:
  // Keeps a reference: the world must outlive the tracer.
  explicit PathTracer(const World& world);

  PathTraceResult render(const Camera& camera, const PathTraceOptions& options = {}) const;

  // One sample of the radiance arriving at `origin` from direction -`direction` (that is, the
  // radiance leaving the first surface the ray meets toward origin); `direction` is unit length.
  // Uses options' max_depth, roulette_depth and next_event; adds to stats when given.
  Rgb radiance(const Vec3& origin, const Vec3& direction, Rng& rng,
               const PathTraceOptions& options = {}, PathStats* stats = nullptr) const;

  // Total emitted power weight sum(luminance(emission) * area) the light sampler draws from;
  // 0 when the scene has no emitter.
  double emitter_weight() const { return lights_.total_weight(); }

 private:
  const PatchSet& patches_;
  const std::vector<Material>& materials_;
  const RayCaster& caster_;
  LightSampler lights_;  // next-event estimation, by emitted power
};

}  // namespace polyrad
