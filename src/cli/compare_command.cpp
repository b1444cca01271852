// polyrad compare A B [--scene SCENE] [--report R.json] [--heatmap H.png] [--side-by-side S.png]
#include <cstdio>

#include "flags.h"
#include "polyrad/app/compare.h"
#include "polyrad/io/image_io.h"

namespace polyrad::cli {

namespace {

struct CompareFlags {
  std::string a, b, report, heatmap, side_by_side;
  CompareFilesOptions options;
};

void print_comparison(const std::string& a, const std::string& b, const ImageComparison& c) {
  std::printf("%s vs %s (%dx%d)\n", a.c_str(), b.c_str(), c.width, c.height);
  std::printf("relative RMSE %.4f, mean relative error %.4f, normalized RMSE %.4f\n",
              c.relative_rmse, c.mean_relative_error, c.normalized_rmse);
  std::printf("mean radiance A (%.4g, %.4g, %.4g), B (%.4g, %.4g, %.4g)\n", c.mean_a[0],
              c.mean_a[1], c.mean_a[2], c.mean_b[0], c.mean_b[1], c.mean_b[2]);
  if (!c.regions.empty()) {
    std::printf("%-20s %8s %12s %12s %10s\n", "region", "pixels", "lum A", "lum B", "A/B - 1");
    for (const auto& r : c.regions)
      std::printf("%-20s %8lld %12.5g %12.5g %+9.2f%%\n", r.name.c_str(), r.pixels,
                  luminance(r.mean_a), luminance(r.mean_b), 100.0 * r.luminance_difference);
  }
  if (!c.worst.empty())
    std::printf("worst pixel (%d, %d): relative luminance error %+.3f\n", c.worst[0].x,
                c.worst[0].y, c.worst[0].error);
}

int run_compare(CompareFlags& f) {
  if (!f.report.empty()) check_output_path(f.report, "report");
  if (!f.heatmap.empty()) check_image_path(f.heatmap);
  if (!f.side_by_side.empty()) check_image_path(f.side_by_side);
  f.options.pictures = !f.heatmap.empty() || !f.side_by_side.empty();
  CompareResult r = compare_files(f.a, f.b, f.options);
  if (!f.heatmap.empty()) write_image(r.error_picture, f.heatmap);
  if (!f.side_by_side.empty()) write_image(r.side_by_side, f.side_by_side);
  r.report.inputs = {{"a", f.a}, {"b", f.b}};
  write_report(f.report, r.report);
  print_comparison(f.a, f.b, r.comparison);
  return kExitOk;
}

}  // namespace

void add_compare_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<CompareFlags>();
  CompareFilesOptions& o = f->options;
  CLI::App* cmd = app.add_subcommand(
      "compare", "Compare image A with a reference B: relative errors, region means, pictures");
  cmd->add_option("a", f->a, "Image A (.exr, .pfm or .png)")->required()->check(CLI::ExistingFile);
  cmd->add_option("b", f->b, "Reference image B")->required()->check(CLI::ExistingFile);
  cmd->add_option("--scene", o.scene, "Scene whose camera made both: per-object regions")
      ->check(CLI::ExistingFile);
  cmd->add_option("--report", f->report, "Write a JSON report here");
  cmd->add_option("--heatmap", f->heatmap, "Write the false-colour error picture here");
  cmd->add_option("--side-by-side", f->side_by_side, "Write A | B | error here");
  cmd->add_option("--error-scale", o.error_scale,
                  "Relative error shown at full colour in the error picture")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--epsilon", o.compare.epsilon_fraction,
                  "Floor of relative errors, as a fraction of B's mean")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--exposure", o.exposure, "Exposure of A and B in the side-by-side picture")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--worst", o.compare.worst_pixels, "How many of the worst pixels to report")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->callback([f, &exit_code] { exit_code = run_compare(*f); });
}

}  // namespace polyrad::cli
