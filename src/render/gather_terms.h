// What the two camera gathers (camera_gather.cpp, final_gather.cpp) share inside the library: a
// pixel's terms, the smooth-shading corner averages, and the context a pixel is gathered in.
// Not installed: the public interface is include/polyrad/render/camera_gather.h.
#pragma once

#include <cstdint>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/scene/brdf.h"
#include "polyrad/transport/hierarchy.h"
#include "polyrad/transport/mirror_planes.h"
#include "polyrad/world/light_sampling.h"

namespace polyrad::gather_detail {

struct Term {
  std::int32_t column;
  Rgbf w;
};

// One pixel's weights: over the unknowns (G) and over the patches' emission (E).
struct PixelTerms {
  std::vector<Term> unknowns, emission;
  MirrorChainCount chains;  // over every pixel gathered into these terms (not cleared)
  void clear() {
    unknowns.clear();
    emission.clear();
  }
};

// Adds the weights of equal columns and sorts by column: one entry per (pixel, column). A slot
// per column remembers where a pixel's first term of that column went, so the terms merge in
// one pass and only the distinct columns are sorted (a sort of all of a pixel's terms took 5
// percent of the mirror cube's hierarchical render). One per thread.
class TermMerger {
 public:
  explicit TermMerger(std::int64_t columns) : slot_(static_cast<std::size_t>(columns), -1) {}
  // Requires every column in [0, columns).
  void merge(std::vector<Term>& terms);

 private:
  std::vector<std::int32_t> slot_;  // per column: its entry in the merged terms, or -1
};

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
  const LightBounds& light_bounds;  // whether a ray may meet a light (the final gather's kMesh)
  const LightSampler& reflectors;  // the final gather's reflector points (by area)
  const std::vector<double>& diameters;  // per patch, Patch::diameter (asked at every hit)
  const MeshDirect* direct;  // the final gather's IndirectMode::kMesh or mirror images; else null
  const MirrorPlanes& mirrors;  // empty unless the final gather draws mirror images
};

// Where a hit reads B: (u, v) on patch p and, with a hierarchy, the leaf under it, located once
// for both what the final gather asks of it (its size, then its value).
struct DiffusePoint {
  PatchId patch;
  double u, v;
  LeafPoint leaf;   // with a hierarchy; else leaf.leaf < 0
  double diameter;  // of the unknown read there: the leaf, or the patch
};
DiffusePoint locate(const GatherContext& c, PatchId p, double u, double v);

// w times B at a point, flat or smooth: the patch itself, its corners' averages, or with a
// hierarchy the leaf (or the leaves' corners) under the point.
void add_diffuse(const GatherContext& c, const DiffusePoint& at, const Rgbf& w,
                 std::vector<Term>& terms, bool smooth);
inline void add_diffuse(const GatherContext& c, const DiffusePoint& at, const Rgbf& w,
                        std::vector<Term>& terms) {
  add_diffuse(c, at, w, terms, c.options.diffuse == DiffuseMode::kSmooth);
}
inline void add_diffuse(const GatherContext& c, PatchId p, double u, double v, const Rgbf& w,
                        std::vector<Term>& terms) {
  add_diffuse(c, locate(c, p, u, v), w, terms);
}

// The path class a pixel's coarse finer rays (four of the final gather's emission grid) all
// meet, where they agree and none meets an emitter (uniform).
struct CoarseClass {
  std::uint64_t key = 0;
  bool uniform = false;
};
// Those of image rows first_row onward (cls.size() / width of them): a block's rows and one more
// on each side.
struct CoarseClasses {
  int width = 0, height = 0;  // the image's
  int first_row = 0;
  std::vector<CoarseClass> cls;  // row-major from first_row
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y - first_row) * static_cast<std::size_t>(width) +
           static_cast<std::size_t>(x);
  }
  const CoarseClass& at(int x, int y) const { return cls[index(x, y)]; }
  // The class pixel (x, y) and its eight neighbours all share, or null (also at the image's
  // border). Where a pixel's own four rays and its neighbours' 32 meet one class and no emitter,
  // its finer rays are taken to add that class and no Le: an edge or a lamp's sliver within the
  // pixel would have to lie between them all (features thinner than about a third of a pixel).
  const std::uint64_t* shared_around(int x, int y) const;
};

// The terms of pixel (x, y); each returns the number of rays cast.
long long patch_gather_pixel(const GatherContext& c, int x, int y, PixelTerms& terms);
// shared: the class its neighbourhood shares (CoarseClasses::shared_around), or null. Given, the
// finer rays are cast only if a shading ray meets another class (else each is taken to add that
// class and no Le).
long long final_gather_pixel(const GatherContext& c, int x, int y, PixelTerms& terms,
                             const std::uint64_t* shared = nullptr);
// Pixel (x, y)'s coarse class; adds the rays cast to `rays`.
CoarseClass final_gather_coarse(const GatherContext& c, int x, int y, PixelTerms& scratch,
                                long long& rays);

}  // namespace polyrad::gather_detail
