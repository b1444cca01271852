// Stage 2 of scene loading: cross-references, meshes, face checks -> Scene.
#include "polyrad/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <unordered_map>

#include "polyrad/util/files.h"
#include "polyrad/util/hash.h"

namespace polyrad {

namespace {

// Faces must be convex and planar; a quad may bend slightly (the measured Cornell walls bend by
// 0.15 percent of their size) because the mesher subdivides it bilinearly.
constexpr double kPlanarTolerance = 0.01;

void validate_face(const Face& f, const SourceLocation& where, const std::string& what) {
  const auto& v = f.vertices;
  size_t n = v.size();
  Vec3 normal = Vec3::Zero();
  double size = 0.0;
  for (size_t a = 0; a < n; ++a) {
    normal += v[a].cross(v[(a + 1) % n]);
    for (size_t b = a + 1; b < n; ++b) size = std::max(size, (v[a] - v[b]).norm());
  }
  double area = 0.5 * normal.norm();
  // Past about 1e150 the squares overflow: the normal would normalise to zero and every check
  // below would pass whatever the shape.
  if (!std::isfinite(area) || !std::isfinite(size * size))
    throw InputError(where, what + " has coordinates too large to compute with");
  if (!(size > 0.0) || !(area > 1e-9 * size * size))
    throw InputError(where, what + " is degenerate (zero area)");
  normal.normalize();
  Vec3 centre = Vec3::Zero();
  for (const auto& p : v) centre += p / static_cast<double>(n);
  for (const auto& p : v)
    if (std::abs((p - centre).dot(normal)) > kPlanarTolerance * size)
      throw InputError(where, what + " is not planar");
  for (size_t a = 0; a < n; ++a) {
    Vec3 e0 = v[(a + 1) % n] - v[a];
    Vec3 e1 = v[(a + 2) % n] - v[(a + 1) % n];
    if (e0.norm() < 1e-9 * size) throw InputError(where, what + " repeats a vertex");
    if (e0.cross(e1).dot(normal) < -1e-9 * size * size)
      throw InputError(where, what + " is not convex");
  }
}

std::string resolve_path(const std::string& directory, const std::string& relative) {
  std::filesystem::path p(relative);
  if (p.is_absolute()) return relative;
  return (std::filesystem::path(directory) / p).lexically_normal().string();
}

}  // namespace

Scene apply_overrides(Scene scene, const SceneOverrides& overrides) {
  if (overrides.patch_size > 0.0)
    for (auto& o : scene.objects) {
      if (!(o.authored_patch_size > 0.0)) o.authored_patch_size = o.patch_size;  // built in code
      o.patch_size = overrides.patch_size;
    }
  if (overrides.classic)
    for (auto& m : scene.materials) m = Material::lambert(m.name, m.diffuse);
  return scene;
}

ObjectId Scene::find_object(const std::string& name) const {
  for (size_t n = 0; n < objects.size(); ++n)
    if (objects[n].name == name) return static_cast<ObjectId>(n);
  return -1;
}

Scene resolve_scene(const SceneDesc& desc) {
  Scene s;
  s.file = desc.file;
  s.camera = desc.camera;
  s.hash = desc.text_hash;
  // Names to ids through a map: a scan per object was quadratic in hostile files.
  std::unordered_map<std::string, MaterialId> material_ids;
  for (const auto& m : desc.materials) {
    material_ids.emplace(m.material.name, static_cast<MaterialId>(s.materials.size()));
    s.materials.push_back(m.material);
  }

  for (const auto& o : desc.objects) {
    SceneObject obj;
    obj.name = o.name;
    auto it = material_ids.find(o.material);
    if (it == material_ids.end())
      throw InputError(o.material_where,
                       "object '" + o.name + "': unknown material '" + o.material + "'");
    obj.material = it->second;
    obj.is_emitter = o.emission.has_value();
    obj.emission = o.emission.value_or(Rgb::Zero());
    obj.patch_size = o.patch_size.value_or(desc.patch_size);
    obj.authored_patch_size = obj.patch_size;

    if (!o.polygon.empty()) {
      obj.faces.push_back(Face{o.polygon, 0});
      validate_face(obj.faces.back(), o.where, "object '" + o.name + "': its polygon");
    } else {
      std::string path = resolve_path(desc.directory, o.mesh);
      if (!std::filesystem::exists(path))
        throw InputError(o.mesh_where,
                         "object '" + o.name + "': mesh file '" + path + "' does not exist");
      std::string text = read_text_file(path, "the mesh file");
      s.hash = fnv1a64(text.data(), text.size(), s.hash);
      obj.faces = read_obj_text(text, path);
      for (size_t f = 0; f < obj.faces.size(); ++f)
        validate_face(obj.faces[f], SourceLocation{path, obj.faces[f].source_line},
                      "object '" + o.name + "': face " + std::to_string(f + 1));
    }
    s.objects.push_back(std::move(obj));
  }
  return s;
}

Scene load_scene(const std::string& path, const SceneOptions& options) {
  return resolve_scene(parse_scene_file(path, options));
}

}  // namespace polyrad
