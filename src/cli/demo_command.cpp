// polyrad demo [--out DIR]: the main job on the default scene.
#include <cstdio>

#include "cli_common.h"
#include "polyrad/camera_gather.h"
#include "polyrad/files.h"
#include "polyrad/image.h"
#include "polyrad/scene.h"

#ifndef POLYRAD_SCENES_DIR
#define POLYRAD_SCENES_DIR "scenes"
#endif

namespace polyrad::cli {

namespace {

struct DemoFlags {
  std::string out = "out";
  std::string scene = std::string(POLYRAD_SCENES_DIR) + "/cornell-mirror-cube.json";
};

int run_demo(const DemoFlags& f) {
  make_directories(f.out);
  std::string name = "cornell-mirror-cube";
  std::fprintf(stderr, "polyrad demo: %s -> %s/\n", f.scene.c_str(), f.out.c_str());
  auto sys = build_system(load_scene(f.scene), PipelineOptions{});
  SolveResult result = solve(sys->transport, sys->transport.emission(), SolveOptions{});
  if (!result.ok()) throw NumericalError(result.message);
  Gather gather = build_gather(sys->scene.camera, sys->patches, sys->scene.materials,
                               *sys->caster, sys->transport, GatherOptions{});
  Image image = apply_gather(gather, result.u);
  write_image(image, f.out + "/" + name + ".exr");
  write_image(image, f.out + "/" + name + ".png");
  JsonWriter w;
  w.begin_object();
  w.value("command", "demo");
  write_system(w, *sys);
  write_solve(w, result);
  auto times = sys->times;
  times.push_back({"solve", result.seconds});
  times.push_back({"gather_build", gather.seconds});
  write_stage_times(w, times);
  w.value("peak_memory_bytes", peak_memory_bytes());
  w.value("machine", machine_description());
  w.end_object();
  write_file_atomic(f.out + "/report.json", w.str());
  std::fprintf(stderr, "polyrad demo: wrote %s/%s.png, %s/%s.exr, %s/report.json\n", f.out.c_str(),
               name.c_str(), f.out.c_str(), name.c_str(), f.out.c_str());
  return kExitOk;
}

}  // namespace

void add_demo_command(CLI::App& app, int& exit_code) {
  auto flags = std::make_shared<DemoFlags>();
  CLI::App* cmd = app.add_subcommand("demo", "Run the main job on the default scene");
  cmd->add_option("--out", flags->out, "Output directory")->capture_default_str();
  cmd->add_option("--scene", flags->scene, "Scene to use instead of the default")
      ->check(CLI::ExistingFile);
  cmd->callback([flags, &exit_code] { exit_code = run_demo(*flags); });
}

}  // namespace polyrad::cli
