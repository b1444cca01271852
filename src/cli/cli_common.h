// Shared pieces of the polyrad subcommands: output checks, reports, the machine description.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "polyrad/render/camera_gather.h"
#include "polyrad/util/json.h"
#include "polyrad/transport/system.h"
#include "polyrad/solve/solver.h"

namespace polyrad::cli {

// Exit codes of the command line (README, "Exit codes").
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitNumerical = 3;

// Throws InputError unless the directory of `path` exists (outputs are checked before work).
void check_output_path(const std::string& path, const char* what);
void check_image_path(const std::string& path);

// One line describing this machine: CPU model, cores, memory.
std::string machine_description();

// Writers of report sections.
void write_system(JsonWriter& w, const RadiositySystem& sys);
void write_solve(JsonWriter& w, const SolveResult& r);
void write_stage_times(JsonWriter& w, const std::vector<StageTime>& times);
// "warnings": one entry per glossy object whose lobe the patches smear (lobe_resolution.h), and
// "lobe_resolution": the check for every glossy object. write_system writes both.
void write_lobe_checks(JsonWriter& w, const std::vector<LobeResolution>& lobes);

// One "polyrad: warning: ..." line on stderr per smeared lobe of the system.
void print_warnings(const RadiositySystem& sys);

// patch,object,area,cx,cy,cz,nx,ny,nz,r,g,b: one row per patch, its diffuse radiosity B.
void write_patch_csv(const std::string& path, const RadiositySystem& sys, const Field& u);

// Options shared by commands that build a system.
struct SystemFlags {
  double patch_size = 0.0;
  int specular_samples = 16;
  bool classic = false;
  bool centre_point = false;
  bool on_the_fly = false;
  bool unsafe_albedo = false;
  double max_memory_gib = 0.0;
  void add(CLI::App& app);
  PipelineOptions pipeline() const;
  SceneOptions scene_options() const;
};

// The camera gather's flags, for `render` and `precompute`.
struct GatherFlags {
  std::string diffuse = "smooth";
  int pixel_grid = 2;
  int lobe_samples = 16;
  int light_samples = 4;
  void add(CLI::App& app);
  // classic: every material shows its diffuse part only, as the classic system transports it.
  GatherOptions options(bool classic) const;
};

void add_render_command(CLI::App& app, int& exit_code);
void add_demo_command(CLI::App& app, int& exit_code);
void add_compare_command(CLI::App& app, int& exit_code);
void add_precompute_command(CLI::App& app, int& exit_code);
void add_relight_command(CLI::App& app, int& exit_code);
void add_convergence_command(CLI::App& app, int& exit_code);
void add_sweep_command(CLI::App& app, int& exit_code);

}  // namespace polyrad::cli
