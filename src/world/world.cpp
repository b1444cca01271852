// The scene as every computation sees it (world/world.h).
#include "polyrad/world/world.h"

#include <cstdio>

#include "polyrad/util/machine.h"

namespace polyrad {

namespace {

// A patch, its share of the BVH and of the light sampler, in bytes (measured about 300).
constexpr double kBytesPerPatch = 350.0;

// The light sampler's weights: the area of every patch of a named light.
std::vector<double> light_areas(const PatchSet& patches) {
  std::vector<double> weight(patches.size(), 0.0);
  for (size_t p = 0; p < patches.size(); ++p)
    if (patches[p].emitter) weight[p] = patches[p].area;
  return weight;
}

}  // namespace

World::~World() = default;

std::shared_ptr<const World> World::build(Scene scene, const SceneOverrides& overrides) {
  Scene s = apply_overrides(std::move(scene), overrides);
  const double patches = count_patches(s);
  const double memory = physical_memory_bytes();
  if (memory > 0.0 && patches * kBytesPerPatch > 0.8 * memory) {
    char text[256];
    std::snprintf(text, sizeof text,
                  "the scene meshes into %.3g patches, which alone would need %.3g GiB; use a "
                  "larger patch_size",
                  patches, patches * kBytesPerPatch / (1 << 30));
    throw InputError(SourceLocation{s.file}, text);
  }
  std::shared_ptr<World> w(new World());
  w->overrides_ = overrides;
  w->scene_ = std::move(s);
  Stopwatch watch;
  w->patches_ = mesh_scene(w->scene_);
  w->times_.push_back({"mesh", watch.lap()});
  w->caster_ = std::make_unique<RayCaster>(w->patches_);
  w->lights_ = std::make_unique<LightSampler>(w->patches_, light_areas(w->patches_));
  w->times_.push_back({"ray_caster", watch.lap()});
  return w;
}

std::shared_ptr<const World> World::load(const std::string& scene_path,
                                         const SceneOverrides& overrides,
                                         const SceneOptions& scene_options) {
  return build(load_scene(scene_path, scene_options), overrides);
}

}  // namespace polyrad
