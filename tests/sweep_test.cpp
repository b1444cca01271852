// polyrad sweep and scripts/charts.py end to end, on a Cornell box shrunk to a 32 x 32 camera and
// a handful of patches: the CSV has the columns the charts read and figures that hold together,
// the charts are PNG files a loader opens, the reference is cached, bad input is exit code 2.
#include "polyrad/app/sweep.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "polyrad/io/image_io.h"
#include "test_support.h"

namespace polyrad {
namespace {

const std::string kPython = "/usr/bin/python3";
const std::string kCharts = std::string(POLYRAD_SCRIPTS_DIR) + "/charts.py";

using test::CommandRun;
using test::read_text;
using test::run_cli;
using test::run_shell;

// python3 with matplotlib is a listed dependency (scripts/deps.sh installs python3-matplotlib):
// its absence fails the test with the reason, it is not skipped.
void require_matplotlib() {
  CommandRun r = run_shell(kPython + " -c 'import matplotlib'");
  ASSERT_EQ(r.code, 0) << "the charts need " << kPython
                       << " with matplotlib: install python3-matplotlib (scripts/deps.sh)\n"
                       << r.err;
}

// The Cornell box, its camera cut to 32 x 32 pixels, copied into dir with its meshes.
std::string tiny_scene(const std::filesystem::path& dir) {
  std::string text = read_text(test::scene_path("cornell-box"));
  const std::string size = "\"width\": 256, \"height\": 256";
  EXPECT_NE(text.find(size), std::string::npos);
  text.replace(text.find(size), size.size(), "\"width\": 32, \"height\": 32");
  for (const char* mesh : {"short_block.obj", "tall_block.obj"})
    test::write_file(dir, std::string("meshes/") + mesh,
                     read_text(std::string(POLYRAD_SCENES_DIR) + "/meshes/" + mesh));
  return test::write_file(dir, "tiny-box.json", text);
}

std::vector<std::string> split(const std::string& line, char sep = ',') {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, sep);) cells.push_back(cell);
  if (!line.empty() && line.back() == sep) cells.emplace_back();
  return cells;
}

struct Csv {
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  double number(size_t row, const std::string& column) const {
    const std::string& cell = rows.at(row).at(column);
    return cell.empty() ? NAN : std::stod(cell);
  }
};

Csv read_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  Csv csv;
  std::string line;
  std::getline(in, line);
  csv.header = split(line);
  while (std::getline(in, line)) {
    auto cells = split(line);
    EXPECT_EQ(cells.size(), csv.header.size()) << line;
    std::map<std::string, std::string> row;
    for (size_t c = 0; c < csv.header.size() && c < cells.size(); ++c)
      row[csv.header[c]] = cells[c];
    csv.rows.push_back(row);
  }
  return csv;
}

bool has(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TEST(Sweep, RunsEndToEndAndTheChartsOpen) {
  require_matplotlib();
  auto dir = test::temp_dir();
  std::string scene = tiny_scene(dir);
  std::string out = (dir / "sweep").string();
  const std::string knobs =
      " --patch-sizes 200,150 --link-tolerances 0.2 --orders 0,2,8 --drops 0,1e-3"
      " --precisions float,half --sweeps 1,4 --spp 1,2 --repeats 2";
  CommandRun r = run_cli("sweep " + scene + " --out " + out + knobs + " --reference-spp 8");
  ASSERT_EQ(r.code, 0) << r.err;

  Csv csv = read_csv(std::filesystem::path(out) / "sweep.csv");
  // The columns the charts read, named with their units; and every one charts.py asks for.
  for (const char* column :
       {"method", "patch_size_scene_units", "patches", "order_K", "drop_fraction", "precision",
        "sweeps", "spp", "image_seconds", "precompute_seconds", "operator_bytes", "peak_rss_bytes",
        "a_max", "apriori_bound_rel", "solution_error_flux_rel", "error_vs_converged_rel_l1",
        "error_vs_converged_rel_rmse", "error_vs_converged_mean_rel", "error_vs_reference_rel_l1"})
    EXPECT_TRUE(has(csv.header, column)) << column;
  CommandRun wanted = run_shell(kPython + " -c \"import sys; sys.path.insert(0, '" +
                                std::string(POLYRAD_SCRIPTS_DIR) +
                                "'); import charts; print(','.join(charts.COLUMNS))\"");
  ASSERT_EQ(wanted.code, 0) << wanted.err;
  for (const std::string& column : split(wanted.out.substr(0, wanted.out.find('\n'))))
    EXPECT_TRUE(has(csv.header, column))
        << "charts.py reads '" << column << "', the sweep lacks it";

  // Per mesh (patch sizes 200 and 150, and the hierarchy on the 200 patches): the converged
  // row, 2 solvers x 2 sweep counts, 3 orders x 2 drops x 2 precisions, 2 path-traced images.
  ASSERT_EQ(csv.rows.size(), 3u * (1 + 4 + 12 + 2));
  std::map<std::string, int> methods;
  double uniform_200_patches = 0.0, leaves = 0.0;
  int hierarchical = 0;
  for (size_t i = 0; i < csv.rows.size(); ++i) {
    const std::string& m = csv.rows[i].at("method");
    ++methods[m];
    if (csv.rows[i].at("mesh") == "hierarchical") {
      ++hierarchical;
      EXPECT_EQ(csv.number(i, "link_tolerance"), 0.2) << i;
      EXPECT_EQ(csv.number(i, "patch_size_scene_units"), 200.0) << i;
      leaves = csv.number(i, "patches");
    } else {
      EXPECT_EQ(csv.rows[i].at("mesh"), "uniform") << i;
      EXPECT_TRUE(csv.rows[i].at("link_tolerance").empty()) << i;
      if (csv.number(i, "patch_size_scene_units") == 200.0)
        uniform_200_patches = csv.number(i, "patches");
    }
    EXPECT_GT(csv.number(i, "image_seconds"), 0.0) << i;
    EXPECT_GE(csv.number(i, "error_vs_reference_rel_l1"), 0.0) << i;
    if (m == "pathtrace") continue;
    double a = csv.number(i, "a_max");
    EXPECT_GT(a, 0.0);
    EXPECT_LT(a, 1.0);
    EXPECT_GT(csv.number(i, "operator_bytes"), 0.0) << i;
    // The a-priori bound bounds the measured error of the solution (papers/, section 5).
    if (m != "converged") {
      EXPECT_LE(csv.number(i, "solution_error_flux_rel"),
                csv.number(i, "apriori_bound_rel") * (1 + 1e-9))
          << i;
    }
    if (m == "series" && csv.rows[i].at("drop_fraction") == "0" &&
        csv.rows[i].at("precision") == "float" && csv.rows[i].at("order_K") == "8") {
      EXPECT_LT(csv.number(i, "error_vs_converged_rel_l1"), 0.02) << i;
    }
  }
  EXPECT_EQ(methods["series"], 36);
  EXPECT_EQ(methods["jacobi"], 6);
  EXPECT_EQ(methods["gauss-seidel"], 6);
  EXPECT_EQ(methods["pathtrace"], 6);
  EXPECT_EQ(methods["converged"], 3);
  EXPECT_EQ(hierarchical, 19);
  EXPECT_GT(leaves, uniform_200_patches);  // the hierarchy's leaves refine the 200 patches
  std::string machine = read_text(std::filesystem::path(out) / "machine.txt");
  for (const char* key : {"machine: ", "threads: ", "date: ", "reference: "})
    EXPECT_NE(machine.find(key), std::string::npos) << key << "\n" << machine;
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(out) / "reference.exr"));

  // The charts, from the CSV: PNG files that a loader opens.
  std::string charts = (dir / "charts").string();
  CommandRun c = run_shell(kPython + " " + kCharts + " " + out + " --out " + charts);
  ASSERT_EQ(c.code, 0) << c.err;
  for (const char* name : {"error_vs_time.png", "error_vs_order.png", "cost_vs_patches.png"}) {
    auto path = std::filesystem::path(charts) / name;
    ASSERT_TRUE(std::filesystem::exists(path)) << path;
    EXPECT_EQ(read_text(path).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << path;
    Image img = read_image(path.string());
    EXPECT_GT(img.width, 300) << path;
    EXPECT_GT(img.height, 300) << path;
  }
  for (const auto& e : std::filesystem::directory_iterator(charts))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();

  // A rerun reuses the cached reference; another sample count makes it stale.
  CommandRun again = run_cli("sweep " + scene + " --out " + out +
                             " --patch-sizes 200 --orders 1 --drops 0"
                             " --precisions float --sweeps 1 --spp 1 --reference-spp 8");
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_NE(again.err.find("reusing"), std::string::npos) << again.err;
  CommandRun stale = run_cli("sweep " + scene + " --out " + out +
                             " --patch-sizes 200 --orders 1 --drops 0"
                             " --precisions float --sweeps 1 --spp 1 --reference-spp 4");
  ASSERT_EQ(stale.code, 0) << stale.err;
  EXPECT_NE(stale.err.find("stale"), std::string::npos) << stale.err;
  EXPECT_EQ(read_csv(std::filesystem::path(out) / "sweep.csv").rows.size(), 1u + 2 + 1 + 1);
}

// The quick preset fills what the caller left: one hierarchical mesh at the tolerance a render
// with the same gather takes (the two gathers take different ones, so a lost gather shows).
TEST(Sweep, QuickPresetTakesTheGathersLinkTolerance) {
  ASSERT_NE(link_tolerance_for(GatherKind::kFinal), link_tolerance_for(GatherKind::kPatch));
  for (GatherKind kind : {GatherKind::kFinal, GatherKind::kPatch}) {
    SweepOptions o;
    o.gather.kind = kind;
    apply_quick_preset(o, {});
    EXPECT_EQ(o.link_tolerances, std::vector<double>{link_tolerance_for(kind)});
    EXPECT_EQ(o.patch_sizes, (std::vector<double>{100, 50, 35}));
    EXPECT_EQ(o.drops, (std::vector<double>{0.0, 1e-3}));
    EXPECT_EQ(o.reference_spp, 512);
  }
  SweepOptions chosen;
  chosen.patch_sizes = {40};
  chosen.link_tolerances = {0.2};
  chosen.drops = {0.01};
  chosen.reference_spp = 64;
  apply_quick_preset(chosen, {true, true, true, true});
  EXPECT_EQ(chosen.patch_sizes, std::vector<double>{40});
  EXPECT_EQ(chosen.link_tolerances, std::vector<double>{0.2});
  EXPECT_EQ(chosen.drops, std::vector<double>{0.01});
  EXPECT_EQ(chosen.reference_spp, 64);
}

// Through the command line: `--quick` with each gather writes its hierarchical rows at that
// gather's tolerance (the preset must see the gather the flags chose).
TEST(Sweep, QuickFromTheCommandLineFollowsTheGather) {
  auto dir = test::temp_dir();
  std::string scene = tiny_scene(dir);
  for (GatherKind kind : {GatherKind::kFinal, GatherKind::kPatch}) {
    const std::string name = kind == GatherKind::kFinal ? "final" : "patch";
    std::string out = (dir / name).string();
    CommandRun r = run_cli("sweep " + scene + " --out " + out + " --quick --gather " + name +
                           " --patch-sizes 200 --orders 1 --drops 0 --precisions float"
                           " --sweeps 1 --spp 1 --reference-spp 8 --gather-samples 4"
                           " --light-samples 4 --reflector-samples 4");
    ASSERT_EQ(r.code, 0) << r.err;
    Csv csv = read_csv(std::filesystem::path(out) / "sweep.csv");
    int hierarchical = 0;
    for (size_t i = 0; i < csv.rows.size(); ++i) {
      if (csv.rows[i].at("mesh") != "hierarchical") continue;
      ++hierarchical;
      EXPECT_DOUBLE_EQ(csv.number(i, "link_tolerance"), link_tolerance_for(kind)) << name;
    }
    EXPECT_GT(hierarchical, 0) << name;
  }
}

// Paths cut at --max-depth in the reference are a warning on stderr and a line of machine.txt,
// also when a rerun reuses the cached reference (its paths and cut paths are kept with its key);
// another depth is another key, and the reference is rendered again.
TEST(Sweep, WarnsOfReferencePathsCutAtMaxDepthAndCachesTheCount) {
  auto dir = test::temp_dir();
  const std::string scene = tiny_scene(dir), out = (dir / "sweep").string();
  const std::string sweep = "sweep " + scene + " --out " + out +
                            " --patch-sizes 200 --orders 0 --drops 0 --precisions float"
                            " --sweeps 1 --spp 1 --reference-spp 1 --repeats 1";
  auto machine_line = [&] {
    const std::string text = read_text(std::filesystem::path(out) / "machine.txt");
    const std::size_t at = text.find("reference_paths_cut_at_max_depth: ");
    return at == std::string::npos ? std::string() : text.substr(at, text.find('\n', at) - at);
  };
  // One segment: every camera ray ends on its first surface, cut there unless it is the black
  // lamp (947 of the 32 x 32 paths, measured); the rerun reuses the reference and its count.
  std::string first;
  for (int run = 0; run < 2; ++run) {
    const CommandRun r = run_cli(sweep + " --max-depth 1");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("polyrad sweep: warning: the reference: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("raise --max-depth"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("reusing") != std::string::npos, run == 1) << r.err;
    const std::string line = machine_line();
    const std::string head = "reference_paths_cut_at_max_depth: ", tail = " of 1024";
    ASSERT_EQ(line.substr(0, head.size()), head) << line;
    ASSERT_GT(line.size(), head.size() + tail.size()) << line;
    EXPECT_EQ(line.substr(line.size() - tail.size()), tail) << line;
    EXPECT_GT(std::stoi(line.substr(head.size())), 512) << line;
    if (run == 0) first = line;
    EXPECT_EQ(line, first);
  }
  const CommandRun deep = run_cli(sweep);
  ASSERT_EQ(deep.code, 0) << deep.err;
  EXPECT_EQ(deep.err.find("warning"), std::string::npos) << deep.err;
  EXPECT_EQ(machine_line(), "reference_paths_cut_at_max_depth: 0 of 1024");
}

TEST(Sweep, BadInputIsExitTwoAndWritesNothing) {
  auto dir = test::temp_dir();
  std::string scene = tiny_scene(dir);
  std::string out = (dir / "out").string();
  std::string file = test::write_file(dir, "a-file", "x");
  for (const std::string& args : std::vector<std::string>{
           "sweep " + scene + " --out " + out + " --orders -1",
           "sweep " + scene + " --out " + out + " --precisions double",
           "sweep " + scene + " --out " + out + " --patch-sizes 0",
           "sweep " + scene + " --out " + out + " --drops 1.5",
           "sweep " + scene + " --out " + out + " --spp 0",
           "sweep " + scene + " --out " + out + " --max-depth 0",
           "sweep " + scene + " --out " + out + " --link-tolerances 0",
           "sweep " + scene + " --out " + out + " --link-tolerances x",
           "sweep " + scene + " --out " + file,
           "sweep " + (dir / "none.json").string() + " --out " + out, "sweep " + scene}) {
    CommandRun r = run_cli(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << "\n" << r.err;
    EXPECT_FALSE(std::filesystem::exists(std::filesystem::path(out) / "sweep.csv")) << args;
  }
}

TEST(Sweep, ChartsRefuseACsvWithoutTheirColumns) {
  require_matplotlib();
  auto dir = test::temp_dir();
  test::write_file(dir, "sweep.csv", "method,image_seconds\nseries,0.001\n");
  CommandRun r = run_shell(kPython + " " + kCharts + " " + dir.string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("error_vs_converged_rel_l1"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "error_vs_time.png"));
}

}  // namespace
}  // namespace polyrad
