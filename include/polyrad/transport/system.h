// The stages from a scene to its transport operator, run in order and timed:
//   mesh -> ray caster -> form factors -> specular transfer (and the lobe resolution check)
//   -> operator T.
// What the CLI, the benchmarks and the tests share; each stage is also callable on its own.
//
//   auto sys = build_system(load_scene(path), {});
//   SolveResult r = solve(sys->transport, sys->transport.emission());
//
// Cost: that of the stages (form factors dominate for diffuse scenes, the specular transfer
// for glossy ones). The system is not movable: the ray caster refers to the patches.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "polyrad/transport/form_factors.h"
#include "polyrad/transport/lobe_resolution.h"
#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/scene.h"
#include "polyrad/transport/specular_transfer.h"
#include "polyrad/transport/transport.h"

namespace polyrad {

struct PipelineOptions {
  FormFactorOptions form_factors;
  SpecularOptions specular;
  // false: the classic system, every material reduced to its diffuse part.
  bool specular_transport = true;
  // Recompute the specular rows at every sweep instead of storing them (section 4.1): the
  // transfer is computed once to find the links, then its entries are released.
  bool specular_on_the_fly = false;
  // Overrides every patch_size of the scene when > 0.
  double patch_size = 0.0;
  // Refuse (InputError) a scene whose estimated memory exceeds this many bytes; 0: 80 percent
  // of the machine's physical memory.
  double max_memory_bytes = 0.0;
};

// An upper estimate of the memory build_system will need, by part, before anything is built:
// form factors as if half of all patch pairs faced each other, the specular transfer as if
// every reflector's samples spread over distinct targets, and the solver's fields.
struct MemoryEstimate {
  double patches = 0.0;
  double form_factors = 0.0, specular = 0.0, fields = 0.0;
  double total() const { return form_factors + specular + fields; }
};
MemoryEstimate estimate_memory(const Scene& scene, const PipelineOptions& options);
double physical_memory_bytes();

struct StageTime {
  std::string name;
  double seconds;
};

struct RadiositySystem {
  Scene scene;
  PatchSet patches;
  std::unique_ptr<RayCaster> caster;
  FormFactors form_factors;
  SpecularTransfer specular;
  TransportOperator transport;
  // Each glossy object's lobe width against its patches' angle (lobe_resolution.h); those with
  // `smeared` set are the warnings a caller should show.
  std::vector<LobeResolution> lobes;
  std::vector<StageTime> times;

  RadiositySystem() = default;
  RadiositySystem(const RadiositySystem&) = delete;
  RadiositySystem& operator=(const RadiositySystem&) = delete;
  double seconds(const std::string& stage) const;
};

std::unique_ptr<RadiositySystem> build_system(Scene scene, const PipelineOptions& options = {});

// The --patch-size override as build_system applies it: when patch_size > 0, every object's.
// Whatever meshes the scene again to match a system (path tracer, relight) calls this too.
void override_patch_size(Scene& scene, double patch_size);

// Peak resident memory of this process so far, in bytes.
std::size_t peak_memory_bytes();

}  // namespace polyrad
