// The camera gather: each pixel as a fixed linear combination of the unknowns and of the
// patches' emission, image = G u + E e (papers/glossy-radiosity.md, section 7).
//
// Two kinds. The patch gather (GatherKind::kPatch; E is empty) reads the solution where each
// primary ray of the pixel meets patch i at x, seen from direction v:
//   diffuse part  B_i (flat) or B interpolated from the corners of i (smooth: each corner
//                 averages the patches of the same object and orientation that share it);
//   mirror part   s_i * L_{j->i}, j met by the reflected ray;
//   glossy part   s_i * mean over a fixed set of lobe samples of beta * L_{j->i}, combined by
//                 multiple importance with a fixed set of points on the lights (patches of
//                 objects with an "emission" key, drawn by area);
// with L_{j->i} = B_j + S_{j->i}. Every shadow is then as wide as a patch.
//
// The final gather (GatherKind::kFinal, section 7.1) computes the pixel's light at its own
// surface point and uses the mesh only one bounce away. Along each shading ray's chain of
// mirrors (delta lobes, up to mirror_depth bounces), at every hit x on patch i (eq. 11):
//   L(x, v) = Le_i + integral f Le(y) cos_x dw                          (direct; E)
//           + integral f (B~_j(y) - E~_j(y) + S_{j->i}) cos_x dw        (first bounce; G, -E)
// The direct term takes stratified points on the lights with shadow rays, weighted by the
// power heuristic against the BRDF samples (cosine samples for the diffuse part, lobe samples
// for the glossy part); those same samples read the reflected light where they land, and when
// they land on a light, their weighted share of its Le. Emission is read once, in E. Near hits
// gather the diffuse light there again; Le of what a pixel sees comes from a finer grid of rays.
// With reflector_samples (64 in final_gather()), points drawn by area on the patches that send
// specular links read the diffuse part's S_{j->i} too, weighted by the power heuristic against
// the cosine samples.
// With mirror_image_samples, the light of the lamps that one planar mirror j reflects to x is
// taken at x too: light points p seen in j's plane, at their images, each with a ray to the
// mirror and a shadow ray from it to p (the mirror image of a lamp, section 8, exactly where the
// links would spread it over patches); the diffuse part's reads of S_{j->i} then leave out that
// part of the link, sum_o D(j->i, o) e_o (render/mesh_direct.h), so nothing is counted twice;
// with IndirectMode::kMesh the read of the unknown under x leaves out what the mirrors' links
// brought it of the lamps' light likewise. With mirror_image_depth above 1 (16 in
// final_gather(), which kMesh does not use: mirror_chain_depth), the lamps are also drawn at
// their images through chains of mirrors that face each other, p' = R_a(R_b(R_c(...(p)))),
// those whose beam from x is not empty (transport/mirror_chains.h, up to mirror_chain_budget of
// them), checked by a ray to each mirror in turn, and a sample read through a mirror follows its
// ray on through such a chain; so between facing mirrors the light is not left to links that
// forget where it met each one.
// Where a cosine sample meets a delta mirror j whose lamps' light the mirror images give
// (through_mirrors, default kImaged), the gather follows it through the mirror: s_j times what
// the mirrored ray meets, its reflected light B~ - E~ at the unknown under the hit (or the second
// gather there, where the path through the mirror is short) and its link toward j; so what a
// mirror shows is resolved per sample, not per pair of patches (on a hierarchy, of roots). With
// kAlways every delta mirror is followed, by the reflector points on it too (none are drawn on
// imaged mirrors), and the Le met through a mirror the images do not give is read there. Lobe
// samples, the second gather and the mirror chains read the links whole; but on a hierarchy with
// image links (transport/hierarchy.h, eq. H4) a mirror's link to a root without a lobe no longer
// carries what the mirror shows, and both gathers at such a root read through the mirror there.
// With a hierarchical mesh (UnknownLayout::hierarchy) B is read from the leaves under a hit.
// With IndirectMode::kMesh the diffuse part's first bounce is not gathered: at a hit on unknown
// l it is read as B_l - E_l - sum_o D(l, o) e_o, l's light beyond what the lights give it
// directly (render/mesh_direct.h), and the cosine samples only weigh the lights they meet
// against the light points; but where a surface lies within mesh_near_distance diameters of l
// (on a hierarchy, at least half its root's), the point is gathered by rays as above. A glossy
// part's lobe samples, and a chain that reaches mirror_depth, still read the mesh where they
// land, as with rays.
//
// Nothing here depends on the values of u or e, so the view-mode precompute folds both into its
// operator: Q = E S + G P_K S (eq. 12).
//
//   const GatherOptions o = GatherOptions::final_gather();
//   Gather g = build_gather(*world, t.layout(), o, mesh_direct_for(o, t, *world).get());
//   Image img = apply_gather(g, solution.u, scene_emission(world->patches()));
//
// Cost: the patch gather casts pixels x sub-pixel rays x (1 + lobe samples + light samples)
// rays. The final gather casts per pixel 4 coarse rays and, where they or its neighbours' rays
// meet more than one path class or a lamp (emission_grid_everywhere), emission_grid^2 finer
// ones, then per shading ray and hit
// light samples + gather samples (diffuse part, + reflector samples where a scene has them)
// + lobe samples (glossy part) + 2 rays per mirror image (a light point and a mirror plane whose
// outline lets it through) + 1 per sample read through a mirror (and 1 per further mirror of a
// chain it follows), and 2 near_samples more where a sample lands near; between facing
// mirrors, for each chain of n of them kept (up to mirror_chain_budget),
// max(1, mirror_image_samples / n^2) light points, of up to n + 1 rays where the point's image
// lies in the chain's beam (about 480 rays a hit at depth 16 on the facing mirrors, on 2 mirror
// planes), and the chains' beams clipped in the plane (a few microseconds a hit on two facing
// mirrors, about 100 on four mirror walls at the default budget): about 710
// rays a pixel on cornell-box with the defaults (760 with the finer rays everywhere). With kMesh,
// up to 8 short probe rays per hit with a diffuse part, and where they find a surface
// mesh_near_samples cosine samples (and reflector samples, if asked) as above, at every such hit of
// a mirror chain. Memory 16 bytes per entry after merging each pixel's equal columns (a final
// gather: about 190 entries a pixel on cornell-box, 12 million for 256 x 256); a deferred gather
// (defer_gather) is never stored whole, its rows are built block by block where they are used.
#pragma once

#include <algorithm>
#include <array>
#include <functional>
#include <memory>

#include "polyrad/render/image.h"
#include "polyrad/render/mesh_direct.h"
#include "polyrad/scene/camera.h"
#include "polyrad/transport/transport.h"
#include "polyrad/util/enum_names.h"
#include "polyrad/util/sparse.h"
#include "polyrad/world/world.h"

namespace polyrad {

enum class DiffuseMode { kFlat, kSmooth };
template <>
struct EnumNames<DiffuseMode> {
  static constexpr const char* kind = "diffuse shading";
  static constexpr std::array<std::pair<DiffuseMode, const char*>, 2> table{
      {{DiffuseMode::kSmooth, "smooth"}, {DiffuseMode::kFlat, "flat"}}};
};

enum class GatherKind { kPatch, kFinal };

// Where the final gather takes the light a point reflects beyond the direct light: from rays
// (cosine samples and reflector points reading the mesh one bounce away), or from the mesh at
// the point itself (B - E - D e of the unknown under it, render/mesh_direct.h).
enum class IndirectMode { kRays, kMesh };
template <>
struct EnumNames<IndirectMode> {
  static constexpr const char* kind = "indirect light";
  static constexpr std::array<std::pair<IndirectMode, const char*>, 2> table{
      {{IndirectMode::kRays, "rays"}, {IndirectMode::kMesh, "mesh"}}};
};
// Where a final gather's cosine sample or reflector point meets a delta mirror j: read its link
// S_{j->i}, one value per pair of patches (of roots, on a hierarchy) (kNever); or follow the
// sample through the mirror and read what the mirrored ray meets, where the mirror images give
// the lamps' light that j reflects (kImaged), or at every mirror (kAlways: the lamps seen in a
// mirror without images, a bent one or all with mirror_image_samples 0, then found by the
// samples alone, without bias but noisy where a lamp looks small).
enum class ThroughMirrors { kNever, kImaged, kAlways };
template <>
struct EnumNames<ThroughMirrors> {
  static constexpr const char* kind = "reads through mirrors";
  static constexpr std::array<std::pair<ThroughMirrors, const char*>, 3> table{
      {{ThroughMirrors::kNever, "never"},
       {ThroughMirrors::kImaged, "imaged"},
       {ThroughMirrors::kAlways, "always"}}};
};
template <>
struct EnumNames<GatherKind> {
  static constexpr const char* kind = "gather";
  static constexpr std::array<std::pair<GatherKind, const char*>, 2> table{
      {{GatherKind::kPatch, "patch"}, {GatherKind::kFinal, "final"}}};
};

// GatherOptions{} is the patch gather, as the library has always built it;
// GatherOptions::final_gather() the final gather, which the command line defaults to.
struct GatherOptions {
  GatherKind kind = GatherKind::kPatch;
  DiffuseMode diffuse = DiffuseMode::kSmooth;
  int pixel_grid = 2;     // sub-pixel rays per side (2: four rays a pixel)
  int lobe_samples = 16;  // lobe samples of a glossy hit (rounded to a square)
  // Points on the lights: per glossy hit (patch gather; 0: the lobe samples alone), per
  // non-delta hit (final gather; 0: the lights are found by the BRDF samples alone).
  int light_samples = 4;
  int gather_samples = 16;  // final gather: cosine samples of a diffuse part (rounded to a square)
  int mirror_depth = 4;     // final gather: delta bounces traced before reading L_{j->i}
  // Final gather: jittered rays per side that find the emitters a pixel sees (directly or in
  // mirrors), finer than pixel_grid because a lamp's edge pixels are far brighter than its
  // surroundings.
  int emission_grid = 8;
  // Final gather, emission_grid >= 4: false casts the finer rays only where a pixel may need
  // them: where 4 of them (2 x 2 of the grid, spread evenly), in the pixel and in each of its 8
  // neighbours, do not all meet the same objects along their mirror chains and no emitter,
  // where a shading ray meets other objects, and on the image's border; elsewhere all of them
  // are taken to add that one path class and no Le. An approximation: a feature thinner than
  // about a third of a pixel can lie between all 36 (the same images at the scenes' own sizes,
  // and for cornell-box and the mirror cube at 8 to 37 pixels a side). Where they are cast, the
  // 4 are cast again with them (68).
  // true casts them at every pixel (as gathers written before the choice did).
  bool emission_grid_everywhere = false;
  // Final gather: where a BRDF sample lands within near_distance diameters of the unknown it
  // reads (the patch it meets, or on a hierarchy the leaf under the hit), the diffuse light
  // reflected there is gathered again (near_samples light points and cosine samples, rounded to
  // a square; 0: never) instead of read from that unknown's B; blended linearly to reading B at
  // twice the distance.
  int near_samples = 4;
  double near_distance = 1.0;
  // Final gather: points on the reflectors (patches whose material has a lobe and that send
  // specular links) per hit with a diffuse part, for the specular light S_{j->i} they send it,
  // weighted against the cosine samples (0: the cosine samples alone). A mirror's links are
  // bright and change from patch to patch, which cosine samples alone read with much noise.
  int reflector_samples = 0;
  // Final gather: light points per hit with a diffuse part for the lamps' light that planar
  // mirrors reflect to it (mirror images, above; 0: none, the links carry it). Drawn only
  // where the scene has mirrors and the gather is given the mirror links' part of the mesh's
  // direct light (mesh_direct_for); without it the gather reads the links whole and says so in
  // Gather::options (mirror_image_samples 0).
  int mirror_image_samples = 0;
  // Final gather, with mirror images and through_mirrors not kNever, kRays: the most planar
  // mirrors between a hit and a lamp's image. Past the first, only mirrors with no light on
  // them that face the one before: the lamps are drawn at their images through every such chain
  // (mirror_image_samples / n^2 points, at least one, for a chain of n), and a cosine sample or
  // reflector point that reads through a mirror follows its ray on through up to that many,
  // reading where it leaves them (a lamp met there is the images'). 1: one mirror, the rest on
  // the links, which forget where on a patch the light met each mirror.
  int mirror_image_depth = 1;
  // Final gather, with mirror_image_depth above 1: the most chains of two or more facing mirrors
  // drawn from one hit (transport/mirror_chains.h), whole lengths at a time: all chains of 2,
  // then all of 3, ... up to mirror_image_depth while their count stays within this; longer
  // chains stay on the links. Two facing mirrors have 2 (n - 1) chains up to n; three or more
  // that face each other many more (from the floor of a room of four mirror walls, 36 up to 3
  // walls, 188 to 204 up to 6: at budgets 64 and 256 its floor -3.0 and -0.8 percent against
  // the exact lattice of images, for 2.0 and 3.5 times the wall time of one mirror). 0: one
  // mirror, as mirror_image_depth 1.
  int mirror_chain_budget = 256;
  // Final gather: where a cosine sample or a reflector point meets a delta mirror, whether it
  // reads through it (ThroughMirrors, above; kNever: as gathers written before the choice). On
  // the mirror cube against the path tracer at 4096 spp: kNever 0.0704, kImaged 0.0697 (the
  // hierarchy 0.0699, 0.0692); without the mirror images, kAlways 0.0855 against kNever's 0.0792,
  // the floor's region +0.05 against +0.50 percent: less bias, the lamp's light through the
  // mirror found by samples alone.
  ThroughMirrors through_mirrors = ThroughMirrors::kImaged;
  // Final gather: kMesh reads the diffuse part's indirect light from the unknown under each hit
  // (but near other surfaces: mesh_near_distance); the cosine samples then only find the lights
  // (the light points' partner) and no reflector points are drawn (but at the near points): the
  // pixel's direct light is its own, the rest is the mesh's, with the mesh's error (a fine mesh's
  // is below the rays' noise, a coarse one's above it). It needs the mesh's direct light
  // (MeshDirect) where the gather is built.
  IndirectMode indirect = IndirectMode::kRays;
  // Final gather, kMesh: where one of up to 8 cosine probes from a point, each mesh_near_distance
  // times the diameter of the unknown under the point long (on a hierarchy at least half its
  // root's: a leaf's light from afar comes on links near its root), meets a surface, that
  // unknown's mean is the wrong value there (the light arriving changes across it: the wall
  // beside a corner fills more of the sky the closer the point), and the light the point's
  // diffuse part reflects beyond the direct light is gathered by rays as kRays gathers it:
  // mesh_near_samples cosine samples (rounded to a square) reading the mesh one bounce away, and
  // points on the reflectors if reflector_samples asks (the light points and mirror images keep
  // their counts). 0: the mesh is read at every point.
  double mesh_near_distance = 0.0;
  int mesh_near_samples = 64;
  // Final gather, kMesh: how the unknowns under a shading point give its light: kSmooth,
  // bilinear in the averages at their corners (as the patch gather's smooth reads), or kFlat,
  // the mean of the one under it. The mean is the light of the whole unknown, not of the point:
  // smooth reads brought relative RMSE from 0.0463 to 0.0443 on cornell-box's hierarchy, 0.0625
  // to 0.0606 on cornell-glossy's, 0.0694 to 0.0687 on the mirror cube's (one refinement pass;
  // 0.0453 to 0.0440 against 16,384 spp), 0.0714 to 0.0708 on its uniform 50 mesh, in the same
  // time (README, "The final gather": Smooth reads of the mesh). The gather samples' reads keep
  // `diffuse`.
  DiffuseMode mesh_read = DiffuseMode::kSmooth;
  std::uint64_t seed = 11;

  // The final gather with the counts the sample study chose (README, "The final gather"):
  // flat reads (each patch's mean keeps the flux a sample reads, where the smooth interpolation
  // moves light off bright patches), 64 cosine samples and 64 light points per sub-pixel ray,
  // and 64 points on the reflectors (a sixth less error on the mirror cube for an eighth more
  // gather time; nothing drawn where no patch sends specular links). With the indirect light
  // from the mesh the cosine samples only find the lights, against the light points: 16 (the
  // mirror cube's error the same as with 64, in 3.5 s less); and the light points are the only
  // noise left in the direct light: 32 kept the error of 64 on the three cornell scenes
  // (hierarchical; 16 raised the mirror cube's by 0.004) in two fifths less gather time.
  // Mirror images as many as light points: on the mirror cube, uniform 17 0.0824 -> 0.0694,
  // hierarchical 0.0788 -> 0.0699, and with the indirect light from the mesh 0.0817 -> 0.0761
  // (32 and 64 the same, 16 0.0763); on the room 16 gave 0.0528 and 64 0.0518 against 0.0526
  // without (README, "Mirror images of the lamps"). With the indirect light from the mesh, points
  // within 2 diameters (on a hierarchy, at least half its root's) of a surface are gathered by 64
  // rays: on the hierarchy, relative RMSE cornell-box 0.0594 -> 0.0463, cornell-glossy 0.0682 ->
  // 0.0625, the mirror cube 0.0761 -> 0.0694, for 1.1 to 1.8 s more (README, "Near surfaces,
  // rays").
  static GatherOptions final_gather(IndirectMode indirect = IndirectMode::kRays) {
    GatherOptions o;
    o.kind = GatherKind::kFinal;
    o.diffuse = DiffuseMode::kFlat;
    o.gather_samples = indirect == IndirectMode::kMesh ? 16 : 64;
    o.light_samples = indirect == IndirectMode::kMesh ? 32 : 64;
    o.reflector_samples = indirect == IndirectMode::kMesh ? 0 : 64;  // none at kMesh's near points
    o.mirror_image_samples = indirect == IndirectMode::kMesh ? 32 : 64;
    o.mirror_image_depth = indirect == IndirectMode::kMesh ? 1 : 16;
    o.mesh_near_distance = indirect == IndirectMode::kMesh ? 2.0 : 0.0;
    o.indirect = indirect;
    return o;
  }
};

// The most mirrors a chain of mirror images takes with these options: mirror_image_depth where
// the images are drawn and every read through a mirror follows them (the final gather, kRays,
// through_mirrors not kNever), else 1 (kMesh reads the light beyond one mirror from the mesh).
inline int mirror_chain_depth(const GatherOptions& o) {
  return o.kind == GatherKind::kFinal && o.mirror_image_samples > 0 &&
                 o.through_mirrors != ThroughMirrors::kNever && o.indirect == IndirectMode::kRays
             ? o.mirror_image_depth
             : 1;
}

// The link tolerance (HierarchyOptions::link_tolerance, eq. H1) that a hierarchical mesh needs
// behind a gather: what `render`, `precompute` and `sweep` take when none is given. The patch
// gather reads the leaves at every pixel: 0.05, since its error doubles at 0.1. The final gather
// reads the mesh only one bounce away from what a pixel sees: 0.07, which against 0.05 kept the
// relative RMSE (cornell-box 0.0494 against 0.0485, cornell-glossy 0.0646 against 0.0648, the
// mirror cube 0.0788 both) for 15 percent less memory (README, "Hierarchical links"). A final
// gather that reads the indirect light from the mesh (IndirectMode::kMesh) reads the leaves at
// every pixel, as the patch gather does: 0.05 (the mirror cube 0.0816 against 0.0836 at 0.07).
// With chosen > 0 (a tolerance the caller chose), chosen itself.
double link_tolerance_for(GatherKind kind, double chosen = 0.0);
double link_tolerance_for(const GatherOptions& gather, double chosen = 0.0);

using Rgbf = std::array<float, 3>;

class GatherRows;

// What a final gather's chains of facing mirrors did (GatherOptions::mirror_chain_budget): the
// hits in front of a mirror plane that faces another, those where the budget left out longer
// chains than it kept, and the shortest length kept at such a hit (0 where none was cut).
struct MirrorChainCount {
  long long hits = 0, cut = 0;
  int shortest_cut = 0;
  void count(bool was_cut, int depth) { add({1, was_cut ? 1 : 0, was_cut ? depth : 0}); }
  void add(const MirrorChainCount& o) {
    hits += o.hits;
    cut += o.cut;
    if (o.shortest_cut > 0)
      shortest_cut = shortest_cut > 0 ? std::min(shortest_cut, o.shortest_cut) : o.shortest_cut;
  }
};

struct Gather {
  int width = 0, height = 0;
  GatherOptions options;  // what built it
  Csr<Rgbf> g;            // row = pixel (row-major from the top-left), column = unknown
  Csr<Rgbf> e;  // final gather: row = pixel, column = patch (its emission); empty otherwise
  long long rays = 0;
  double seconds = 0.0;
  MirrorChainCount mirror_chains;  // the final gather's, as it was built
  // Set by defer_gather: g and e are not stored, their rows are built where they are used.
  std::shared_ptr<const GatherRows> deferred;
  std::size_t bytes() const { return g.bytes() + e.bytes(); }
};

// The gather of the world's camera, or of another camera (a solution operator relit from
// elsewhere), built whole. `direct` (mesh_direct_for the same operator) is required by
// IndirectMode::kMesh (else InputError) and read only while the gather is built; a deferred
// gather keeps its own.
Gather build_gather(const World& world, const UnknownLayout& layout,
                    const GatherOptions& options = {}, const MeshDirect* direct = nullptr);
Gather build_gather(const World& world, const Camera& camera, const UnknownLayout& layout,
                    const GatherOptions& options = {}, const MeshDirect* direct = nullptr);

// What a gather with options o needs of operator t: its MeshDirect for a final gather with
// IndirectMode::kMesh, or with mirror images where the world has planar mirrors that send links
// (one application of T per emitting object, two for both), else null.
std::shared_ptr<const MeshDirect> mesh_direct_for(const GatherOptions& o,
                                                  const TransportOperator& t, const World& world);
// Whether a gather with options o draws the lamps' mirror images in this world, given its
// operator has links (`links`): a final gather, images asked for, a light and a planar mirror.
bool draws_mirror_images(const GatherOptions& o, const World& world, bool links);

// The same gather with its rows built on demand, block by block (for_each_gather_block), so
// that a final gather, with many entries per pixel, never needs to be held whole. Keeps
// references to world and layout, which must outlive it.
Gather defer_gather(const World& world, const Camera& camera, const UnknownLayout& layout,
                    const GatherOptions& options = {},
                    std::shared_ptr<const MeshDirect> direct = nullptr);

// Pixels in a block of a deferred gather's rows, where the library reads one (apply_gather, the
// view precompute): about 3 MB for a final gather of cornell-box. Blocks of 4096 pixels held
// 35 MiB more at the peak of the mirror cube's hierarchical render (0.150 against 0.115 GiB,
// the image written as .pfm) in the same time (gather 9.8 and 9.5 s; precompute 10.2 s both).
inline constexpr std::int64_t kGatherBlockPixels = 1024;

// Calls f(first_row, g_rows, e_rows) over the gather's rows in order: once with everything for
// a stored gather; for a deferred one, for blocks of about block_pixels pixels, each built (in
// parallel) just before the call and released after it. e_rows has no rows for a patch gather.
// Returns what the rows cost.
struct GatherWork {
  long long rays = 0;     // cast to build them (0 for a stored gather)
  double seconds = 0.0;   // spent building them
  long long nnz = 0;      // entries of G and E
  std::size_t bytes = 0;  // the most held at once
  MirrorChainCount mirror_chains;  // the final gather's, over the rows built
};
GatherWork for_each_gather_block(
    const Gather& gather, std::int64_t block_pixels,
    const std::function<void(std::int64_t, const Csr<Rgbf>&, const Csr<Rgbf>&)>& f);
// What a gather's rows cost in all: a stored gather's build, or a deferred gather's rows as
// they were read (work, from for_each_gather_block); the seconds of both.
GatherWork gather_cost(const Gather& gather, const GatherWork& work);

// The bytes a gather of `pixels` pixels holds at its peak, built whole or deferred (for the
// memory estimate, transport/memory_estimate.h): a stored gather its entries twice while it is
// built (about 7 a pixel for the patch gather at 2 x 2 rays, 3 per cosine sample for the final
// gather, with kMesh's near points taken as half the points), a deferred one a block of rows
// and a few buffers; with the image and the apply's sums.
double gather_memory(const GatherOptions& options, std::int64_t pixels, bool deferred);

// The scene's emission of each patch, as apply_gather takes it.
std::vector<Rgb> scene_emission(const PatchSet& patches);

// image = G u + E emission; emission has one RGB value per patch and is required when E is not
// empty (the final gather). Reads a deferred gather block by block.
Image apply_gather(const Gather& gather, const Field& u, const std::vector<Rgb>& emission = {},
                   GatherWork* work = nullptr);

}  // namespace polyrad
