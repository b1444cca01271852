// The scene as every computation sees it: the records with their overrides applied, the
// patches, the ray caster over them and the sampler of the named lights. Built once, then
// immutable and shared: the form factors, the specular transfer, the camera gather, the path
// tracer and the region map all take it, so whatever they compute, they see the same scene.
//
// The overrides live here and nowhere else: `patch_size` re-meshes every object, and `classic`
// reduces every material to its diffuse part, so that the transport, the gather and the path
// tracer all see the classic scene without a flag of their own.
//
//   auto world = World::load("scenes/cornell-box.json", {.patch_size = 25});
//   Hit h = world->caster().intersect(origin, direction);
//   const Patch& p = world->patches()[h.patch];
//
// Cost: the mesher (O(patches)) and Embree's BVH (O(P log P) time); memory about 350 bytes a
// patch (the patch and its BVH share). Not copyable or movable: the ray caster and the light
// sampler refer to the patches; hold it by std::shared_ptr.
#pragma once

#include <memory>
#include <string>

#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/scene.h"
#include "polyrad/util/timer.h"
#include "polyrad/world/light_sampling.h"

namespace polyrad {

class World {
 public:
  // Throws InputError when the patches alone would not fit in memory (a tiny patch_size).
  static std::shared_ptr<const World> build(Scene scene, const SceneOverrides& overrides = {});
  static std::shared_ptr<const World> load(const std::string& scene_path,
                                           const SceneOverrides& overrides = {},
                                           const SceneOptions& scene_options = {});

  const Scene& scene() const { return scene_; }
  const Camera& camera() const { return scene_.camera; }
  const std::vector<Material>& materials() const { return scene_.materials; }
  const PatchSet& patches() const { return patches_; }
  const RayCaster& caster() const { return *caster_; }
  // Points on the patches of the named lights (objects with an "emission" key), drawn by area:
  // the choice does not depend on the lights' values, so relighting may give any light any
  // emission.
  const LightSampler& lights() const { return *lights_; }
  // What build() applied to the scene (apply_overrides).
  const SceneOverrides& overrides() const { return overrides_; }
  // "mesh" and "ray_caster".
  const StageTimes& times() const { return times_; }

  World(const World&) = delete;
  World& operator=(const World&) = delete;
  ~World();

 private:
  World() = default;
  Scene scene_;
  SceneOverrides overrides_;
  PatchSet patches_;
  std::unique_ptr<RayCaster> caster_;
  std::unique_ptr<LightSampler> lights_;
  StageTimes times_;
};

}  // namespace polyrad
