// Scenes: the JSON + OBJ file format, read in stages.
//
//   stage 1  parse_scene_file   text -> SceneDesc records that remember file:line:column;
//                                syntax, kinds, ranges and unknown keys are checked here
//   stage 2  resolve_scene      cross-references checked, OBJ meshes loaded -> Scene
//   (then    mesh_scene in mesher.h turns the Scene into patches)
//
// load_scene() runs both stages. Every problem throws InputError naming the file and, where
// the format allows, the line and column. The format is documented in docs/scene-format.md.
//
//   Scene scene = load_scene("scenes/cornell-box.json");
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "polyrad/brdf.h"
#include "polyrad/camera.h"
#include "polyrad/error.h"
#include "polyrad/types.h"

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
  std::optional<Rgb> emission;      // Lambertian radiance of the front side
  std::optional<double> patch_size;  // overrides the scene's
  std::vector<Vec3> polygon;        // either a polygon ...
  std::string mesh;                 // ... or an OBJ path relative to the scene file
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

// One planar convex polygon, counter-clockwise seen from its front.
struct Face {
  std::vector<Vec3> vertices;
  int source_line = 0;  // line of the OBJ file it came from; 0 for a scene polygon
};

struct SceneObject {
  std::string name;
  MaterialId material = 0;
  Rgb emission = Rgb::Zero();
  bool is_emitter = false;  // has an "emission" key (even 0,0,0: still an addressable light)
  double patch_size = 0.0;
  std::vector<Face> faces;
};

struct Scene {
  std::string file;
  Camera camera;
  std::vector<Material> materials;
  std::vector<SceneObject> objects;
  std::uint64_t hash = 0;  // of the scene text and every mesh it loads

  // The object of that name, or -1.
  ObjectId find_object(const std::string& name) const;
};

struct SceneOptions {
  // Accept materials whose albedo bound exceeds 1 (for tests of divergence detection only).
  bool allow_unsafe_albedo = false;
};

SceneDesc parse_scene_text(const std::string& text, const std::string& file,
                           const SceneOptions& options = {});
SceneDesc parse_scene_file(const std::string& path, const SceneOptions& options = {});
Scene resolve_scene(const SceneDesc& desc);
Scene load_scene(const std::string& path, const SceneOptions& options = {});

// OBJ reading (v and f statements; vn, vt, g, o, s, usemtl, mtllib ignored). Faces keep their
// vertex order; polygons are returned as they are, triangles and quads alike.
std::vector<Face> read_obj_text(const std::string& text, const std::string& file);
std::vector<Face> read_obj_file(const std::string& path);

// 64-bit FNV-1a, used for scene hashes and file checksums.
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed = 0xcbf29ce484222325ull);

}  // namespace polyrad
