// The glossy radiosity system of a world: its form factors, its specular transfer (with the
// lobe resolution check) and the transport operator T of u = e + T u, built in that order and
// timed. What the solvers, the series precompute, the benchmarks and the tests share; each
// stage is also callable on its own.
//
//   auto world = World::load("scenes/cornell-mirror-cube.json");
//   auto sys = build_system(world);
//   SolveResult r = solve(sys->transport, sys->transport.emission());
//
// A classic world (SceneOverrides::classic) has no lobes, so its T is the classic radiosity
// system over the patches alone.
//
// Cost: that of the stages (form factors dominate for diffuse scenes, the specular transfer
// for glossy ones). The system is not movable: with on-the-fly link rows T refers to the form
// factors.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "polyrad/transport/form_factors.h"
#include "polyrad/transport/hierarchy.h"
#include "polyrad/transport/lobe_resolution.h"
#include "polyrad/transport/memory_estimate.h"
#include "polyrad/transport/specular_transfer.h"
#include "polyrad/transport/transport.h"
#include "polyrad/util/timer.h"
#include "polyrad/world/world.h"

namespace polyrad {

// How the scene's surfaces become unknowns: equal patches linked pair by pair, or element trees
// on those patches linked at the level the light needs (transport/hierarchy.h; diffuse transport
// only).
enum class MeshKind { kUniform, kHierarchical };
template <>
struct EnumNames<MeshKind> {
  static constexpr const char* kind = "mesh";
  static constexpr std::array<std::pair<MeshKind, const char*>, 2> table{
      {{MeshKind::kUniform, "uniform"}, {MeshKind::kHierarchical, "hierarchical"}}};
};

struct SystemOptions {
  FormFactorOptions form_factors;
  // Unset: the workflow's gather chooses (system_for_gather, app/precompute.h); where none
  // does, build_system takes the uniform mesh.
  std::optional<MeshKind> mesh;
  // With MeshKind::kHierarchical (its form factor options are taken from the field above).
  HierarchyOptions hierarchy;
  SpecularOptions specular;
  // Recompute the specular rows at every sweep instead of storing them (section 4.1): the
  // transfer is computed once to find the links, then its entries are released.
  bool specular_on_the_fly = false;
  // Refuse (InputError) a run whose estimated memory (transport/memory_estimate.h) exceeds this
  // many bytes; 0: 80 percent of the machine's physical memory.
  double max_memory_bytes = 0.0;
  // The camera's share of that estimate (images and their codec, gather, view rows), which the
  // workflow knows and sets: gather_memory (render/camera_gather.h), rows_memory
  // (solve/series_precompute.h), kImageCodecBytes (io/image_codec.h).
  double camera_bytes = 0.0;
};

// A hierarchical mesh's figures: elements, links, and what each refinement pass did.
struct HierarchySummary {
  long long roots = 0, elements = 0, leaves = 0, links = 0, link_entries = 0;
  std::size_t operator_bytes = 0;
  HierarchyStats stats;
};

// The figures of a built system, for reports: sizes, the stages' statistics, the lobe checks.
struct SystemSummary {
  long long patches = 0, links = 0, unknowns = 0;
  MeshKind mesh = MeshKind::kUniform;
  std::optional<HierarchySummary> hierarchy;  // with a hierarchical mesh
  FormFactorStats form_factors;
  long long form_factor_nnz = 0;
  std::size_t form_factor_bytes = 0;
  SpecularStats specular;
  long long specular_entries = 0;
  std::size_t specular_bytes = 0;
  bool on_the_fly = false;
  long long nnz_diffuse = 0, nnz_specular = 0;
  std::size_t operator_bytes = 0;
  double max_albedo = 0.0;
  std::vector<LobeResolution> lobes;
  // What build_system estimated the run would hold at its peak, by part, the camera's share
  // included (transport/memory_estimate.h): beside the report's measured peak.
  MemoryEstimate estimated_memory;
};

struct RadiositySystem {
  std::shared_ptr<const World> world;
  FormFactors form_factors;
  SpecularTransfer specular;
  TransportOperator transport;
  // Each glossy object's lobe width against its patches' angle (lobe_resolution.h); those with
  // `smeared` set are the warnings a caller should show.
  std::vector<LobeResolution> lobes;
  // With a hierarchical mesh: the element trees on the world's patches, whose leaves are the
  // unknowns (the transport's layout holds it too).
  std::shared_ptr<const ElementHierarchy> hierarchy;
  StageTimes times;  // the world's (mesh, ray caster), then each stage of the system
  MemoryEstimate estimated_memory;  // as checked before the build (memory_estimate.h)

  const Scene& scene() const { return world->scene(); }
  const PatchSet& patches() const { return world->patches(); }
  // The patches the B unknowns belong to, one per B unknown: the hierarchy's leaves, or the
  // world's patches.
  Eigen::Index num_unknown_patches() const {
    return hierarchy ? hierarchy->num_leaves() : static_cast<Eigen::Index>(patches().size());
  }
  const Patch& unknown_patch(Eigen::Index p) const {
    return hierarchy ? hierarchy->leaf(static_cast<int>(p)) : patches()[p];
  }

  RadiositySystem() = default;
  RadiositySystem(const RadiositySystem&) = delete;
  RadiositySystem& operator=(const RadiositySystem&) = delete;
  double seconds(const std::string& stage) const { return stage_seconds(times, stage); }
  SystemSummary summary() const;
};

// Checks the memory estimate first (transport/memory_estimate.h).
std::unique_ptr<RadiositySystem> build_system(std::shared_ptr<const World> world,
                                              const SystemOptions& options = {});
// The same from a scene: an estimate is checked before the world is meshed too, so that a tiny
// patch size is refused at once rather than after meshing millions of patches.
std::unique_ptr<RadiositySystem> build_system(Scene scene, const SceneOverrides& overrides,
                                              const SystemOptions& options = {});

}  // namespace polyrad
