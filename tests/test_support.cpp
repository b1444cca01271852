#include "test_support.h"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

namespace polyrad::test {

namespace {

struct TempRoot {
  std::filesystem::path path;
  TempRoot() {
    path = std::filesystem::temp_directory_path() /
           ("polyrad-test-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(path);
  }
  ~TempRoot() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

}  // namespace

std::filesystem::path temp_dir() {
  static TempRoot root;
  static int counter = 0;
  auto dir = root.path / std::to_string(counter++);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string write_file(const std::filesystem::path& dir, const std::string& name,
                       const std::string& text) {
  auto path = dir / name;
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

Scene scene_from_json(const std::string& json, const std::filesystem::path& dir) {
  auto d = dir.empty() ? temp_dir() : dir;
  return load_scene(write_file(d, "scene.json", json));
}

std::string scene_path(const std::string& name) {
  return std::string(POLYRAD_SCENES_DIR) + "/" + name + ".json";
}

Patch make_quad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  Patch p;
  p.corner = {a, b, c, d};
  p.corners = 4;
  Vec3 n = (c - a).cross(d - b);
  p.area = 0.5 * n.norm();
  p.normal = n.normalized();
  p.centroid = (a + b + c + d) / 4.0;
  return p;
}

PatchSet make_patch_set(std::vector<Patch> patches) {
  PatchSet s;
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (auto& p : patches)
    for (int c = 0; c < 4; ++c) {
      lo = lo.cwiseMin(p.corner[c]);
      hi = hi.cwiseMax(p.corner[c]);
    }
  s.scene_diameter = (hi - lo).norm();
  s.patches = std::move(patches);
  for (size_t n = 0; n < s.patches.size(); ++n)
    for (int c = 0; c < 4; ++c) s.patches[n].vertex_id[c] = static_cast<int>(4 * n + c);
  s.vertex_ids = static_cast<int>(4 * s.patches.size());
  return s;
}

std::string closed_box_json(const Vec3& size, double patch_size, const std::string& material,
                            double emission) {
  double x = size.x(), y = size.y(), z = size.z();
  auto pt = [](double a, double b, double c) {
    std::ostringstream s;
    s << "[" << a << ", " << b << ", " << c << "]";
    return s.str();
  };
  struct F { const char* name; std::string poly; };
  std::vector<F> faces = {
      {"floor", pt(0, 0, 0) + "," + pt(0, 0, z) + "," + pt(x, 0, z) + "," + pt(x, 0, 0)},
      {"ceiling", pt(0, y, 0) + "," + pt(x, y, 0) + "," + pt(x, y, z) + "," + pt(0, y, z)},
      {"left", pt(0, 0, 0) + "," + pt(0, y, 0) + "," + pt(0, y, z) + "," + pt(0, 0, z)},
      {"right", pt(x, 0, 0) + "," + pt(x, 0, z) + "," + pt(x, y, z) + "," + pt(x, y, 0)},
      {"back", pt(0, 0, z) + "," + pt(0, y, z) + "," + pt(x, y, z) + "," + pt(x, 0, z)},
      {"front", pt(0, 0, 0) + "," + pt(x, 0, 0) + "," + pt(x, y, 0) + "," + pt(0, y, 0)},
  };
  std::ostringstream s;
  s << "{\"camera\": {\"position\": " << pt(x / 2, y / 2, z * 0.05) << ", \"look_at\": "
    << pt(x / 2, y / 2, z) << ", \"fov_deg\": 90, \"width\": 32, \"height\": 32},\n"
    << "\"patch_size\": " << patch_size << ",\n\"materials\": {\"m\": " << material << "},\n"
    << "\"objects\": [\n";
  for (size_t f = 0; f < faces.size(); ++f)
    s << "{\"name\": \"" << faces[f].name << "\", \"material\": \"m\", \"emission\": ["
      << emission << ", " << emission << ", " << emission << "], \"polygon\": [" << faces[f].poly
      << "]}" << (f + 1 < faces.size() ? "," : "") << "\n";
  s << "]}\n";
  return s.str();
}

double parallel_rectangles_ff(double a, double b, double c) {
  double X = a / c, Y = b / c;
  double x1 = std::sqrt(1 + X * X), y1 = std::sqrt(1 + Y * Y);
  return 2.0 / (kPi * X * Y) *
         (std::log(std::sqrt((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y))) +
          X * y1 * std::atan(X / y1) + Y * x1 * std::atan(Y / x1) - X * std::atan(X) -
          Y * std::atan(Y));
}

double perpendicular_rectangles_ff(double l, double w, double h) {
  double H = h / l, W = w / l;
  double h2 = H * H, w2 = W * W, s = std::sqrt(h2 + w2);
  double a = (1 + w2) * (1 + h2) / (1 + w2 + h2);
  double b = std::pow(w2 * (1 + w2 + h2) / ((1 + w2) * (w2 + h2)), w2);
  double c = std::pow(h2 * (1 + w2 + h2) / ((1 + h2) * (w2 + h2)), h2);
  return 1.0 / (kPi * W) *
         (W * std::atan(1 / W) + H * std::atan(1 / H) - s * std::atan(1 / s) +
          0.25 * std::log(a * b * c));
}

}  // namespace polyrad::test
