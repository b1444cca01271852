// Stage 1 of scene loading: JSON text -> SceneDesc, plain records that remember
// file:line:column. Syntax, kinds, ranges and unknown keys are checked here; cross-references
// and meshes wait for stage 2 (scene/scene.h, resolve_scene). Every problem throws InputError
// naming the file and, where the format allows, the line and column (docs/scene-format.md).
//
//   SceneDesc d = parse_scene_file("scenes/cornell-box.json");
//   Scene s = resolve_scene(d);                 // or load_scene(path), both stages
//
// Cost: one pass over the text.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "polyrad/scene/brdf.h"
#include "polyrad/scene/camera.h"
#include "polyrad/types.h"
#include "polyrad/util/error.h"

namespace polyrad {

struct MaterialDesc {
  Material material;
  SourceLocation where;
};

struct ObjectDesc {
  std::string name;
  std::string material;
  SourceLocation where;
  SourceLocation material_where;
  std::optional<Rgb> emission;       // Lambertian radiance of the front side
  std::optional<double> patch_size;  // overrides the scene's
  std::vector<Vec3> polygon;         // either a polygon ...
  std::string mesh;                  // ... or an OBJ path relative to the scene file
  SourceLocation mesh_where;
};

struct SceneDesc {
  std::string file;  // as given
  std::string directory;
  Camera camera;
  double patch_size = 0.0;
  std::vector<MaterialDesc> materials;
  std::vector<ObjectDesc> objects;
  std::uint64_t text_hash = 0;
};

struct SceneOptions {
  // Accept materials whose albedo bound exceeds 1 (for tests of divergence detection only).
  bool allow_unsafe_albedo = false;
};

SceneDesc parse_scene_text(const std::string& text, const std::string& file,
                           const SceneOptions& options = {});
SceneDesc parse_scene_file(const std::string& path, const SceneOptions& options = {});

}  // namespace polyrad
