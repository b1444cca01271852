// polyrad render --method pathtrace: the path-traced reference.
#include <chrono>
#include <cmath>
#include <cstdio>

#include "polyrad/util/files.h"
#include "polyrad/io/image_io.h"
#include "polyrad/geometry/mesher.h"
#include "polyrad/render/path_tracer.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/scene.h"
#include "render_flags.h"

namespace polyrad::cli {

int render_pathtrace(const RenderFlags& f) {
  check_image_path(f.output);
  if (!f.report.empty()) check_output_path(f.report, "report");
  // The patch table holds radiosities; a path tracer has none to give.
  if (!f.patches_csv.empty())
    throw InputError("--patches needs a radiosity solution; it is not available with "
                     "--method pathtrace");
  auto t0 = std::chrono::steady_clock::now();

  Scene scene = load_scene(f.scene, f.system.scene_options());
  // Same geometry as the radiosity run with the same flags: --patch-size re-meshes (which
  // matters only for quads that bend), --classic keeps only the diffuse part of each material.
  override_patch_size(scene, f.system.patch_size);
  if (f.system.classic)
    for (auto& m : scene.materials) m = Material::lambert(m.name, m.diffuse);
  double load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  auto tm = std::chrono::steady_clock::now();
  PatchSet patches = mesh_scene(scene);
  RayCaster caster(patches);
  double setup_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tm).count();

  PathTracer tracer(patches, scene.materials, caster);
  PathTraceOptions o;
  o.spp = f.spp;
  o.seed = f.seed;
  o.standard_error = true;
  PathTraceResult r = tracer.render(scene.camera, o);
  if (!r.image.all_finite()) throw NumericalError("the path-traced image has non-finite pixels");

  // Mean relative standard error over pixels with signal: the noise left in the reference.
  double rel_se = 0.0;
  long long lit = 0;
  if (!r.standard_error.rgb.empty()) {
    for (int y = 0; y < r.image.height; ++y)
      for (int x = 0; x < r.image.width; ++x) {
        double l = luminance(r.image.at(x, y));
        if (l <= 0.0) continue;
        rel_se += luminance(r.standard_error.at(x, y)) / l;
        ++lit;
      }
    if (lit > 0) rel_se /= static_cast<double>(lit);
  }

  write_image(r.image, f.output, ImageWriteOptions{f.exposure});
  if (!f.report.empty()) {
    JsonWriter w;
    w.begin_object();
    w.value("command", "render").value("method", f.method);
    w.value("scene", scene.file);
    w.value("width", r.image.width).value("height", r.image.height);
    w.value("patches", patches.size());
    w.value("spp", f.spp);
    w.value("seed", static_cast<long long>(f.seed));
    w.value("max_depth", o.max_depth);
    w.value("paths", r.stats.paths);
    w.value("rays", r.stats.rays);
    w.value("rays_per_second", r.seconds > 0.0 ? static_cast<double>(r.stats.rays) / r.seconds : 0.0);
    w.value("paths_truncated", r.stats.truncated);
    w.value("mean_relative_standard_error", lit > 0 ? rel_se : std::nan(""));
    write_stage_times(w, {{"load", load_seconds}, {"mesh_and_ray_caster", setup_seconds},
                          {"path_tracing", r.seconds}});
    w.value("peak_memory_bytes", peak_memory_bytes());
    w.value("machine", machine_description());
    w.end_object();
    write_file_atomic(f.report, w.str());
  }
  std::fprintf(stderr,
               "polyrad: %zu patches, %d spp, %lld rays in %.2f s (%.1f Mrays/s), mean relative "
               "standard error %.2e; wrote %s\n",
               patches.size(), f.spp, r.stats.rays, r.seconds,
               r.seconds > 0.0 ? 1e-6 * static_cast<double>(r.stats.rays) / r.seconds : 0.0,
               rel_se, f.output.c_str());
  return kExitOk;
}

}  // namespace polyrad::cli
