// Scenes: what a scene file describes, checked and with its meshes loaded.
//
//   stage 1  parse_scene_file   text -> SceneDesc records (scene/scene_parser.h)
//   stage 2  resolve_scene      cross-references checked, OBJ meshes loaded -> Scene
//   (then    World, world/world.h, meshes it into patches and builds the ray caster)
//
// load_scene() runs both stages. Every problem throws InputError naming the file and, where
// the format allows, the line and column. The format is documented in docs/scene-format.md.
//
//   Scene scene = load_scene("scenes/cornell-box.json");
//   ObjectId light = scene.find_object("light");
//
// Cost: the parse, plus reading each OBJ file once.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "polyrad/scene/brdf.h"
#include "polyrad/scene/camera.h"
#include "polyrad/scene/obj_reader.h"
#include "polyrad/scene/scene_parser.h"
#include "polyrad/types.h"

namespace polyrad {

struct SceneObject {
  std::string name;
  MaterialId material = 0;
  Rgb emission = Rgb::Zero();
  bool is_emitter = false;  // has an "emission" key (even 0,0,0: still an addressable light)
  double patch_size = 0.0;
  double authored_patch_size = 0.0;  // patch_size as the scene gives it; overrides leave it
  std::vector<Face> faces;
};

struct Scene {
  std::string file;
  Camera camera;
  std::vector<Material> materials;
  std::vector<SceneObject> objects;
  std::uint64_t hash = 0;  // fnv1a64 of the scene text and every mesh it loads

  // The object of that name, or -1.
  ObjectId find_object(const std::string& name) const;
};

// What a run may change of a scene as written, applied by apply_overrides (and so by World):
// the longest patch edge of every object, and the classic system's materials.
struct SceneOverrides {
  double patch_size = 0.0;  // > 0: overrides every object's patch_size
  bool classic = false;     // every material reduced to its diffuse part
};
// The scene with the overrides applied. Scene::hash stays the file's: it identifies the text.
Scene apply_overrides(Scene scene, const SceneOverrides& overrides);

Scene resolve_scene(const SceneDesc& desc);
Scene load_scene(const std::string& path, const SceneOptions& options = {});

}  // namespace polyrad
