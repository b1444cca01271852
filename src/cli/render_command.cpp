// polyrad render SCENE -o IMAGE [--method iterative] ...
#include <chrono>
#include <cstdio>

#include "render_flags.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/util/files.h"
#include "polyrad/io/image_io.h"
#include "polyrad/scene/scene.h"

namespace polyrad::cli {

int render_iterative(const RenderFlags& f) {
  check_image_path(f.output);
  if (!f.report.empty()) check_output_path(f.report, "report");
  if (!f.patches_csv.empty()) check_output_path(f.patches_csv, "patch table");
  auto t0 = std::chrono::steady_clock::now();

  Scene scene = load_scene(f.scene, f.system.scene_options());
  double load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  auto sys = build_system(std::move(scene), f.system.pipeline());
  print_warnings(*sys);

  SolveOptions so;
  so.method = f.solver == "jacobi"      ? SolveMethod::kJacobi
              : f.solver == "gmres"     ? SolveMethod::kGmres
              : f.solver == "chebyshev" ? SolveMethod::kChebyshev
                                        : SolveMethod::kGaussSeidel;
  so.tolerance = f.tolerance;
  so.max_iterations = f.max_iterations;
  SolveResult result = solve(sys->transport, sys->transport.emission(), so);
  if (result.status == SolveStatus::kDiverged || !result.u.allFinite())
    throw NumericalError(result.message.empty() ? "the solution is not finite" : result.message);
  if (result.status == SolveStatus::kNotConverged) throw NumericalError(result.message);

  Gather gather = build_gather(sys->scene.camera, sys->patches, sys->scene.materials, *sys->caster,
                               sys->transport, f.gather.options(f.system.classic));
  auto tg = std::chrono::steady_clock::now();
  Image image = apply_gather(gather, result.u);
  double apply_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tg).count();
  if (!image.all_finite()) throw NumericalError("the image has non-finite pixels");

  write_image(image, f.output, ImageWriteOptions{f.exposure});
  if (!f.patches_csv.empty()) write_patch_csv(f.patches_csv, *sys, result.u);
  if (!f.report.empty()) {
    JsonWriter w;
    w.begin_object();
    w.value("command", "render").value("method", f.method);
    write_system(w, *sys);
    write_solve(w, result);
    std::vector<StageTime> times{{"load", load_seconds}};
    times.insert(times.end(), sys->times.begin(), sys->times.end());
    times.push_back({"solve", result.seconds});
    times.push_back({"gather_build", gather.seconds});
    times.push_back({"gather_apply", apply_seconds});
    write_stage_times(w, times);
    w.value("gather_nnz", static_cast<long long>(gather.g.nnz()));
    w.value("gather_bytes", gather.bytes());
    w.value("peak_memory_bytes", peak_memory_bytes());
    w.value("machine", machine_description());
    w.end_object();
    write_file_atomic(f.report, w.str());
  }
  std::fprintf(stderr, "polyrad: %zu patches, %lld unknowns, %s in %d sweeps (residual %.2e); wrote %s\n",
               sys->patches.size(), static_cast<long long>(sys->transport.size()),
               solve_status_name(result.status), result.iterations, result.residual,
               f.output.c_str());
  return kExitOk;
}

namespace {

int run_render(const RenderFlags& f) {
  if (f.method == "series") return render_series(f);
  if (f.method == "pathtrace") return render_pathtrace(f);
  return render_iterative(f);
}

}  // namespace

void add_render_command(CLI::App& app, int& exit_code) {
  auto flags = std::make_shared<RenderFlags>();
  CLI::App* cmd = app.add_subcommand("render", "Render a scene to a linear-radiance image");
  cmd->add_option("scene", flags->scene, "Scene file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", flags->output, "Image: .exr or .pfm (linear), .png (tonemapped)")
      ->required();
  cmd->add_option("--method", flags->method, "Solution method")
      ->check(CLI::IsMember({"iterative", "series", "pathtrace"}))
      ->capture_default_str();
  cmd->add_option("--solver", flags->solver, "Iterative solver")
      ->check(CLI::IsMember({"gauss-seidel", "jacobi", "gmres", "chebyshev"}))
      ->capture_default_str();
  cmd->add_option("--tolerance", flags->tolerance, "Relative residual to stop at")
      ->check(CLI::Range(1e-14, 1.0))
      ->capture_default_str();
  cmd->add_option("--max-iterations", flags->max_iterations, "Sweep limit")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str();
  cmd->add_option("--order", flags->order, "Series: order K (default: chosen from --tolerance)")
      ->check(CLI::Range(0, 100000));
  cmd->add_option("--acceleration", flags->acceleration,
                  "Series: plain power series, or the Chebyshev polynomial (diffuse scenes)")
      ->check(CLI::IsMember({"none", "chebyshev"}))
      ->capture_default_str();
  cmd->add_option("--reorder", flags->reorder,
                  "Series: number the unknowns as built, or by reverse Cuthill-McKee for the "
                  "locality of the precompute's products (the same image)")
      ->check(CLI::IsMember({"none", "rcm"}))
      ->capture_default_str();
  cmd->add_option("--spp", flags->spp, "Path tracer: samples per pixel")
      ->check(CLI::Range(1, 1 << 24))
      ->capture_default_str();
  cmd->add_option("--seed", flags->seed, "Path tracer: random seed")->capture_default_str();
  cmd->add_option("--report", flags->report, "Write a JSON report here");
  cmd->add_option("--patches", flags->patches_csv, "Write one CSV row per patch here");
  flags->gather.add(*cmd);
  cmd->add_option("--exposure", flags->exposure, "Exposure of the .png tonemap")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  flags->system.add(*cmd);
  cmd->callback([flags, &exit_code] { exit_code = run_render(*flags); });
}

}  // namespace polyrad::cli
