#include "cli_common.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "polyrad/util/files.h"
#include "polyrad/io/image_io.h"

namespace polyrad::cli {

void check_output_path(const std::string& path, const char* what) {
  std::filesystem::path p(path);
  std::filesystem::path dir = p.parent_path();
  if (p.filename().empty()) throw InputError(std::string(what) + " '" + path + "' names no file");
  if (!dir.empty() && !std::filesystem::is_directory(dir))
    throw InputError(std::string(what) + " '" + path + "': directory '" + dir.string() +
                     "' does not exist");
  if (std::filesystem::is_directory(p))
    throw InputError(std::string(what) + " '" + path + "' is a directory");
}

void check_image_path(const std::string& path) {
  check_output_path(path, "image");
  if (!is_image_path(path))
    throw InputError("image '" + path + "': unknown format (use .exr, .pfm or .png)");
}

std::string machine_description() {
  std::string model = "unknown CPU";
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string line; std::getline(cpu, line);)
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  std::ostringstream s;
  s << model << ", " << std::thread::hardware_concurrency() << " hardware threads, "
    << (pages > 0 && page > 0 ? static_cast<double>(pages) * page / (1 << 30) : 0.0) << " GiB";
  return s.str();
}

void write_stage_times(JsonWriter& w, const std::vector<StageTime>& times) {
  w.begin_object("seconds");
  for (const auto& t : times) w.value(t.name, t.seconds);
  w.end_object();
}

void write_lobe_checks(JsonWriter& w, const std::vector<LobeResolution>& lobes) {
  auto fields = [&w](const LobeResolution& r) {
    w.value("object", r.object_name).value("material", r.material_name).value("lobe", r.lobe);
    w.value("lobe_width_degrees", r.lobe_degrees).value("patch_angle_degrees", r.patch_degrees);
    w.value("patch_size", r.current_patch_size);
    w.value("resolving_patch_size", r.resolving_patch_size);
  };
  w.begin_array("warnings");
  for (const auto& r : lobes) {
    if (!r.smeared) continue;
    w.begin_object().value("kind", "lobe_smeared_by_patches");
    fields(r);
    w.value("message", describe_smear(r)).end_object();
  }
  w.end_array();
  w.begin_array("lobe_resolution");
  for (const auto& r : lobes) {
    w.begin_object();
    fields(r);
    w.value("smeared", r.smeared).end_object();
  }
  w.end_array();
}

void print_warnings(const RadiositySystem& sys) {
  for (const auto& r : sys.lobes)
    if (r.smeared) std::fprintf(stderr, "polyrad: warning: %s\n", describe_smear(r).c_str());
}

void write_system(JsonWriter& w, const RadiositySystem& sys) {
  const auto& t = sys.transport;
  w.value("scene", sys.scene.file);
  w.value("patches", sys.patches.size());
  w.value("links", t.num_links());
  w.value("unknowns", static_cast<long long>(t.size()));
  w.begin_object("form_factors")
      .value("pairs_facing", sys.form_factors.stats.pairs_facing)
      .value("pairs_visible", sys.form_factors.stats.pairs_visible)
      .value("rays", sys.form_factors.stats.rays)
      .value("nnz", static_cast<long long>(sys.form_factors.f.nnz()))
      .value("bytes", sys.form_factors.bytes())
      .value("seconds", sys.form_factors.stats.seconds)
      .end_object();
  const auto& st = sys.specular.stats;
  w.begin_object("specular_transfer")
      .value("link_pairs", st.pairs)
      .value("entries", static_cast<long long>(sys.specular.entries()))
      .value("rays", st.rays)
      .value("pairs_unseen", st.pairs_unseen)
      .value("dropped_hits", st.dropped_hits)
      .value("balance_residual", st.balance_mismatch)
      .value("escaped_fraction", st.escaped_fraction)
      .value("bytes", sys.specular.bytes())
      .value("seconds", st.seconds)
      .end_object();
  w.begin_object("operator")
      .value("on_the_fly", t.on_the_fly())
      .value("nnz_diffuse", static_cast<long long>(t.nnz_diffuse()))
      .value("nnz_specular", static_cast<long long>(t.nnz_specular()))
      .value("bytes", t.bytes())
      .value("max_albedo", t.max_albedo())
      .end_object();
  write_lobe_checks(w, sys.lobes);
}

void write_solve(JsonWriter& w, const SolveResult& r) {
  w.value("solver", solve_method_name(r.method));
  w.value("status", solve_status_name(r.status));
  w.value("iterations", r.iterations);
  w.value("residual", r.residual);
  w.begin_array("sweep_residuals");
  for (double x : r.sweep_residual) w.element(x);
  w.end_array();
}

void write_patch_csv(const std::string& path, const RadiositySystem& sys, const Field& u) {
  std::ostringstream s;
  s.precision(9);
  s << "patch,object,area,cx,cy,cz,nx,ny,nz,r,g,b\n";
  for (size_t p = 0; p < sys.patches.size(); ++p) {
    const Patch& q = sys.patches[p];
    s << p << ',' << sys.scene.objects[q.object].name << ',' << q.area << ',' << q.centroid.x()
      << ',' << q.centroid.y() << ',' << q.centroid.z() << ',' << q.normal.x() << ','
      << q.normal.y() << ',' << q.normal.z() << ',' << u(p, 0) << ',' << u(p, 1) << ','
      << u(p, 2) << '\n';
  }
  write_file_atomic(path, s.str());
}

void GatherFlags::add(CLI::App& app) {
  app.add_option("--diffuse", diffuse, "Diffuse shading in the image")
      ->check(CLI::IsMember({"smooth", "flat"}))
      ->capture_default_str();
  app.add_option("--pixel-grid", pixel_grid, "Sub-pixel rays per side")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  app.add_option("--lobe-samples", lobe_samples, "Gather samples of a glossy lobe")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  app.add_option("--light-samples", light_samples,
                 "Gather points on the lights per glossy hit, weighted against the lobe samples "
                 "(0: lobe samples alone)")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
}

GatherOptions GatherFlags::options(bool classic) const {
  GatherOptions go;
  go.diffuse = diffuse == "flat" ? DiffuseMode::kFlat : DiffuseMode::kSmooth;
  go.pixel_grid = pixel_grid;
  go.lobe_samples = lobe_samples;
  go.light_samples = light_samples;
  go.specular = !classic;
  return go;
}

void SystemFlags::add(CLI::App& app) {
  app.add_option("--patch-size", patch_size, "Override every patch_size of the scene")
      ->check(CLI::PositiveNumber);
  app.add_option("--specular-samples", specular_samples,
                 "Point pairs per link pair for the specular transfer")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  app.add_flag("--classic", classic,
               "Classic radiosity: every material reduced to its diffuse part");
  app.add_flag("--centre-point", centre_point,
               "Specular transfer by the seed's centre-point rho (for comparison only)");
  app.add_option("--max-memory", max_memory_gib,
                 "Refuse scenes estimated to need more memory than this, in GiB (default: 80% of RAM)")
      ->check(CLI::PositiveNumber);
  app.add_flag("--specular-on-the-fly", on_the_fly,
               "Recompute the specular transfer at every sweep instead of storing it");
  app.add_flag("--allow-unsafe-albedo", unsafe_albedo,
               "UNSAFE: accept materials whose albedo may exceed 1 (to test divergence detection)");
}

SceneOptions SystemFlags::scene_options() const {
  SceneOptions o;
  o.allow_unsafe_albedo = unsafe_albedo;
  return o;
}

PipelineOptions SystemFlags::pipeline() const {
  PipelineOptions o;
  o.patch_size = patch_size;
  o.specular.samples = specular_samples;
  o.specular_transport = !classic;
  if (centre_point) o.specular.estimator = SpecularEstimator::kCentrePoint;
  o.specular_on_the_fly = on_the_fly;
  o.max_memory_bytes = max_memory_gib * (1ull << 30);
  return o;
}

}  // namespace polyrad::cli
