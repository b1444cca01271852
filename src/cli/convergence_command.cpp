// polyrad convergence SCENE... : how many products with T each method needs on a scene, and the
// error each leaves at a fixed budget (issue: stability where methods fail).
#include <chrono>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "cli_common.h"
#include "polyrad/util/files.h"
#include "polyrad/util/progress.h"

namespace polyrad::cli {

namespace {

struct ConvergenceFlags {
  std::vector<std::string> scenes;
  std::string output;
  double tolerance = 1e-3;
  int budget = 50;
  int max_products = 200000;
  SystemFlags system;
};

int run_convergence(const ConvergenceFlags& f) {
  if (!f.output.empty()) check_output_path(f.output, "table");
  std::ostringstream csv;
  csv.precision(9);
  csv << "scene,max_albedo,method,products_to_tolerance,seconds_to_tolerance,error_at_budget,budget,tolerance\n";
  std::fprintf(stderr, "%-28s %7s %-13s %10s %12s\n", "scene", "a_max", "method", "products", "err@budget");
  for (const auto& path : f.scenes) {
    auto sys = build_system(load_scene(path, f.system.scene_options()), f.system.pipeline());
    const TransportOperator& t = sys->transport;
    const Field e = t.emission();
    if (!(t.max_albedo() < 1.0))
      throw NumericalError(path + ": no finite solution to converge to; " + t.divergence_hint());
    // The reference: GMRES far past the tolerance, checked by its residual.
    SolveOptions ref;
    ref.method = SolveMethod::kGmres;
    ref.tolerance = 1e-12;
    ref.max_iterations = f.max_products;
    SolveResult reference = solve(t, e, ref);
    if (!reference.ok()) throw NumericalError(path + ": the reference solve failed: " + reference.message);
    std::string name = std::filesystem::path(path).stem().string();
    for (SolveMethod method : {SolveMethod::kJacobi, SolveMethod::kGaussSeidel,
                               SolveMethod::kChebyshev, SolveMethod::kGmres}) {
      ConvergenceMeasure m =
          measure_convergence(t, e, reference.u, method, f.tolerance, f.budget, f.max_products);
      csv << name << ',' << t.max_albedo() << ',' << solve_method_name(method) << ',' << m.products
          << ',' << m.seconds << ',' << m.error_at_budget << ',' << f.budget << ',' << f.tolerance << '\n';
      std::fprintf(stderr, "%-28s %7.4f %-13s %10lld %12.3e\n", name.c_str(), t.max_albedo(),
                   solve_method_name(method), m.products, m.error_at_budget);
    }
  }
  if (!f.output.empty()) write_file_atomic(f.output, csv.str());
  else std::fputs(csv.str().c_str(), stdout);
  return kExitOk;
}

}  // namespace

void add_convergence_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<ConvergenceFlags>();
  CLI::App* cmd = app.add_subcommand(
      "convergence", "Products with T that each solver needs on a scene, and its error at a budget");
  cmd->add_option("scenes", f->scenes, "Scene files")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", f->output, "CSV table (default: standard output)");
  cmd->add_option("--tolerance", f->tolerance, "Relative error to reach (flux-weighted, against a tight GMRES solve)")
      ->check(CLI::Range(1e-12, 0.5))
      ->capture_default_str();
  cmd->add_option("--budget", f->budget, "Products at which to measure every method's error")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd->add_option("--max-products", f->max_products, "Give up after this many products")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str();
  f->system.add(*cmd);
  cmd->callback([f, &exit_code] { exit_code = run_convergence(*f); });
}

}  // namespace polyrad::cli
