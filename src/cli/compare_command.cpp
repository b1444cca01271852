// polyrad compare A B [--scene SCENE] [--report R.json] [--heatmap H.png] [--side-by-side S.png]
#include <chrono>
#include <cstdio>
#include <memory>

#include "cli_common.h"
#include "polyrad/util/files.h"
#include "polyrad/io/image_io.h"
#include "polyrad/render/image_compare.h"
#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/scene.h"

namespace polyrad::cli {

namespace {

struct CompareFlags {
  std::string a, b, scene, report, heatmap, side_by_side;
  double error_scale = 0.25;
  double epsilon = 0.01;
  double exposure = 1.0;
  int worst = 10;
};

void write_rgb(JsonWriter& w, std::string_view key, const Rgb& c) {
  w.begin_array(key);
  for (int k = 0; k < 3; ++k) w.element(c[k]);
  w.end_array();
}

int run_compare(const CompareFlags& f) {
  if (!f.report.empty()) check_output_path(f.report, "report");
  if (!f.heatmap.empty()) check_image_path(f.heatmap);
  if (!f.side_by_side.empty()) check_image_path(f.side_by_side);
  auto t0 = std::chrono::steady_clock::now();
  Image a = read_image(f.a), b = read_image(f.b);

  RegionMap regions;
  bool have_regions = !f.scene.empty();
  if (have_regions) {
    Scene scene = load_scene(f.scene);
    PatchSet patches = mesh_scene(scene);
    RayCaster caster(patches);
    regions = object_regions(scene, patches, caster);
  }
  CompareOptions o;
  o.epsilon_fraction = f.epsilon;
  o.worst_pixels = f.worst;
  ImageComparison c;
  try {
    c = compare_images(a, b, o, have_regions ? &regions : nullptr);
  } catch (const InputError& e) {
    throw InputError(f.a + " vs " + f.b + ": " + e.message());
  }
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  if (!f.heatmap.empty() || !f.side_by_side.empty()) {
    Image err = error_picture(a, b, f.error_scale, f.epsilon);
    if (!f.heatmap.empty()) write_image(err, f.heatmap);
    if (!f.side_by_side.empty()) write_image(side_by_side(a, b, err, f.exposure), f.side_by_side);
  }
  if (!f.report.empty()) {
    JsonWriter w;
    w.begin_object();
    w.value("command", "compare");
    w.value("a", f.a).value("b", f.b);
    if (have_regions) w.value("scene", f.scene);
    w.value("width", c.width).value("height", c.height);
    w.value("epsilon_fraction", f.epsilon);
    write_rgb(w, "epsilon", c.epsilon);
    w.value("relative_rmse", c.relative_rmse);
    w.value("relative_l1", c.relative_l1);
    w.value("mean_relative_error", c.mean_relative_error);
    w.value("normalized_rmse", c.normalized_rmse);
    write_rgb(w, "mean_a", c.mean_a);
    write_rgb(w, "mean_b", c.mean_b);
    if (have_regions) {
      w.value("worst_region_difference", c.worst_region_difference);
      w.value("pixels_without_region", c.pixels_without_region);
      w.begin_array("regions");
      for (const auto& r : c.regions) {
        w.begin_object();
        w.value("name", r.name).value("pixels", r.pixels);
        write_rgb(w, "mean_a", r.mean_a);
        write_rgb(w, "mean_b", r.mean_b);
        write_rgb(w, "relative_difference", r.relative_difference);
        w.value("luminance_difference", r.luminance_difference);
        w.end_object();
      }
      w.end_array();
    }
    w.value("error_scale", f.error_scale);
    w.begin_array("worst_pixels");
    for (const auto& p : c.worst) {
      w.begin_object();
      w.value("x", p.x).value("y", p.y);
      write_rgb(w, "a", p.a);
      write_rgb(w, "b", p.b);
      w.value("error", p.error);
      w.end_object();
    }
    w.end_array();
    w.begin_object("seconds").value("compare", seconds).end_object();
    w.end_object();
    write_file_atomic(f.report, w.str());
  }

  std::printf("%s vs %s (%dx%d)\n", f.a.c_str(), f.b.c_str(), c.width, c.height);
  std::printf("relative RMSE %.4f, mean relative error %.4f, normalized RMSE %.4f\n",
              c.relative_rmse, c.mean_relative_error, c.normalized_rmse);
  std::printf("mean radiance A (%.4g, %.4g, %.4g), B (%.4g, %.4g, %.4g)\n", c.mean_a[0],
              c.mean_a[1], c.mean_a[2], c.mean_b[0], c.mean_b[1], c.mean_b[2]);
  if (have_regions) {
    std::printf("%-20s %8s %12s %12s %10s\n", "region", "pixels", "lum A", "lum B", "A/B - 1");
    for (const auto& r : c.regions)
      std::printf("%-20s %8lld %12.5g %12.5g %+9.2f%%\n", r.name.c_str(), r.pixels,
                  luminance(r.mean_a), luminance(r.mean_b), 100.0 * r.luminance_difference);
  }
  if (!c.worst.empty())
    std::printf("worst pixel (%d, %d): relative luminance error %+.3f\n", c.worst[0].x,
                c.worst[0].y, c.worst[0].error);
  return kExitOk;
}

}  // namespace

void add_compare_command(CLI::App& app, int& exit_code) {
  auto flags = std::make_shared<CompareFlags>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "Compare image A with a reference B: relative errors, region means, pictures");
  cmd->add_option("a", flags->a, "Image A (.exr, .pfm or .png)")->required()->check(CLI::ExistingFile);
  cmd->add_option("b", flags->b, "Reference image B")->required()->check(CLI::ExistingFile);
  cmd->add_option("--scene", flags->scene, "Scene whose camera made both: per-object regions")
      ->check(CLI::ExistingFile);
  cmd->add_option("--report", flags->report, "Write a JSON report here");
  cmd->add_option("--heatmap", flags->heatmap, "Write the false-colour error picture here");
  cmd->add_option("--side-by-side", flags->side_by_side, "Write A | B | error here");
  cmd->add_option("--error-scale", flags->error_scale,
                  "Relative error shown at full colour in the error picture")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--epsilon", flags->epsilon,
                  "Floor of relative errors, as a fraction of B's mean")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--exposure", flags->exposure, "Exposure of A and B in the side-by-side picture")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--worst", flags->worst, "How many of the worst pixels to report")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->callback([flags, &exit_code] { exit_code = run_compare(*flags); });
}

}  // namespace polyrad::cli
