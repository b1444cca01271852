// polyrad sweep SCENE --out DIR: speed against accuracy (app/sweep.h), then scripts/charts.py.
#include <cstdio>

#include "flags.h"
#include "polyrad/app/sweep.h"
#include "polyrad/solve/series_operator.h"

namespace polyrad::cli {

namespace {

struct SweepFlags {
  std::string scene;
  SweepOptions options;
  GatherFlags gather;
  bool quick = false;
};

int run_sweep(SweepFlags& f) {
  const SweepResult r = sweep(f.scene, f.options);
  std::fprintf(stderr, "polyrad sweep: %lld points in %.1f s; wrote %s/sweep.csv, %s/machine.txt\n",
               r.points, r.seconds, f.options.out.c_str(), f.options.out.c_str());
  return kExitOk;
}

}  // namespace

void add_sweep_command(CLI::App& app, int& exit_code) {
  auto f = std::make_shared<SweepFlags>();
  SweepOptions& o = f->options;
  CLI::App* cmd = app.add_subcommand("sweep",
                                     "Speed against accuracy: time and error of the series, the "
                                     "iterative solver and the path tracer");
  cmd->add_option("scene", f->scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", o.out, "Output directory (sweep.csv, machine.txt, the cached reference)")
      ->required();
  auto* patch_sizes = cmd->add_option("--patch-sizes", o.patch_sizes, "Patch sizes (scene units)")
                          ->delimiter(',')
                          ->check(CLI::PositiveNumber)
                          ->capture_default_str();
  auto* tolerances =
      cmd->add_option("--link-tolerances", o.link_tolerances,
                      "Hierarchical meshes on the first patch size's patches, one per link "
                      "tolerance (default none)")
          ->delimiter(',')
          ->check(CLI::Range(1e-9, 1e9));
  cmd->add_option("--orders", o.orders, "Series orders K")
      ->delimiter(',')
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  auto* drops = cmd->add_option("--drops", o.drops,
                                "Series drop tolerances (share of a column's energy dropped)")
                    ->delimiter(',')
                    ->check(CLI::Range(0.0, 0.999999))
                    ->capture_default_str();
  cmd->add_option("--precisions", o.precisions, "Series value precisions")
      ->delimiter(',')
      ->check(CLI::IsMember(enum_names<ValuePrecision>()))
      ->capture_default_str();
  cmd->add_option("--sweeps", o.sweeps, "Jacobi and Gauss-Seidel sweep counts")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
  cmd->add_option("--spp", o.spp, "Path tracer samples per pixel")
      ->delimiter(',')
      ->check(CLI::Range(1, 1 << 24))
      ->capture_default_str();
  auto* reference_spp = cmd->add_option("--reference-spp", o.reference_spp,
                                        "Samples per pixel of the path-traced reference")
                            ->check(CLI::Range(1, 1 << 24))
                            ->capture_default_str();
  cmd->add_option("--max-depth", o.max_depth,
                  "Path tracer: most segments a path may have, the reference's and the points' "
                  "(a warning says when the reference had one path in 10,000 or more cut)")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd->add_option("--repeats", o.repeats, "Timed repeats of each product and solve (median)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  f->gather.add(*cmd);
  cmd->add_flag(
      "--quick", f->quick,
      "The demo's preset, about three minutes on 2 cores: patch sizes 100,50,35, the gather's link "
      "tolerance, drops 0,1e-3, reference at 512 spp (flags given explicitly still win)");
  cmd->callback([f, patch_sizes, tolerances, drops, reference_spp, &exit_code] {
    f->options.gather = f->gather.options();
    if (f->quick)
      apply_quick_preset(f->options, {patch_sizes->count() > 0, tolerances->count() > 0,
                                      drops->count() > 0, reference_spp->count() > 0});
    exit_code = run_sweep(*f);
  });
}

}  // namespace polyrad::cli
