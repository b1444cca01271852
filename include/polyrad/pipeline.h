// The stages from a scene to its transport operator, run in order and timed:
//   mesh -> ray caster -> form factors -> specular transfer -> operator T.
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

#include "polyrad/form_factors.h"
#include "polyrad/mesher.h"
#include "polyrad/ray_caster.h"
#include "polyrad/scene.h"
#include "polyrad/specular_transfer.h"
#include "polyrad/transport.h"

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
};

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
  std::vector<StageTime> times;

  RadiositySystem() = default;
  RadiositySystem(const RadiositySystem&) = delete;
  RadiositySystem& operator=(const RadiositySystem&) = delete;
  double seconds(const std::string& stage) const;
};

std::unique_ptr<RadiositySystem> build_system(Scene scene, const PipelineOptions& options = {});

// Peak resident memory of this process so far, in bytes.
std::size_t peak_memory_bytes();

}  // namespace polyrad
