// polyrad precompute SCENE -o FILE.prt [--order K | --tolerance T] ...
#include <cstdio>

#include "flags.h"
#include "polyrad/app/precompute.h"
#include "polyrad/io/prt_file.h"

namespace polyrad::cli {

namespace {

struct PrecomputeFlags {
  std::string scene, output, report;
  PrecomputeOptions options;
  GatherFlags gather;  // view rows: the gather folded in; solution rows: the one relight builds
  SystemFlags system;
};

int run_precompute(PrecomputeFlags& f) {
  check_output_path(f.output, "operator file");
  if (!f.report.empty()) check_output_path(f.report, "report");
  PrecomputeOptions& o = f.options;
  o.scene = f.system.scene();
  o.overrides = f.system.overrides();
  o.system = f.system.system();
  o.series.gather = f.gather.options();
  PrecomputeResult r = precompute(f.scene, o);
  print_warnings(r.report);
  const double write_seconds = time_seconds([&] { write_prt(r.op, f.output); });
  r.report.seconds.push_back({"write", write_seconds});
  write_report(f.report, r.report);
  const SeriesOperator& q = r.op;
  const bool cheb = q.report.acceleration == SeriesAcceleration::kChebyshev;
  std::fprintf(stderr,
               "polyrad: %s operator, %s of order %d (%s %.2e), %lld x %lld, %lld non-zeros, %.1f "
               "MB; wrote %s\n",
               enum_name(q.output), cheb ? "Chebyshev polynomial" : "power series", q.report.order,
               cheb ? "residual bound" : "a-posteriori estimate",
               cheb ? q.report.residual_bound : q.report.aposteriori_estimate,
               static_cast<long long>(q.rows()), static_cast<long long>(q.cols()),
               static_cast<long long>(q.nnz()), q.bytes() / 1e6, f.output.c_str());
  return kExitOk;
}

}  // namespace

void add_precompute_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<PrecomputeFlags>();
  SeriesOptions& s = f->options.series;
  CLI::App* cmd = app.add_subcommand(
      "precompute", "Precompute the truncated power series of the transport operator");
  cmd->add_option("scene", f->scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  // `-o FILE` names the file and `--output view|solution` the rows, as the precompute has always
  // been documented; `--file` and `--rows` are longer spellings of the same two.
  cmd->add_option("-o,--file", f->output, "Operator file to write (.prt)")->required();
  auto* order =
      cmd->add_option("--order", s.order, "Order K of the series")->check(CLI::Range(0, 100000));
  cmd->add_option("--tolerance", s.tolerance, "Choose K for this relative error (flux-weighted)")
      ->check(CLI::Range(1e-14, 1.0))
      ->excludes(order)
      ->capture_default_str();
  cmd->add_option("--drop", s.drop,
                  "Drop each column's smallest entries, up to this share of its energy")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  add_enum_option(*cmd, "--precision", s.precision, "Stored value precision");
  add_enum_option(*cmd, "--output,--rows,--output-kind", s.output,
                  "Rows: the camera's pixels, or every unknown");
  add_enum_option(*cmd, "--basis", s.basis,
                  "Columns: one per emitting patch, or one per emitting object");
  add_enum_option(*cmd, "--acceleration", s.acceleration,
                  "Plain power series, or the Chebyshev polynomial (fewer terms near albedo 1; "
                  "needs a real spectrum, as diffuse scenes have)");
  add_enum_option(
      *cmd, "--reorder", s.reorder,
      "Number the unknowns as built, or by reverse Cuthill-McKee for the locality of "
      "the precompute's products (the same operator; a second copy of T while it runs)");
  cmd->add_option("--report", f->report, "Write a JSON report here");
  f->gather.add(*cmd);
  f->system.add(*cmd);
  cmd->callback([f, &exit_code] { exit_code = run_precompute(*f); });
}

}  // namespace polyrad::cli
