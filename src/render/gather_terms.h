// What the two camera gathers (camera_gather.cpp, final_gather.cpp) share inside the library: a
// pixel's terms, the smooth-shading corner averages, and the context a pixel is gathered in.
// Not installed: the public interface is include/polyrad/render/camera_gather.h.
#pragma once

#include <cstdint>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/world/light_sampling.h"

namespace polyrad::gather_detail {

struct Term {
  std::int32_t column;
  Rgbf w;
};

// One pixel's weights: over the unknowns (G) and over the patches' emission (E).
struct PixelTerms {
  std::vector<Term> unknowns, emission;
  void clear() {
    unknowns.clear();
    emission.clear();
  }
};

// Sorts by column and adds the weights of equal columns: one entry per (pixel, column).
void merge_terms(std::vector<Term>& terms);

inline Rgbf scaled(const Rgb& c, double s) {
  return {static_cast<float>(c[0] * s), static_cast<float>(c[1] * s), static_cast<float>(c[2] * s)};
}

// For smooth shading: each patch corner as a weighted average of patches (same object, normals
// within 10 degrees) that share the welded corner.
class CornerAverages {
 public:
  // weight: one per patch, the exposed areas (flux weights / pi) where the patches are the
  // unknowns: a buried patch does not darken its neighbours' corners.
  CornerAverages(const PatchSet& patches, const std::vector<double>& weight);

  // Adds w * (smoothly interpolated B at (u, v) on p) to terms.
  void add(PatchId p, double u, double v, const Rgbf& w, std::vector<Term>& terms) const;
  // Adds -w * (the same interpolation of the emission E) to terms, over emitting patches only:
  // with add(), w (B - E) interpolated, the reflected part of the diffuse radiance.
  void subtract_emission(PatchId p, double u, double v, const Rgbf& w,
                         std::vector<Term>& terms) const;

 private:
  const PatchSet& patches_;
  std::vector<std::size_t> start_;
  std::vector<std::pair<PatchId, double>> entries_;
};

// Everything a pixel is gathered from. The light sampler draws the patches of the scene's
// named lights by area (World::lights()): relighting may give any of them any emission, so the
// choice must not depend on the scene's values. patches are the world's, where rays land; the
// B unknowns are those patches, or the leaves of layout.hierarchy.
struct GatherContext {
  const Camera& camera;
  const PatchSet& patches;
  const std::vector<Material>& materials;
  const RayCaster& caster;
  const UnknownLayout& layout;
  const GatherOptions& options;
  const CornerAverages& corners;
  const LightSampler& lights;
  const LightSampler& reflectors;  // the final gather's reflector points (by area)
};

// w times B at (u, v) of patch p, flat or smooth: the patch itself, its corners' averages, or
// with a hierarchy the leaf (or the leaves' corners) under the point.
void add_diffuse(const GatherContext& c, PatchId p, double u, double v, const Rgbf& w,
                 std::vector<Term>& terms);

// The terms of pixel (x, y); each returns the number of rays cast.
long long patch_gather_pixel(const GatherContext& c, int x, int y, PixelTerms& terms);
long long final_gather_pixel(const GatherContext& c, int x, int y, PixelTerms& terms);

}  // namespace polyrad::gather_detail
