// Stage 1 of scene loading: JSON text -> SceneDesc records (docs/scene-format.md).
#include "polyrad/scene/scene_parser.h"

#include <cmath>
#include <unordered_map>

#include "polyrad/util/files.h"
#include "polyrad/util/hash.h"
#include "polyrad/util/json.h"

namespace polyrad {

namespace {

Vec3 read_vec3(const JsonValue& v, const std::string& what) {
  auto n = json_numbers(v, what, 3);
  return Vec3(n[0], n[1], n[2]);
}

// A colour whose channels must lie in [0, max].
Rgb read_colour(const JsonValue& v, const std::string& what, double max) {
  auto n = json_numbers(v, what, 3);
  for (double c : n)
    if (c < 0.0 || c > max)
      throw InputError(v.where, what + " channels must lie in [0, " +
                                    std::to_string(max).substr(0, 3) + "], got " +
                                    std::to_string(c));
  return Rgb(n[0], n[1], n[2]);
}

double positive(ObjectReader& r, const char* key, const std::string& what) {
  const JsonValue& v = r.get(key);
  double x = json_number(v, std::string(key) + " of " + what);
  if (!(x > 0.0)) throw InputError(v.where, std::string(key) + " of " + what + " must be > 0");
  return x;
}

int image_side(ObjectReader& r, const char* key) {
  const JsonValue& v = r.get(key);
  double x = json_number(v, key);
  if (x != std::floor(x) || x < 1 || x > 16384)
    throw InputError(v.where, std::string("camera ") + key + " must be an integer in [1, 16384]");
  return static_cast<int>(x);
}

Camera read_camera(const JsonValue& value) {
  ObjectReader r(value, "camera");
  Camera c;
  c.position = read_vec3(r.get("position"), "camera position");
  const JsonValue& look = r.get("look_at");
  c.look_at = read_vec3(look, "camera look_at");
  if (const JsonValue* up = r.optional("up")) c.up = read_vec3(*up, "camera up");
  const JsonValue& fov = r.get("fov_deg");
  c.fov_deg = json_number(fov, "camera fov_deg");
  if (!(c.fov_deg > 0.0 && c.fov_deg < 180.0))
    throw InputError(fov.where, "camera fov_deg must lie in (0, 180)");
  c.width = image_side(r, "width");
  c.height = image_side(r, "height");
  r.finish();
  Vec3 f = c.look_at - c.position;
  if (f.norm() == 0.0) throw InputError(look.where, "camera look_at equals its position");
  if (c.up.norm() == 0.0 || f.normalized().cross(c.up.normalized()).norm() < 1e-6)
    throw InputError(value.where, "camera up must not be zero or parallel to the view direction");
  return c;
}

void check_albedo(const Material& m, const SourceLocation& where, const SceneOptions& options) {
  if (options.allow_unsafe_albedo) return;
  Rgb bound = m.albedo_bound();
  static const char* kChannel[3] = {"red", "green", "blue"};
  for (int c = 0; c < 3; ++c)
    if (bound[c] > 1.0 + 1e-12)
      throw InputError(where, "material '" + m.name + "': diffuse + specular = " +
                                  std::to_string(bound[c]) + " in the " + kChannel[c] +
                                  " channel; its albedo could exceed 1 and create energy");
}

MaterialDesc read_material(const std::string& name, const JsonValue& value,
                           const SceneOptions& options) {
  std::string what = "material '" + name + "'";
  ObjectReader r(value, what);
  const JsonValue& type_value = r.get("type");
  if (!type_value.is(JsonValue::Kind::kString))
    throw InputError(type_value.where, what + ": type must be a string");
  const std::string& type = type_value.string;
  // Unsafe materials may exceed 1 per channel (tests of divergence detection only).
  double max = options.allow_unsafe_albedo ? 1e3 : 1.0;
  Material m;
  if (type == "diffuse") {
    m = Material::lambert(name, read_colour(r.get("reflectance"), what + " reflectance", max));
  } else if (type == "mirror") {
    m = Material::mirror(name, read_colour(r.get("reflectance"), what + " reflectance", max));
  } else if (type == "glossy" || type == "phong") {
    Rgb diffuse = Rgb::Zero();
    if (const JsonValue* d = r.optional("diffuse"))
      diffuse = read_colour(*d, what + " diffuse", max);
    Rgb specular = read_colour(r.get("specular"), what + " specular", max);
    if (type == "glossy") {
      const JsonValue& a = r.get("roughness");
      double alpha = json_number(a, what + " roughness");
      if (alpha < 0.0 || alpha > 1.0)
        throw InputError(a.where, what + ": roughness (GGX alpha) must lie in [0, 1]");
      m = Material::glossy(name, diffuse, specular, alpha);
    } else {
      const JsonValue& e = r.get("exponent");
      double n = json_number(e, what + " exponent");
      if (n < 0.0 || n > 1e6) throw InputError(e.where, what + ": exponent must lie in [0, 1e6]");
      m = Material::phong(name, diffuse, specular, n);
    }
  } else {
    throw InputError(type_value.where, what + ": unknown type '" + type +
                                           "' (expected diffuse, mirror, glossy or phong)");
  }
  r.finish();
  check_albedo(m, value.where, options);
  return MaterialDesc{m, value.where};
}

ObjectDesc read_object(const JsonValue& value, size_t index) {
  ObjectReader r(value, "object #" + std::to_string(index + 1));
  ObjectDesc o;
  o.where = value.where;
  const JsonValue& name = r.get("name");
  if (!name.is(JsonValue::Kind::kString) || name.string.empty())
    throw InputError(name.where, "object name must be a non-empty string");
  o.name = name.string;
  std::string what = "object '" + o.name + "'";
  const JsonValue& mat = r.get("material");
  if (!mat.is(JsonValue::Kind::kString))
    throw InputError(mat.where, what + ": material must be a string");
  o.material = mat.string;
  o.material_where = mat.where;
  if (const JsonValue* e = r.optional("emission")) {
    auto n = json_numbers(*e, what + " emission", 3);
    for (double c : n)
      if (c < 0.0) throw InputError(e->where, what + ": emission must not be negative");
    o.emission = Rgb(n[0], n[1], n[2]);
  }
  if (r.has("patch_size")) o.patch_size = positive(r, "patch_size", what);
  const JsonValue* polygon = r.optional("polygon");
  const JsonValue* mesh = r.optional("mesh");
  if ((polygon != nullptr) == (mesh != nullptr))
    throw InputError(value.where, what + " needs exactly one of 'polygon' and 'mesh'");
  if (polygon) {
    if (!polygon->is(JsonValue::Kind::kArray) || polygon->array.size() < 3)
      throw InputError(polygon->where, what + ": polygon must be an array of at least 3 points");
    for (const auto& p : polygon->array) o.polygon.push_back(read_vec3(p, what + " polygon point"));
  } else {
    if (!mesh->is(JsonValue::Kind::kString) || mesh->string.empty())
      throw InputError(mesh->where, what + ": mesh must be a file path");
    o.mesh = mesh->string;
    o.mesh_where = mesh->where;
  }
  r.finish();
  return o;
}

}  // namespace

SceneDesc parse_scene_text(const std::string& text, const std::string& file,
                           const SceneOptions& options) {
  JsonValue root = parse_json(text, file);
  ObjectReader r(root, "the scene");
  SceneDesc d;
  d.file = file;
  auto slash = file.find_last_of('/');
  d.directory = slash == std::string::npos ? "." : file.substr(0, slash);
  d.text_hash = fnv1a64(text.data(), text.size());
  d.camera = read_camera(r.object("camera"));
  d.patch_size = positive(r, "patch_size", "the scene");

  const JsonValue& materials = r.object("materials");
  for (const auto& [name, value] : materials.object) {
    if (name.empty()) throw InputError(value.where, "material names must not be empty");
    d.materials.push_back(read_material(name, value, options));
  }
  const JsonValue& objects = r.array("objects");
  if (objects.array.empty()) throw InputError(objects.where, "the scene has no objects");
  std::unordered_map<std::string, size_t> first_use;  // a scan of all earlier names was quadratic
  for (size_t n = 0; n < objects.array.size(); ++n) {
    d.objects.push_back(read_object(objects.array[n], n));
    auto [earlier, fresh] = first_use.emplace(d.objects[n].name, n);
    if (!fresh)
      throw InputError(d.objects[n].where, "object name '" + d.objects[n].name +
                                               "' is used twice (first at " +
                                               d.objects[earlier->second].where.str() + ")");
  }
  r.finish();
  return d;
}

SceneDesc parse_scene_file(const std::string& path, const SceneOptions& options) {
  return parse_scene_text(read_text_file(path, "the scene file"), path, options);
}

}  // namespace polyrad
