// The hierarchical mesh against the uniform one on cornell-mirror-cube: whole renders, as a user
// runs them.
//
//   mirror_cube_render  `polyrad render` with the final gather, writing a .pfm (no image codec),
//                       at --mesh hierarchical (the final gather's default link tolerance,
//                       link_tolerance_for) and at --mesh uniform --patch-size 17, each as a
//                       process of its own so that its peak resident set is its own (wait4), the
//                       two alternated in every iteration so that both see the same load. Counters:
//                       each one's median wall time and peak, and time_ratio, memory_ratio
//                       (hierarchical over uniform, of the medians). Target: both at most 0.1, with
//                       the image error no worse, which the README's hierarchy study measures
//                       against the 4096-spp reference (a benchmark has no reference to compare
//                       with). Beside them, in the same iterations, the hierarchical mesh with
//                       the indirect light read from the mesh (--indirect mesh; its default
//                       tolerance 0.05) at the default two refinement passes (mesh_*) and at one
//                       (mesh1_*), each with its ratios to the same uniform run; and the
//                       mesh mode tuned for time (mesh60_*): roots of 60 instead of the scene's
//                       50, link tolerance 0.07, one pass, the probes' reach 1 instead of 2
//                       (--mesh-near-distance) and no second gather at near hits
//                       (--near-samples 0); what each costs in error: README, Hierarchical links.
// About a minute an iteration on two cores, most of it the uniform render.
// Targets are reported, never enforced.
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench_common.h"

extern char** environ;

namespace polyrad::bench {
namespace {

namespace fs = std::filesystem;

struct ProcessRun {
  double seconds = 0.0;
  double peak_bytes = 0.0;
};

// Runs the polyrad program with `args` to its end: its wall time and peak resident set.
ProcessRun run_polyrad(const std::vector<std::string>& args) {
  std::vector<std::string> all = {POLYRAD_CLI, "--quiet"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const Stopwatch watch;
  pid_t pid = 0;
  if (posix_spawn(&pid, POLYRAD_CLI, nullptr, nullptr, argv.data(), environ) != 0)
    throw std::runtime_error(std::string("cannot start ") + POLYRAD_CLI);
  int status = 0;
  struct rusage usage {};
  pid_t waited = 0;
  do {
    waited = wait4(pid, &status, 0, &usage);
  } while (waited < 0 && errno == EINTR);
  if (waited != pid) throw std::runtime_error("lost the polyrad process");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error(
        WIFEXITED(status)
            ? "polyrad render exited with " + std::to_string(WEXITSTATUS(status))
            : "polyrad render was killed by signal " + std::to_string(WTERMSIG(status)));
  return {watch.seconds(), static_cast<double>(usage.ru_maxrss) * 1024.0};  // kilobytes on Linux
}

// A folder of this run's own under the temporary directory, removed with it.
struct ScratchDir {
  fs::path path;
  ScratchDir() {
    std::string pattern = (fs::temp_directory_path() / "polyrad-hierarchy-bench-XXXXXX").string();
    if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot make a temporary folder");
    path = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

void mirror_cube_render(benchmark::State& state) {
  std::optional<ScratchDir> scratch;
  try {
    scratch.emplace();
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  const fs::path& out = scratch->path;
  const std::string scene = std::string(POLYRAD_SCENES_DIR) + "/cornell-mirror-cube.json";
  const std::vector<std::string> common = {"render", scene, "--gather", "final"};
  auto with = [&](std::vector<std::string> mesh, const char* image) {
    std::vector<std::string> args = common;
    args.insert(args.end(), mesh.begin(), mesh.end());
    args.push_back("-o");
    args.push_back((out / image).string());
    return args;
  };
  struct Runs {
    std::string name;  // counters' prefix
    std::vector<std::string> args;
    std::vector<double> time, peak;
  };
  std::vector<Runs> runs = {
      {"uniform17", with({"--mesh", "uniform", "--patch-size", "17"}, "uniform.pfm"), {}, {}},
      {"hierarchical", with({"--mesh", "hierarchical"}, "hierarchical.pfm"), {}, {}},
      {"mesh", with({"--mesh", "hierarchical", "--indirect", "mesh"}, "mesh.pfm"), {}, {}},
      {"mesh1",
       with({"--mesh", "hierarchical", "--indirect", "mesh", "--refine-passes", "1"}, "mesh1.pfm"),
       {},
       {}},
      {"mesh60",
       with({"--mesh", "hierarchical", "--indirect", "mesh", "--refine-passes", "1", "--patch-size",
             "60", "--link-tolerance", "0.07", "--mesh-near-distance", "1", "--near-samples", "0"},
            "mesh60.pfm"),
       {},
       {}}};
  try {
    for (auto _ : state) {
      for (Runs& r : runs) {
        const ProcessRun p = run_polyrad(r.args);
        r.time.push_back(p.seconds);
        r.peak.push_back(p.peak_bytes);
      }
      state.SetIterationTime(runs[1].time.back());
    }
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  const double ut = median(runs[0].time), up = median(runs[0].peak);
  for (const Runs& r : runs) {
    const double t = median(r.time), p = median(r.peak);
    state.counters[r.name + "_s"] = t;
    state.counters[r.name + "_peak_bytes"] = bytes_counter(p);
    if (&r == &runs[0]) continue;
    const std::string prefix = &r == &runs[1] ? "" : r.name + "_";
    state.counters[prefix + "time_ratio"] = ut > 0.0 ? t / ut : 0.0;
    state.counters[prefix + "memory_ratio"] = up > 0.0 ? p / up : 0.0;
  }
}

BENCHMARK(mirror_cube_render)->UseManualTime()->Iterations(2)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace polyrad::bench

int main(int argc, char** argv) {
  return polyrad::bench::run_benchmarks(argc, argv, "cornell-mirror-cube");
}
