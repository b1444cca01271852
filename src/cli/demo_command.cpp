// polyrad demo [--out DIR] [--scene SCENE] [--spp N]: the main job on the default scene
// (app/demo.h).
#include <cstdio>

#include "flags.h"
#include "polyrad/app/demo.h"

#ifndef POLYRAD_SCENES_DIR
#define POLYRAD_SCENES_DIR "scenes"
#endif

namespace polyrad::cli {

void add_demo_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<DemoOptions>();
  o->scene = std::string(POLYRAD_SCENES_DIR) + "/cornell-mirror-cube.json";
  CLI::App* cmd = app.add_subcommand("demo", "Run the main job on the default scene");
  cmd->add_option("--out", o->out, "Output directory")->capture_default_str();
  cmd->add_option("--scene", o->scene, "Scene to use instead of the default")
      ->check(CLI::ExistingFile);
  cmd->add_option("--spp", o->spp, "Samples per pixel of the path-traced reference")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd->callback([o, &exit_code] {
    const DemoResult r = demo(*o);
    print_warnings(r.report);
    std::fputs(r.summary.c_str(), stdout);
    exit_code = kExitOk;
  });
}

}  // namespace polyrad::cli
