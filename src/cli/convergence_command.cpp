// polyrad convergence SCENE... : products against error for each iterative method
// (app/convergence.h), then scripts/convergence_chart.py.
#include <cstdio>

#include "flags.h"
#include "polyrad/app/convergence.h"
#include "polyrad/util/files.h"

namespace polyrad::cli {

namespace {

struct ConvergenceFlags {
  std::vector<std::string> scenes;
  std::string output;
  ConvergenceOptions options;
  SystemFlags system;
};

int run_convergence(ConvergenceFlags& f) {
  if (!f.output.empty()) check_output_path(f.output, "table");
  ConvergenceOptions& o = f.options;
  o.scene = f.system.scene();
  o.overrides = f.system.overrides();
  o.system = f.system.system();
  const std::string csv = convergence_csv(convergence(f.scenes, o), o);
  if (!f.output.empty())
    write_file_atomic(f.output, csv);
  else
    std::fputs(csv.c_str(), stdout);
  return kExitOk;
}

}  // namespace

void add_convergence_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<ConvergenceFlags>();
  ConvergenceOptions& o = f->options;
  CLI::App* cmd = app.add_subcommand(
      "convergence",
      "Products with T that each solver needs on a scene, and its error at a budget");
  cmd->add_option("scenes", f->scenes, "Scene files")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", f->output, "CSV table (default: standard output)");
  cmd->add_option("--tolerance", o.tolerance,
                  "Relative error to reach (flux-weighted, against a tight GMRES solve)")
      ->check(CLI::Range(1e-12, 0.5))
      ->capture_default_str();
  cmd->add_option("--budget", o.budget, "Products at which to measure every method's error")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd->add_option("--max-products", o.max_products, "Give up after this many products")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str();
  f->system.add(*cmd);
  cmd->callback([f, &exit_code] { exit_code = run_convergence(*f); });
}

}  // namespace polyrad::cli
