// The command line's shared pieces: flag groups that fill the library's options, checks of
// output paths before any work, and the report. Each subcommand (src/cli/<name>_command.cpp)
// parses its flags into options, calls one workflow of the library (include/polyrad/app/), and
// writes what it returned; main.cpp maps errors by kind to exit codes.
#pragma once

#include <CLI/CLI.hpp>
#include <map>
#include <string>
#include <vector>

#include "polyrad/app/report.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/scene/scene.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/enum_names.h"

namespace polyrad::cli {

// Exit codes of the command line (README, "Exit codes").
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitNumerical = 3;

// An option whose value is one of an enum's names (util/enum_names.h); its default shown.
template <typename E>
CLI::Option* add_enum_option(CLI::App& app, const std::string& name, E& value,
                             const std::string& help) {
  std::map<std::string, E> names;
  for (const auto& [v, n] : EnumNames<E>::table) names.emplace(n, v);
  return app.add_option(name, value, help)
      ->transform(CLI::CheckedTransformer(names))
      ->default_str(enum_name(value));
}

// Throws InputError unless the directory of `path` exists (outputs are checked before work).
void check_output_path(const std::string& path, const char* what);
void check_image_path(const std::string& path);

// The report, when a path was given. Its peak memory is the process's up to this call, so that
// it counts the images the command wrote (their codec loads with the first, io/image_codec.h).
void write_report(const std::string& path, Report report);

// One "polyrad: warning: ..." line on stderr per lobe the patches smear.
void print_warnings(const std::vector<LobeResolution>& lobes);
// The same for a report: its lobes, and a path tracer's paths cut at max_depth.
void print_warnings(const Report& report);

// What every command that builds a radiosity system takes.
struct SystemFlags {
  double patch_size = 0.0;
  int specular_samples = 16;
  bool classic = false;
  bool centre_point = false;
  bool on_the_fly = false;
  bool unsafe_albedo = false;
  double max_memory_gib = 0.0;
  MeshKind mesh = MeshKind::kUniform;
  CLI::Option* mesh_option = nullptr;  // unless it was given, the workflow chooses the mesh
  HierarchyOptions hierarchy;          // link_tolerance 0 unless given: the workflow chooses
  std::vector<CLI::Option*> hierarchy_options;  // any given without --mesh: hierarchical
  void add(CLI::App& app);
  SceneOptions scene() const;
  SceneOverrides overrides() const;
  SystemOptions system() const;
};

// The camera gather's flags, for `render`, `precompute` and `sweep`. Counts left unset (-1, and
// an unset diffuse mode) take the kind's defaults: GatherOptions{} for the patch gather,
// GatherOptions::final_gather() for the final gather.
struct GatherFlags {
  GatherKind kind = GatherKind::kFinal;
  IndirectMode indirect = IndirectMode::kRays;
  std::string diffuse, mesh_read;
  int pixel_grid = -1, lobe_samples = -1, light_samples = -1, gather_samples = -1,
      near_samples = -1, reflector_samples = -1, mirror_image_samples = -1, mesh_near_samples = -1,
      mirror_image_depth = -1, mirror_chain_budget = -1;
  double near_distance = -1.0, mesh_near_distance = -1.0;
  ThroughMirrors through_mirrors = ThroughMirrors::kImaged;
  void add(CLI::App& app);
  GatherOptions options() const;
};

// NAME=R,G,B, repeatable, into a map; a name given twice, malformed text, or a negative or
// non-finite value is an InputError.
std::map<std::string, Rgb> parse_emissions(const std::vector<std::string>& texts);

void add_render_command(CLI::App& app, int& exit_code);
void add_precompute_command(CLI::App& app, int& exit_code);
void add_relight_command(CLI::App& app, int& exit_code);
void add_compare_command(CLI::App& app, int& exit_code);
void add_sweep_command(CLI::App& app, int& exit_code);
void add_convergence_command(CLI::App& app, int& exit_code);
void add_demo_command(CLI::App& app, int& exit_code);
void add_serve_command(CLI::App& app, int& exit_code);

}  // namespace polyrad::cli
