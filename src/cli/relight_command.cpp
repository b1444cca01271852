// polyrad relight FILE.prt -o IMAGE [--emission NAME=R,G,B]... [--scene SCENE]
#include <cstdio>

#include "flags.h"
#include "polyrad/app/relight.h"
#include "polyrad/io/image_io.h"

namespace polyrad::cli {

namespace {

struct RelightFlags {
  std::string prt, output, report;
  std::vector<std::string> emission;
  RelightOptions options;
  double exposure = 1.0;
};

int run_relight(RelightFlags& f) {
  check_image_path(f.output);
  if (!f.report.empty()) check_output_path(f.report, "report");
  f.options.emission = parse_emissions(f.emission);
  const RelightResult r = relight(f.prt, f.options);
  print_warnings(r.report);
  write_image(r.image, f.output, ImageWriteOptions{f.exposure});
  write_report(f.report, r.report);
  std::fprintf(
      stderr,
      "polyrad: relit with one product of %lld non-zeros in %.3f ms (median of %d); wrote %s\n",
      static_cast<long long>(r.report.series->report.nnz), 1e3 * r.report.relight->product.median,
      r.report.relight->product.repeats, f.output.c_str());
  return kExitOk;
}

}  // namespace

void add_relight_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<RelightFlags>();
  CLI::App* cmd =
      app.add_subcommand("relight", "Relight with a precomputed operator: one sparse product");
  cmd->add_option("operator", f->prt, "Operator file (.prt)")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", f->output, "Image: .exr or .pfm (linear), .png (tonemapped)")
      ->required();
  cmd->add_option("--emission", f->emission,
                  "NAME=R,G,B: new emission of a light (repeatable; 0,0,0 turns it off)");
  cmd->add_option("--scene", f->options.scene, "The scene, if it moved since the precompute");
  cmd->add_option("--repeats", f->options.repeats,
                  "Time the product over this many repeats (median)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--exposure", f->exposure, "Exposure of the .png tonemap")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--report", f->report, "Write a JSON report here");
  cmd->callback([f, &exit_code] { exit_code = run_relight(*f); });
}

}  // namespace polyrad::cli
