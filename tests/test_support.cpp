#include "test_support.h"

#include <omp.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include "polyrad/transport/form_factors.h"

namespace polyrad::test {

namespace {

struct TempRoot {
  std::filesystem::path path;
  TempRoot() {
    path = std::filesystem::temp_directory_path() / ("polyrad-test-" + std::to_string(::getpid()) +
                                                     "-" + std::to_string(std::random_device{}()));
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
  return closed_box_json(size, patch_size, std::vector<std::string>(6, material), emission);
}

std::string closed_box_json(const Vec3& size, double patch_size,
                            const std::vector<std::string>& face_materials, double emission) {
  double x = size.x(), y = size.y(), z = size.z();
  auto pt = [](double a, double b, double c) {
    std::ostringstream s;
    s << "[" << a << ", " << b << ", " << c << "]";
    return s.str();
  };
  struct F {
    const char* name;
    std::string poly;
  };
  std::vector<F> faces = {
      {"floor", pt(0, 0, 0) + "," + pt(0, 0, z) + "," + pt(x, 0, z) + "," + pt(x, 0, 0)},
      {"ceiling", pt(0, y, 0) + "," + pt(x, y, 0) + "," + pt(x, y, z) + "," + pt(0, y, z)},
      {"left", pt(0, 0, 0) + "," + pt(0, y, 0) + "," + pt(0, y, z) + "," + pt(0, 0, z)},
      {"right", pt(x, 0, 0) + "," + pt(x, 0, z) + "," + pt(x, y, z) + "," + pt(x, y, 0)},
      {"back", pt(0, 0, z) + "," + pt(0, y, z) + "," + pt(x, y, z) + "," + pt(x, 0, z)},
      {"front", pt(0, 0, 0) + "," + pt(x, 0, 0) + "," + pt(x, y, 0) + "," + pt(0, y, 0)},
  };
  std::ostringstream s;
  s << "{\"camera\": {\"position\": " << pt(x / 2, y / 2, z * 0.05)
    << ", \"look_at\": " << pt(x / 2, y / 2, z)
    << ", \"fov_deg\": 90, \"width\": 32, \"height\": 32},\n"
    << "\"patch_size\": " << patch_size << ",\n\"materials\": {";
  for (size_t f = 0; f < faces.size(); ++f)
    s << "\"m" << f << "\": " << face_materials.at(f) << (f + 1 < faces.size() ? ", " : "");
  s << "},\n\"objects\": [\n";
  for (size_t f = 0; f < faces.size(); ++f)
    s << "{\"name\": \"" << faces[f].name << "\", \"material\": \"m" << f << "\", \"emission\": ["
      << emission << ", " << emission << ", " << emission << "], \"polygon\": [" << faces[f].poly
      << "]}" << (f + 1 < faces.size() ? "," : "") << "\n";
  s << "]}\n";
  return s.str();
}

Field gauss_seidel_on(const TransportOperator& t, int threads, int sweeps) {
  omp_set_num_threads(threads);
  Field u = t.emission();
  for (int k = 0; k < sweeps; ++k) t.gauss_seidel_sweep(t.emission(), u);
  omp_set_num_threads(omp_get_num_procs());
  return u;
}

const char* const kMirrorFloor = R"({
  "camera": {"position": [0, 3, -4], "look_at": [0, 0, 0], "fov_deg": 40, "width": 8, "height": 8},
  "patch_size": 0.25,
  "materials": {
    "black": {"type": "diffuse", "reflectance": [0, 0, 0]},
    "card":  {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
    "glass": {"type": "mirror",  "reflectance": [0.8, 0.8, 0.8]}
  },
  "objects": [
    {"name": "lamp", "material": "black", "emission": [1, 1, 1], "patch_size": 0.1,
     "polygon": [[-1.2, 1, -0.2], [-0.8, 1, -0.2], [-0.8, 1, 0.2], [-1.2, 1, 0.2]]},
    {"name": "receiver", "material": "card", "patch_size": 1,
     "polygon": [[RX0, 1, -0.2], [RX1, 1, -0.2], [RX1, 1, 0.2], [RX0, 1, 0.2]]},
    {"name": "mirror", "material": "glass",
     "polygon": [[MX0, 0, MZ0], [MX0, 0, MZ1], [MX1, 0, MZ1], [MX1, 0, MZ0]]}
  ]
})";

std::string mirror_floor_json(double rx0, double rx1, double mx0, double mx1, double mz0,
                              double mz1) {
  std::string s = kMirrorFloor;
  auto put = [&](const std::string& key, double v) {
    for (size_t at; (at = s.find(key)) != std::string::npos;)
      s.replace(at, key.size(), std::to_string(v));
  };
  put("RX0", rx0);
  put("RX1", rx1);
  put("MX0", mx0);
  put("MX1", mx1);
  put("MZ0", mz0);
  put("MZ1", mz1);
  return s;
}

Scene facing_mirrors_black() {
  Scene scene = load_scene(scene_path("stability/facing-mirrors-black"));
  scene.camera.position = Vec3(0.1, 0.5, 0.5);
  scene.camera.look_at = Vec3(0.1, 0.0, 0.5);
  scene.camera.up = Vec3(0, 0, 1);
  scene.camera.fov_deg = 16.0;
  scene.camera.width = scene.camera.height = 8;
  return scene;
}

Scene mirrored_room() {
  Scene scene = load_scene(scene_path("stability/mirrored-room"));
  scene.camera.width = scene.camera.height = 8;
  return scene;
}

double mirrored_room_floor_radiance(const Vec3& x) {
  constexpr int kImages = 60;  // 0.9^60 = 2e-3 of a term that is itself far
  double sum = 0.0;
  for (int i = -kImages; i <= kImages; ++i)
    for (int j = -kImages + std::abs(i); j <= kImages - std::abs(i); ++j) {
      const double x0 = 0.15 + 0.4 * i, z0 = 0.15 + 0.4 * j;
      const std::vector<Vec3> lamp{{x0, 0.999, z0},
                                   {x0 + 0.1, 0.999, z0},
                                   {x0 + 0.1, 0.999, z0 + 0.1},
                                   {x0, 0.999, z0 + 0.1}};
      sum += std::pow(0.9, std::abs(i) + std::abs(j)) *
             std::abs(point_to_polygon_form_factor(x, Vec3(0, 1, 0), lamp));
    }
  return 0.9 * sum;
}

double facing_mirrors_floor_radiance(const Vec3& x) {
  constexpr int kImages = 150;
  double sum = 0.0;
  for (int k = -kImages; k <= kImages; ++k) {
    const double x0 = 0.05 + 0.2 * k, x1 = 0.15 + 0.2 * k;
    const std::vector<Vec3> lamp{
        {x0, 0.999, 0.45}, {x1, 0.999, 0.45}, {x1, 0.999, 0.55}, {x0, 0.999, 0.55}};
    sum += std::pow(0.99, std::abs(k)) *
           std::abs(point_to_polygon_form_factor(x, Vec3(0, 1, 0), lamp));
  }
  return 0.9 * sum;
}

double facing_mirrors_floor_mean() {
  constexpr int nx = 10, nz = 50;
  double sum = 0.0;
  for (int a = 0; a < nx; ++a)
    for (int b = 0; b < nz; ++b)
      sum += facing_mirrors_floor_radiance(Vec3(0.2 * (a + 0.5) / nx, 0.0, (b + 0.5) / nz));
  return sum / (nx * nz);
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

namespace polyrad::test {

double parallel_offset_rectangles_ff(double x1, double x2, double y1, double y2, double xi1,
                                     double xi2, double eta1, double eta2, double c) {
  // A1 F12 = 1/(2 pi) sum (-1)^(i+j+k+l) G(x_i - xi_k, y_j - eta_l), with
  // G(u, v) = v sqrt(u^2 + c^2) atan(v / sqrt(u^2 + c^2)) + u sqrt(v^2 + c^2) atan(u / sqrt(v^2 +
  // c^2))
  //           - c^2 / 2 ln(u^2 + v^2 + c^2).
  auto g = [c](double u, double v) {
    double su = std::sqrt(u * u + c * c), sv = std::sqrt(v * v + c * c);
    return v * su * std::atan(v / su) + u * sv * std::atan(u / sv) -
           0.5 * c * c * std::log(u * u + v * v + c * c);
  };
  double xs[2] = {x1, x2}, ys[2] = {y1, y2}, xis[2] = {xi1, xi2}, etas[2] = {eta1, eta2};
  double sum = 0.0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k)
        for (int l = 0; l < 2; ++l)
          sum += ((i + j + k + l) % 2 == 0 ? 1.0 : -1.0) * g(xs[i] - xis[k], ys[j] - etas[l]);
  return sum / (2.0 * kPi * (x2 - x1) * (y2 - y1));
}

}  // namespace polyrad::test

namespace polyrad::test {

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

JsonValue read_json(const std::filesystem::path& path) {
  return parse_json(read_text(path), path.string());
}

CommandRun run_shell(const std::string& command) {
  auto dir = temp_dir();
  const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
  const int status = std::system((command + " >" + out + " 2>" + err).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(out), read_text(err)};
}

CommandRun run_cli(const std::string& args) {
  return run_shell(std::string(POLYRAD_CLI) + " --quiet " + args);
}

}  // namespace polyrad::test
