// Memory estimated before the work (transport/memory_estimate.h).
#include "polyrad/transport/memory_estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "polyrad/geometry/mesher.h"
#include "polyrad/scene/scene.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/machine.h"
#include "polyrad/util/sampling.h"
#include "polyrad/world/world.h"

namespace polyrad {

namespace {

// The process before any scene: a 16 x 16 render of cornell-box on five patches peaked at 14.0
// MiB (2026-12-06).
constexpr double kBaseBytes = 15.0 * (1 << 20);
constexpr double kPatchBytes = 350.0;
constexpr double kPairBytes = 48.0;
constexpr double kEntryBytes = 50.0;
// The hierarchy keeps the roots' transfer (12 bytes an entry) and the specular links' rows read
// from it (8), built one reflector at a time. Measured on 2026-12-05 (.pfm, no codec): the room's
// transfer and links held 278 MiB beyond its diffuse-only build (--classic) against 195 counted
// at 25 bytes an entry, cornell-glossy's 32 against 26; 35 bytes cover both.
constexpr double kRootEntryBytes = 35.0;
// The links at tau 0.05 and two refinement passes: 1.9 links a visible root pair at about 80 to
// 120 bytes each (the builder's kept link, the finished link, its operator rows and the leaves),
// from the peaks of cornell-box, cornell-glossy, the mirror cube and the room.
constexpr double kRootPairBytes = 260.0;
// That fit holds on the scenes' own patches. On roots finer or coarser than those, the links a
// root pair adds or takes away are about one each, at the roots' level: what refinement adds
// is set by where the light varies, not by the roots (cornell-box at tau 0.05, links less
// visible root pairs: 125k, 200k, 231k and 179k at patch sizes 100, 50, 35 and 25). At 90
// bytes a link (the peaks of cornell-box at 25 and 35: 86 and 80), estimate against peak went
// from 0.74 / 1.81 / 2.41 to 1.4 / 1.2 / 1.1 at 100 / 35 / 25.
constexpr double kRootLinkBytes = 90.0;
constexpr double kVisibleShareOfFacing = 0.75;
// Before meshing, work is refused only if it would not fit even were this share of the facing
// pairs all that see each other: a cluttered scene whose pairs are mostly blocked is left to the
// world's estimate, which samples visibility with rays before any form factor is computed.
constexpr double kVisibleShareFloor = 0.1;
// A tighter link tolerance refines further, a looser one less, down to the roots' own pairs.
// Fitted on 2026-12-05 to the peaks of cornell-box from tau 0.2 to 0.005 and of the room at
// 0.07, 0.05 and 0.02: links a root pair 1.0, 1.5, 1.9, 4.9 (the room 3.8), 13 and 37 at tau
// 0.2, 0.07, 0.05, 0.02, 0.01 and 0.005.
constexpr double kLooseExponent = 0.6;   // above 0.05
constexpr double kMiddleExponent = 0.8;  // 0.05 to 0.02
constexpr double kFineTolerance = 0.02;
constexpr double kFineExponent = 1.5;  // below 0.02
constexpr double kMaxRefinementGrowth = 64.0;
constexpr double kMinRefinementGrowth = 0.2;
// Each refinement pass after the first solves and judges every link again with the radiosities
// it found, and from the second on the builder holds the previous operator and its kept links
// through the solve: the peaks of the first pass alone and of one further pass were 0.33 to 0.6
// and 0.83 to 0.95 of two passes' hierarchy share (the same four scenes, 44-byte kept links); a
// third adds < 1 %. 0.8 is where the fit over all the rows put the second, and it keeps the
// room's one-pass renders (1.10, 1.14) off the low end. The floor applies after this share.
constexpr double kPassShare[] = {0.4, 0.8, 1.0};
// Refinement stops at the smallest element: with it coarser than the scene's own (an eighth of
// its authored patch), the links where the light varies are cut short. Cornell-box at tau 0.05,
// links against those with the scene's own smallest element: 0.83, 0.43 and 0.10 with it 2, 4
// and 12 times as large (roots 100, 200 and 600, each at an eighth); the share below,
// min(1, (2 / r)^1.33), gives 1, 0.40 and 0.09.
constexpr double kFreeCoarsening = 2.0;
constexpr double kCoarseningExponent = 1.33;
constexpr int kPairSamples = 4096;

bool facing(const Vec3& ca, const Vec3& na, const Vec3& cb, const Vec3& nb) {
  const Vec3 d = cb - ca;
  return d.dot(na) > 0.0 && -d.dot(nb) > 0.0;
}

// The targets one (j -> i) pair of a reflector reaches: a mirror's samples land on few patches,
// a lobe's spread over about all of them (and balancing adds the reverse entries); never more
// than the patches the reflector sees.
double targets_per_pair(const Material& m, int samples, double partners) {
  return std::min(m.is_delta() ? 0.4 * samples : 1.1 * samples, 2.0 * partners);
}

// The visible pairs the scene would have on its own patches (SceneObject::authored_patch_size),
// from those it has: they grow as the square of the patches. The pairs themselves where every
// object keeps its own size or gives none.
double authored_pairs(const Scene& scene, double pairs) {
  auto moved = [](const SceneObject& o) {
    return o.authored_patch_size > 0.0 && o.authored_patch_size != o.patch_size;
  };
  if (std::none_of(scene.objects.begin(), scene.objects.end(), moved)) return pairs;
  const double now = count_patches(scene), then = count_patches(scene, true);
  return now > 0.0 ? pairs * (then / now) * (then / now) : pairs;
}

// The share of the fit's refined links the hierarchy can make with its smallest element
// (kFreeCoarsening, above): per face, weighed by its patches on the scene's own sizes. A face
// of n such patches is taken as sqrt(n) of them long: a root is never longer than its face.
double finest_share(const Scene& scene, const HierarchyOptions& o) {
  double weight = 0.0, share = 0.0;
  for (const FacePatches& f : face_patches(scene, true)) {
    const SceneObject& obj = scene.objects[f.object];
    const double own = obj.authored_patch_size > 0.0 ? obj.authored_patch_size : obj.patch_size;
    const double root = std::min(obj.patch_size, own * std::sqrt(f.patches));
    const double smallest = o.smallest_element(root);
    if (!(own > 0.0) || !(smallest > 0.0)) continue;
    const double r = smallest / HierarchyOptions{}.smallest_element(own);
    share += f.patches * std::min(1.0, std::pow(kFreeCoarsening / r, kCoarseningExponent));
    weight += f.patches;
  }
  return weight > 0.0 ? share / weight : 1.0;
}

// The system's bytes from the counts: `pairs` visible root pairs, `authored` those on the
// scene's own patches (the hierarchy's fit, above), `finest` the share of its refined links the
// smallest element allows (finest_share).
double system_bytes(double pairs, double authored, double finest, double reflector_pairs_targets,
                    const SystemOptions& o) {
  if (o.mesh == MeshKind::kHierarchical) {
    // The links, and with lobes the transfer on the roots (the uniform mesh's, eq. H3).
    const double tau = std::max(1e-6, o.hierarchy.tolerance());
    const double transfer =
        o.hierarchy.specular_links ? reflector_pairs_targets * kRootEntryBytes : 0.0;
    const double coarse = tau >= 0.05
                              ? std::pow(0.05 / tau, kLooseExponent)
                              : std::pow(0.05 / std::max(tau, kFineTolerance), kMiddleExponent);
    const double fine = tau < kFineTolerance ? std::pow(kFineTolerance / tau, kFineExponent) : 1.0;
    const double passes = kPassShare[std::clamp(o.hierarchy.passes, 0, 2)];
    const double growth =
        std::clamp(coarse * fine * passes, kMinRefinementGrowth, kMaxRefinementGrowth);
    // Each root pair beyond (or short of) the scene's own adds (or takes away) one root link,
    // never more than a pair of the fit costs at this tolerance; a coarser smallest element
    // refines less (finest), but every root pair keeps its link.
    const double root_link = std::min(kRootLinkBytes, kRootPairBytes * growth);
    const double links = authored * kRootPairBytes * growth + (pairs - authored) * root_link;
    return std::max(finest * links, pairs * root_link) + transfer;
  }
  return pairs * kPairBytes + reflector_pairs_targets * kEntryBytes;
}

// The parts from the counts already in m (patches, visible pairs); reflectors: the patches of
// each lobed material (a face's, or one patch at a time); reflector_partners: the visible
// partners of a reflector patch, when measured (else the mean patch's).
MemoryEstimate with_parts(MemoryEstimate m, const Scene& scene,
                          const std::vector<std::pair<double, const Material*>>& reflectors,
                          const SystemOptions& options, double reflector_partners = -1.0) {
  // Transfer entries: each reflector patch's visible partners times the targets a pair reaches.
  const double partners = reflector_partners >= 0.0 ? reflector_partners
                          : m.patches > 0.0         ? 2.0 * m.visible_pairs / m.patches
                                                    : 0.0;
  double entries = 0.0;
  for (const auto& [patches, mat] : reflectors)
    entries += patches * partners * targets_per_pair(*mat, options.specular.samples, partners);
  m.base = kBaseBytes;
  m.world = m.patches * kPatchBytes;
  const bool tree = options.mesh == MeshKind::kHierarchical;
  const double authored = tree ? authored_pairs(scene, m.visible_pairs) : m.visible_pairs;
  const double finest = tree ? finest_share(scene, options.hierarchy) : 1.0;
  m.system = system_bytes(m.visible_pairs, authored, finest, entries, options);
  m.camera = options.camera_bytes;
  return m;
}

}  // namespace

MemoryEstimate estimate_memory(const Scene& scene, const SystemOptions& options) {
  const std::vector<FacePatches> faces = face_patches(scene);
  MemoryEstimate m;
  for (const auto& f : faces) m.patches += f.patches;
  // Facing pairs of faces, weighted by their patches; sampled when the faces are many.
  const size_t n = faces.size();
  double facing_pairs = 0.0;
  if (n <= 4000) {
    for (size_t a = 0; a < n; ++a)
      for (size_t b = a + 1; b < n; ++b)
        if (facing(faces[a].centroid, faces[a].normal, faces[b].centroid, faces[b].normal))
          facing_pairs += faces[a].patches * faces[b].patches;
  } else {
    Rng rng(0x6d656d);
    double hit = 0.0, total = 0.0;
    for (int s = 0; s < 1 << 20; ++s) {
      const auto a = static_cast<size_t>(rng.uniform() * n),
                 b = static_cast<size_t>(rng.uniform() * n);
      if (a == b) continue;
      const double w = faces[a].patches * faces[b].patches;
      total += w;
      if (facing(faces[a].centroid, faces[a].normal, faces[b].centroid, faces[b].normal)) hit += w;
    }
    double all = 0.0, squares = 0.0;
    for (const auto& f : faces) {
      all += f.patches;
      squares += f.patches * f.patches;
    }
    facing_pairs = total > 0.0 ? hit / total * 0.5 * (all * all - squares) : 0.0;
  }
  m.visible_pairs = kVisibleShareOfFacing * facing_pairs;
  std::vector<std::pair<double, const Material*>> reflectors;
  for (const auto& f : faces) {
    const Material& mat = scene.materials[scene.objects[f.object].material];
    if (mat.has_lobe()) reflectors.emplace_back(f.patches, &mat);
  }
  return with_parts(m, scene, reflectors, options);
}

namespace {

// The share of random pairs (a from `from`, or any patch when empty; b any patch) that see each
// other: a plane test, then rays between up to kPointPairs random points of the two, since a
// pair links (F > 0) if any part of one sees any part of the other. Centroids alone missed a
// fifth of the partners of a glossy floor among furniture (scenes/room).
double visible_share(const World& world, const std::vector<PatchId>& from, std::uint64_t seed) {
  constexpr int kPointPairs = 4;
  const PatchSet& patches = world.patches();
  const auto n = static_cast<std::int64_t>(patches.size());
  Rng rng(seed);
  int seen = 0, tried = 0;
  for (int s = 0; s < kPairSamples && n > 1; ++s) {
    const auto a = from.empty() ? static_cast<PatchId>(rng.uniform() * n)
                                : from[static_cast<size_t>(rng.uniform() * from.size())];
    const auto b = static_cast<PatchId>(rng.uniform() * n);
    if (a == b) continue;
    ++tried;
    const Patch& pa = patches[a];
    const Patch& pb = patches[b];
    if (!facing(pa.centroid, pa.normal, pb.centroid, pb.normal)) continue;
    for (int k = 0; k < kPointPairs; ++k) {
      double density;
      const Vec3 x = k == 0 ? pa.centroid : pa.sample(rng.uniform2(), &density);
      const Vec3 y = k == 0 ? pb.centroid : pb.sample(rng.uniform2(), &density);
      if ((y - x).dot(pa.normal) <= 0.0 || (x - y).dot(pb.normal) <= 0.0) continue;
      if (!world.caster().segment_occluded(x, a, y, b)) {
        ++seen;
        break;
      }
    }
  }
  // Pairs hidden at these points may still link through the rest: a tenth more than seen.
  return tried > 0 ? 1.1 * seen / tried : 0.0;
}

}  // namespace

MemoryEstimate estimate_memory(const World& world, const SystemOptions& options) {
  const PatchSet& patches = world.patches();
  MemoryEstimate m;
  m.patches = static_cast<double>(patches.size());
  m.visible_pairs = visible_share(world, {}, 0x706169) * 0.5 * m.patches * (m.patches - 1);
  std::vector<std::pair<double, const Material*>> reflectors;
  std::vector<PatchId> lobed;
  for (PatchId i = 0; i < static_cast<PatchId>(patches.size()); ++i) {
    const Material& mat = world.materials()[patches[i].material];
    if (!mat.has_lobe()) continue;
    reflectors.emplace_back(1.0, &mat);
    lobed.push_back(i);
  }
  // The reflectors' partners sampled on their own: a glossy floor sees most of a room, half
  // again the mean patch's partners in scenes/room, and its transfer grows with them.
  if (lobed.empty()) return with_parts(m, world.scene(), reflectors, options);
  const double partners = visible_share(world, lobed, 0x6c6f6265) * (m.patches - 1);
  return with_parts(m, world.scene(), reflectors, options, partners);
}

void require_memory_before_meshing(const MemoryEstimate& need, double budget,
                                   const std::string& file) {
  MemoryEstimate floor = need;
  floor.system *= kVisibleShareFloor / kVisibleShareOfFacing;  // linear in the visible pairs
  if (!(budget > 0.0) || floor.total() <= budget) return;
  require_memory(need, budget, file);  // need >= floor > budget: throws with the estimate
}

double memory_budget(double max_memory_bytes) {
  return max_memory_bytes > 0.0 ? max_memory_bytes : 0.8 * physical_memory_bytes();
}

void require_memory(const MemoryEstimate& need, double budget, const std::string& file) {
  if (!(budget > 0.0) || need.total() <= budget) return;
  constexpr double gib = 1 << 30;
  char text[512];
  std::snprintf(text, sizeof text,
                "the run needs an estimated %.3g GiB (%.3g patches, %.3g visible pairs: system "
                "%.3g GiB, camera %.3g GiB, process and world %.3g GiB), more than the budget of "
                "%.3g GiB; use a larger patch_size, a smaller image, or raise --max-memory",
                need.total() / gib, need.patches, need.visible_pairs, need.system / gib,
                need.camera / gib, (need.base + need.world) / gib, budget / gib);
  throw InputError(SourceLocation{file}, text);
}

}  // namespace polyrad
