// polyrad render SCENE -o IMAGE [--method iterative|series|pathtrace] ...
#include <cstdio>

#include "flags.h"
#include "polyrad/app/render.h"
#include "polyrad/io/image_io.h"
#include "polyrad/io/patch_table.h"
#include "polyrad/util/files.h"

namespace polyrad::cli {

namespace {

struct RenderFlags {
  std::string scene, output, report, patches_csv;
  RenderOptions options;
  double tolerance = 1e-4;  // the solver's residual, or the series' error
  double exposure = 1.0;
  GatherFlags gather;
  SystemFlags system;
};

void print_summary(const RenderResult& r, const std::string& output) {
  const Report& rep = r.report;
  if (rep.solve)
    std::fprintf(
        stderr, "polyrad: %lld patches, %lld unknowns, %s in %d sweeps (residual %.2e); wrote %s\n",
        rep.system->patches, rep.system->unknowns, enum_name(rep.solve->status),
        rep.solve->iterations, rep.solve->residual, output.c_str());
  else if (rep.series)
    std::fprintf(stderr, "polyrad: %lld patches, series of order %d, product %.3f ms; wrote %s\n",
                 rep.system->patches, rep.series->report.order,
                 1e3 * stage_seconds(rep.seconds, "product"), output.c_str());
  else if (rep.pathtrace)
    std::fprintf(stderr,
                 "polyrad: %zu patches, %d spp, %lld rays in %.2f s (%.1f Mrays/s), mean relative "
                 "standard error %.2e; wrote %s\n",
                 r.world->patches().size(), rep.pathtrace->spp, rep.pathtrace->stats.rays,
                 rep.pathtrace->seconds,
                 rep.pathtrace->seconds > 0.0
                     ? 1e-6 * rep.pathtrace->stats.rays / rep.pathtrace->seconds
                     : 0.0,
                 rep.pathtrace->mean_relative_standard_error, output.c_str());
}

int run_render(RenderFlags& f) {
  check_image_path(f.output);
  if (!f.report.empty()) check_output_path(f.report, "report");
  if (!f.patches_csv.empty()) {
    if (f.options.method != RenderMethod::kIterative)
      throw InputError("--patches needs --method iterative (only it solves for patch radiosities)");
    check_output_path(f.patches_csv, "patch table");
  }
  RenderOptions& o = f.options;
  o.scene = f.system.scene();
  o.overrides = f.system.overrides();
  o.system = f.system.system();
  o.solve.tolerance = o.series.tolerance = f.tolerance;
  o.gather = f.gather.options();
  o.image_codec = image_needs_codec(f.output);
  const RenderResult r = render(f.scene, o);
  print_warnings(r.report);
  write_image(r.image, f.output, ImageWriteOptions{f.exposure});
  if (!f.patches_csv.empty()) write_file_atomic(f.patches_csv, patch_table_csv(*r.system, r.u));
  write_report(f.report, r.report);
  print_summary(r, f.output);
  return kExitOk;
}

}  // namespace

void add_render_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<RenderFlags>();
  RenderOptions& o = f->options;
  CLI::App* cmd = app.add_subcommand("render", "Render a scene to a linear-radiance image");
  cmd->add_option("scene", f->scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", f->output, "Image: .exr or .pfm (linear), .png (tonemapped)")
      ->required();
  add_enum_option(*cmd, "--method", o.method, "Solution method");
  add_enum_option(*cmd, "--solver", o.solve.method, "Iterative solver");
  cmd->add_option("--tolerance", f->tolerance,
                  "Relative residual to stop at (series: relative error)")
      ->check(CLI::Range(1e-14, 1.0))
      ->capture_default_str();
  cmd->add_option("--max-iterations", o.solve.max_iterations, "Sweep limit")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str();
  cmd->add_option("--order", o.series.order, "Series: order K (default: chosen from --tolerance)")
      ->check(CLI::Range(0, 100000));
  add_enum_option(*cmd, "--acceleration", o.series.acceleration,
                  "Series: plain power series, or the Chebyshev polynomial (diffuse scenes)");
  add_enum_option(*cmd, "--reorder", o.series.reorder,
                  "Series: number the unknowns as built, or by reverse Cuthill-McKee for the "
                  "locality of the precompute's products (the same image)");
  cmd->add_option("--spp", o.pathtrace.spp, "Path tracer: samples per pixel")
      ->check(CLI::Range(1, 1 << 24))
      ->capture_default_str();
  cmd->add_option("--seed", o.pathtrace.seed, "Path tracer: random seed")->capture_default_str();
  cmd->add_option("--max-depth", o.pathtrace.max_depth,
                  "Path tracer: most segments a path may have; a longer path is cut, and the "
                  "light it would still gather is lost (a warning says when that happened to "
                  "one path in 10,000 or more)")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd->add_option("--report", f->report, "Write a JSON report here");
  cmd->add_option("--patches", f->patches_csv, "Write one CSV row per patch here (iterative)");
  f->gather.add(*cmd);
  cmd->add_option("--exposure", f->exposure, "Exposure of the .png tonemap")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  f->system.add(*cmd);
  cmd->callback([f, &exit_code] { exit_code = run_render(*f); });
}

}  // namespace polyrad::cli
