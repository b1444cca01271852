// The command line as a user meets it: exit codes, one-line errors, no partial outputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "polyrad/io/image_io.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/util/hash.h"
#include "polyrad/util/json.h"
#include "test_support.h"

namespace polyrad {
namespace {

using test::CommandRun;
using test::run_shell;

CommandRun run(const std::string& args) { return test::run_cli(args); }

// A final gather of few samples, for the runs whose subject is not the gather: the default's 64
// cosine and 64 light samples per ray took five sixths of a Cornell box render (10.6 s against
// 1.9 s in Release), and six times as long under the sanitizers.
const std::string kQuickGather =
    " --gather-samples 4 --light-samples 4 --near-samples 0 --pixel-grid 1";

size_t lines(const std::string& s) {
  size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// The run r, whose report is at `report_path`, counted hits where the chain budget cut the
// facing mirrors' chains and warned of it, once, on stderr and in the report. Returns the counts.
JsonValue expect_chains_cut(const CommandRun& r, const std::string& report_path) {
  if (r.code != 0) {
    ADD_FAILURE() << "exit " << r.code << ": " << r.err;
    return JsonValue{};
  }
  EXPECT_NE(r.err.find("raise --mirror-chains"), std::string::npos) << r.err;
  JsonValue report = test::read_json(report_path);
  const JsonValue* warnings = report.find("warnings");
  EXPECT_EQ(warnings->array.size(), 1u);
  if (!warnings->array.empty()) {
    EXPECT_EQ(warnings->array[0].find("kind")->string, "mirror_chains_cut_by_budget");
  }
  const JsonValue* chains = report.find("gather")->find("mirror_chains");
  EXPECT_NE(chains, nullptr);
  if (!chains) return JsonValue{};
  EXPECT_GT(chains->find("hits_cut")->number, 0.0);
  return *chains;
}

// Where the chain budget cuts the chains of facing mirrors short, the report counts the hits and
// warns, on stderr too; where it holds them all, neither.
TEST(Cli, RenderWarnsWhereTheChainBudgetCutsFacingMirrorsShort) {
  auto dir = test::temp_dir();
  const std::string img = (dir / "m.pfm").string(), rep = (dir / "m.json").string();
  const std::string render = "render " + test::scene_path("stability/mirrored-room") + " -o " +
                             img + " --report " + rep + kQuickGather;
  CommandRun r = run(render + " --mirror-chains 64");
  const JsonValue chains = expect_chains_cut(r, rep);
  ASSERT_NE(chains.find("hits"), nullptr);
  EXPECT_GT(chains.find("hits")->number, 0.0);
  EXPECT_EQ(chains.find("hits_cut")->number, chains.find("hits")->number);
  r = run(render + " --mirror-chains 100000 --mirror-image-depth 3");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  const JsonValue report = test::read_json(rep);
  EXPECT_EQ(report.find("gather")->find("mirror_chains")->find("hits_cut")->number, 0.0);
  EXPECT_TRUE(report.find("warnings")->array.empty());
  EXPECT_EQ(run(render + " --mirror-chains -1").code, 2);
}

// The precompute builds the same gather behind its view rows, so it counts and warns as render
// does.
TEST(Cli, PrecomputeWarnsWhereTheChainBudgetCutsFacingMirrorsShort) {
  auto dir = test::temp_dir();
  const std::string scene = test::scene_path("stability/mirrored-room");
  const std::string view = (dir / "v.prt").string();
  const std::string rep = (dir / "p.json").string(), img = (dir / "r.pfm").string();
  const std::string cut = " --order 8 --mirror-chains 64" + kQuickGather;
  CommandRun r =
      run("precompute " + scene + " -o " + view + " --output view --report " + rep + cut);
  ASSERT_NE(expect_chains_cut(r, rep).find("hits_cut"), nullptr);
  // A view operator's rows hold the gather: relighting it builds none and says nothing of it.
  r = run("relight " + view + " -o " + img + " --report " + rep);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  EXPECT_EQ(test::read_json(rep).find("gather"), nullptr);
}

TEST(Cli, RenderWritesImageReportAndPatchTable) {
  auto dir = test::temp_dir();
  std::string img = (dir / "cb.pfm").string(), rep = (dir / "r.json").string(),
              csv = (dir / "p.csv").string();
  CommandRun r = run("render " + test::scene_path("cornell-box") + " -o " + img + " --report " +
                     rep + " --patches " + csv + " --method iterative --tolerance 1e-4" +
                     kQuickGather);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(img));
  JsonValue report = test::read_json(rep);
  for (const char* key : {"system", "solve", "gather", "seconds", "peak_memory_bytes", "machine"})
    ASSERT_NE(report.find(key), nullptr) << key;
  const JsonValue& system = *report.find("system");
  for (const char* key : {"patches", "unknowns", "form_factors", "specular_transfer", "operator"})
    EXPECT_NE(system.find(key), nullptr) << key;
  EXPECT_LT(report.find("solve")->find("residual")->number, 1e-4);
  EXPECT_GT(report.find("solve")->find("iterations")->number, 0.0);
  EXPECT_GT(report.find("peak_memory_bytes")->number, 1e6);
  EXPECT_NE(report.find("seconds")->find("form_factors"), nullptr);
  std::ifstream cin(csv);
  std::string header;
  std::getline(cin, header);
  EXPECT_EQ(header, "patch,object,area,cx,cy,cz,nx,ny,nz,r,g,b");
  size_t rows = 0;
  for (std::string line; std::getline(cin, line);) ++rows;
  EXPECT_EQ(static_cast<double>(rows), system.find("patches")->number);
}

TEST(Cli, BadInputIsExitTwoWithOneLineAndNoOutput) {
  auto dir = test::temp_dir();
  std::string img = (dir / "x.png").string();
  std::string bad = test::write_file(dir, "bad.json", "{\"camera\": 3}");
  for (const std::string& args : std::vector<std::string>{
           "render " + bad + " -o " + img, "render " + dir.string() + "/none.json -o " + img,
           "render " + test::scene_path("cornell-box") + " -o " + (dir / "x.bmp").string(),
           "render " + test::scene_path("cornell-box") + " -o " + (dir / "no" / "x.png").string(),
           "render " + test::scene_path("cornell-box") + " -o " + img + " --tolerance -1",
           "render " + test::scene_path("cornell-box") + " -o " + img + " --method magic",
           "render " + test::scene_path("cornell-box"), "frobnicate", ""}) {
    CommandRun r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
    EXPECT_EQ(lines(r.err), 1u) << args << "\n" << r.err;
  }
  CommandRun r = run("render " + bad + " -o " + img);
  EXPECT_NE(r.err.find("bad.json:1:"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(img));
}

TEST(Cli, WorkThatCannotFitIsRefusedAtOnceWithTheEstimate) {
  // The Cornell box seen at 8192 x 8192 (precompute) and 16384 x 16384 (render with the stored
  // patch gather): the camera's share alone is tens of GiB, past a budget of 16 GiB that the
  // rest fits in many times over; the refusal comes before the mesh is made, with exit 2, the
  // estimate by part (the camera's over the budget), and no output.
  auto dir = test::temp_dir();
  const std::filesystem::path scenes = std::filesystem::path(test::scene_path("cornell-box")).parent_path();
  auto scene_at = [&](int side) {
    std::string text = test::read_text(test::scene_path("cornell-box"));
    for (const char* key : {"\"width\": 256", "\"height\": 256"}) {
      const size_t at = text.find(key);
      EXPECT_NE(at, std::string::npos) << key;
      text.replace(at, std::string(key).size(),
                   std::string(key).substr(0, std::string(key).find(':') + 2) + std::to_string(side));
    }
    for (size_t at = text.find("\"meshes/"); at != std::string::npos; at = text.find("\"meshes/", at + 2))
      text.insert(at + 1, scenes.string() + "/");
    return test::write_file(dir, "box" + std::to_string(side) + ".json", text);
  };
  const std::string prt = (dir / "huge.prt").string(), img = (dir / "huge.exr").string();
  for (const std::string& args :
       {"precompute " + scene_at(8192) + " -o " + prt + " --max-memory 16",
        "render " + scene_at(16384) + " --gather patch -o " + img + " --max-memory 16"}) {
    CommandRun r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find("needs an estimated"), std::string::npos) << r.err;
    const size_t at = r.err.find("camera ");
    ASSERT_NE(at, std::string::npos) << r.err;
    EXPECT_GT(std::stod(r.err.substr(at + 7)), 16.0) << r.err;  // "camera X GiB"
  }
  EXPECT_FALSE(std::filesystem::exists(prt));
  EXPECT_FALSE(std::filesystem::exists(img));
  // The same scene at 256 x 256 fits the same budget (on the uniform mesh, which is quick under
  // the sanitizers; the hierarchy's estimate is held to its peak elsewhere).
  CommandRun fits = run("render " + scene_at(256) + " --gather patch --mesh uniform -o " + img +
                        " --max-memory 16");
  EXPECT_EQ(fits.code, 0) << fits.err;
}

// How far the light refines a hierarchy is known only as it goes: the facing mirrors of 0.99
// refine to 236,711 links (7.2 a visible root pair, where the estimate's fit takes 1.9) and peak
// at 58 MB against an estimate of 35. Past what the budget leaves the links (at 100 bytes a
// link, under the 135 to 176 measured), refinement stops with exit 2 and writes nothing; with
// the default budget the same run succeeds (HierarchyImages.FacingMirrorsKeepTheRootLinksFlux).
TEST(Cli, HierarchyRefinedPastTheMemoryBudgetIsRefusedWithoutOutput) {
  auto dir = test::temp_dir();
  const std::string img = (dir / "f.pfm").string();
  const CommandRun r = run("render " + test::scene_path("stability/facing-mirrors-0.99") +
                           " --gather patch -o " + img + " --max-memory 0.0335");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("the hierarchy refined to"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("link tolerance"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(img));
}

TEST(Cli, MemoryEstimateIsWithinOneAndAHalfOfTheMeasuredPeak) {
  if (test::kUnderAddressSanitizer)
    GTEST_SKIP() << "AddressSanitizer's shadow memory is not the program's";
  // A specular scene (the mirror's transfer entries) and a diffuse one at a finer mesh (the form
  // factors), each uniform with the stored patch gather, a hierarchy of one refinement pass read
  // by the final gather, and the patch gather's own hierarchy on a glossy scene's patches and on
  // roots finer than the scene's (estimated at 1.8 times its peak when it scaled the scene's
  // links with the root pairs), and the final gather's hierarchy on roots four times the scene's
  // (2.0 when the estimate took no account of their coarser smallest elements): what the report
  // says was estimated against the process's peak
  // resident set. The first writes an .exr (the codec module loaded beside the system), the
  // others a .pfm (no module, none counted).
  auto dir = test::temp_dir();
  const std::string report = (dir / "r.json").string();
  for (const std::string& args :
       {"render " + test::scene_path("cornell-mirror-cube") +
            " --mesh uniform --patch-size 35 --gather patch -o " + (dir / "x.exr").string(),
        "render " + test::scene_path("cornell-box") +
            " --mesh uniform --patch-size 25 --gather patch -o " + (dir / "x.pfm").string(),
        "render " + test::scene_path("cornell-box") +
            " --mesh hierarchical --indirect mesh --refine-passes 1 -o " + (dir / "x.pfm").string(),
        "render " + test::scene_path("cornell-glossy") + " --gather patch -o " +
            (dir / "x.pfm").string(),
        "render " + test::scene_path("cornell-box") + " --patch-size 35 --gather patch -o " +
            (dir / "x.pfm").string(),
        "render " + test::scene_path("cornell-box") + " --mesh hierarchical --patch-size 200 -o " +
            (dir / "x.pfm").string()}) {
    CommandRun r = run(args + " --report " + report);
    ASSERT_EQ(r.code, 0) << args << "\n" << r.err;
    const JsonValue rep = test::read_json(report);
    const double estimate = rep.find("system")->find("estimated_memory_bytes")->number;
    const double peak = rep.find("peak_memory_bytes")->number;
    const JsonValue* parts = rep.find("system")->find("estimated_memory");
    ASSERT_NE(parts, nullptr) << args;
    double sum = 0.0;
    for (const char* part : {"base_bytes", "world_bytes", "system_bytes", "camera_bytes"})
      sum += parts->find(part)->number;
    EXPECT_NEAR(sum, estimate, 1e-9 * estimate) << args;
    EXPECT_LT(estimate, 1.5 * peak) << args;
    EXPECT_GT(estimate, peak / 1.5) << args;
    RecordProperty(args.substr(7, 40), std::to_string(estimate / peak));
  }
}

TEST(Cli, DivergenceIsExitThreeAndWritesNothing) {
  auto dir = test::temp_dir();
  std::string scene = test::write_file(
      dir, "hot.json",
      test::closed_box_json(Vec3(1, 1, 1), 0.5,
                            R"({"type": "diffuse", "reflectance": [1.3, 1.3, 1.3]})", 1.0));
  std::string img = (dir / "hot.exr").string();
  CommandRun safe = run("render " + scene + " -o " + img);
  EXPECT_EQ(safe.code, 2) << safe.err;  // refused at load without the unsafe flag
  CommandRun r = run("render " + scene + " -o " + img + " --allow-unsafe-albedo --report " +
                     (dir / "r.json").string());
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("diverges"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(img));
  EXPECT_FALSE(std::filesystem::exists(dir / "r.json"));
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(Cli, HelpIsExitZero) {
  EXPECT_EQ(run("--help").code, 0);
  EXPECT_EQ(run("render --help").code, 0);
}

}  // namespace
}  // namespace polyrad

namespace polyrad {
namespace {

TEST(Cli, PrecomputeThenRelight) {
  auto dir = test::temp_dir();
  // A private copy of the scene, so that changing it afterwards makes the operator stale.
  std::ifstream in(test::scene_path("cornell-box"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* mesh : {"short_block.obj", "tall_block.obj"}) {
    std::ifstream m(std::string(POLYRAD_SCENES_DIR) + "/meshes/" + mesh);
    test::write_file(dir, std::string("meshes/") + mesh,
                     std::string((std::istreambuf_iterator<char>(m)), {}));
  }
  std::string scene = test::write_file(dir, "box.json", text);
  std::string prt = (dir / "box.prt").string();
  CommandRun pre =
      run("precompute " + scene + " -o " + prt + " --tolerance 1e-3 --precision half --report " +
          (dir / "pre.json").string() + kQuickGather);
  ASSERT_EQ(pre.code, 0) << pre.err;
  CommandRun relit = run("relight " + prt + " -o " + (dir / "a.pfm").string() +
                         " --emission light=34,24,8 --report " + (dir / "rel.json").string());
  ASSERT_EQ(relit.code, 0) << relit.err;
  const JsonValue report = test::read_json(dir / "rel.json");
  ASSERT_NE(report.find("relight"), nullptr);
  ASSERT_NE(report.find("series"), nullptr);
  for (const char* key : {"product_seconds_median", "product_repeats", "bytes_touched", "emission"})
    EXPECT_NE(report.find("relight")->find(key), nullptr) << key;
  for (const char* key : {"order", "nnz", "bytes"})
    EXPECT_NE(report.find("series")->find("report")->find(key), nullptr) << key;

  EXPECT_EQ(
      run("relight " + prt + " -o " + (dir / "b.exr").string() + " --emission lamp=1,1,1").code, 2);
  EXPECT_EQ(
      run("relight " + prt + " -o " + (dir / "b.exr").string() + " --emission light=1,1").code, 2);
  EXPECT_EQ(
      run("relight " + prt + " -o " + (dir / "b.exr").string() + " --emission light=-1,1,1").code,
      2);
  // The scene changes: the operator is stale.
  text.replace(text.find("0.725, 0.71, 0.68"), 17, "0.700, 0.71, 0.68");
  test::write_file(dir, "box.json", text);
  CommandRun stale = run("relight " + prt + " -o " + (dir / "c.exr").string());
  EXPECT_EQ(stale.code, 2);
  EXPECT_NE(stale.err.find("stale"), std::string::npos) << stale.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "c.exr"));
  // A damaged file is refused.
  std::string damaged = test::write_file(dir, "damaged.prt", "POLYRADQ garbage");
  EXPECT_EQ(run("relight " + damaged + " -o " + (dir / "d.exr").string()).code, 2);
}

// `--output view|solution` picks the rows; relighting either must give the same picture: a
// solution operator keeps the mesh's direct light its gather reads (the lamps' images in the
// mirrors and their chains, --indirect mesh), so relight builds the gather render does.
TEST(Cli, SolutionRowsRelightLikeViewRows) {
  auto dir = test::temp_dir();
  const std::string view = (dir / "view.prt").string(), sol = (dir / "sol.prt").string();
  const std::string a = (dir / "v.pfm").string(), b = (dir / "s.pfm").string();
  const auto alike = [&](const std::string& scene, const std::string& flags,
                         const std::string& emission) {
    SCOPED_TRACE(scene + flags);
    const std::string pre = "precompute " + test::scene_path(scene) + " --order 12" + flags;
    ASSERT_EQ(run(pre + " -o " + view + " --output view").code, 0);
    ASSERT_EQ(run(pre + " -o " + sol + " --output solution").code, 0);
    ASSERT_EQ(run("relight " + view + " -o " + a + " --emission " + emission).code, 0);
    const CommandRun relit = run("relight " + sol + " -o " + b + " --emission " + emission);
    ASSERT_EQ(relit.code, 0) << relit.err;
    const Image x = read_image(a), y = read_image(b);
    ASSERT_EQ(x.rgb.size(), y.rgb.size());
    double sum = 0.0, diff = 0.0;
    for (size_t k = 0; k < x.rgb.size(); ++k) {
      sum += y.rgb[k];
      diff += std::abs(x.rgb[k] - y.rgb[k]);
    }
    EXPECT_GT(sum, 0.0);
    EXPECT_LT(diff / sum, 1e-5);  // the same sums in another order: float rounding only
  };
  alike("cornell-box", kQuickGather, "light=8,8,8");
  // Without the mesh's direct light kept, the solution's image differed by 20 percent here.
  const std::string chains = " --mirror-image-depth 4" + kQuickGather;
  alike("stability/mirrored-room", chains, "lamp=2,3,5");
  alike("stability/mirrored-room", chains + " --indirect mesh", "lamp=2,3,5");
  EXPECT_EQ(
      run("precompute " + test::scene_path("cornell-box") + " -o " + sol + " --output pixels").code,
      2);
}

// A solution operator written before polyrad kept the mesh's direct light in it (its header
// without "mesh_direct"; the sections it names are then unread) still relights, as it did then,
// without the lamps' mirror images, and says so.
TEST(Cli, OlderSolutionFilesRelightWithoutTheMirrorImagesAndSaySo) {
  auto dir = test::temp_dir();
  const std::string prt = (dir / "s.prt").string(), img = (dir / "s.pfm").string(),
                    rep = (dir / "s.json").string();
  ASSERT_EQ(run("precompute " + test::scene_path("stability/mirrored-room") + " -o " + prt +
                " --output solution --order 8 --mirror-image-depth 2" + kQuickGather)
                .code,
            0);
  CommandRun r = run("relight " + prt + " -o " + img);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  std::string bytes = test::read_text(prt);
  const std::size_t from = bytes.find("\"mesh_direct\""), to = bytes.find('}', from);
  ASSERT_NE(from, std::string::npos);
  std::fill(bytes.begin() + static_cast<std::ptrdiff_t>(from),
            bytes.begin() + static_cast<std::ptrdiff_t>(to) + 2, ' ');  // its comma too
  const std::uint64_t sum = checksum64(bytes.data(), bytes.size() - 8);
  std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
  test::write_file(dir, "s.prt", bytes);
  r = run("relight " + prt + " -o " + img + " --report " + rep);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("precompute it again"), std::string::npos) << r.err;
  const JsonValue report = test::read_json(rep);
  ASSERT_EQ(report.find("warnings")->array.size(), 1u);
  EXPECT_EQ(report.find("warnings")->array[0].find("kind")->string,
            "operator_without_mirror_images");
  EXPECT_EQ(report.find("gather")->find("options")->find("mirror_image_samples")->number, 0.0);
}

TEST(Cli, ReorderFlagIsReportedAndBadValuesAreExitTwo) {
  auto dir = test::temp_dir();
  const std::string scene = test::scene_path("cornell-box"), prt = (dir / "r.prt").string(),
                    rep = (dir / "r.json").string();
  CommandRun ok = run("precompute " + scene + " -o " + prt +
                      " --patch-size 200 --order 3 --reorder rcm --report " + rep + kQuickGather);
  ASSERT_EQ(ok.code, 0) << ok.err;
  const JsonValue report = test::read_json(rep);
  ASSERT_NE(report.find("series"), nullptr);
  const JsonValue& series = *report.find("series")->find("report");
  ASSERT_NE(series.find("reorder"), nullptr);
  EXPECT_EQ(series.find("reorder")->string, "rcm");
  for (const char* key : {"bandwidth_before", "bandwidth_after", "reorder_seconds"})
    EXPECT_NE(series.find(key), nullptr) << key;
  EXPECT_LE(series.find("bandwidth_after")->number, series.find("bandwidth_before")->number);
  for (const std::string& args :
       {"precompute " + scene + " -o " + (dir / "x.prt").string() + " --reorder metis",
        "precompute " + scene + " -o " + (dir / "x.prt").string() + " --reorder",
        "render " + scene + " --method series -o " + (dir / "x.pfm").string() + " --reorder RCM",
        // A valid value the system cannot honour: refused before the scene is built.
        "precompute " + scene + " -o " + (dir / "x.prt").string() +
            " --reorder rcm --specular-on-the-fly",
        "render " + scene + " --method series -o " + (dir / "x.pfm").string() +
            " --reorder rcm --specular-on-the-fly"}) {
    CommandRun bad = run(args);
    EXPECT_EQ(bad.code, 2) << args << "\n" << bad.err;
    EXPECT_EQ(lines(bad.err), 1u) << bad.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.prt"));
  EXPECT_FALSE(std::filesystem::exists(dir / "x.pfm"));
}

// Every field of the operator's record, as precompute reported it, is what relight reads back
// from the file: one serialisation for the header and the reports, whatever the options.
void expect_same_json(const JsonValue& a, const JsonValue& b, const std::string& where) {
  ASSERT_EQ(a.kind, b.kind) << where;
  switch (a.kind) {
    case JsonValue::Kind::kNumber:
      EXPECT_EQ(a.number, b.number) << where;
      break;
    case JsonValue::Kind::kString:
      EXPECT_EQ(a.string, b.string) << where;
      break;
    case JsonValue::Kind::kBool:
      EXPECT_EQ(a.boolean, b.boolean) << where;
      break;
    case JsonValue::Kind::kArray:
      ASSERT_EQ(a.array.size(), b.array.size()) << where;
      for (size_t k = 0; k < a.array.size(); ++k)
        expect_same_json(a.array[k], b.array[k], where + "[" + std::to_string(k) + "]");
      break;
    case JsonValue::Kind::kObject:
      ASSERT_EQ(a.object.size(), b.object.size()) << where;
      for (size_t k = 0; k < a.object.size(); ++k) {
        EXPECT_EQ(a.object[k].first, b.object[k].first) << where;
        expect_same_json(a.object[k].second, b.object[k].second, where + "." + a.object[k].first);
      }
      break;
    case JsonValue::Kind::kNull:
      break;
  }
}

TEST(Cli, EveryPrecomputeOptionRoundTripsThroughTheFileIntoRelightsReport) {
  auto dir = test::temp_dir();
  const std::string scene = test::scene_path("cornell-box");
  // The patch gather on the uniform mesh keeps this quick (one variant on the hierarchy, the
  // patch gather's own mesh); one variant takes a small final gather, whose counts the header
  // records too.
  const std::vector<std::string> variants = {
      "--acceleration chebyshev --gather patch --mesh uniform",
      "--acceleration none --order 3 --gather patch --mesh uniform",
      "--basis object --gather patch",
      "--output solution --order 4 --gather patch",
      "--precision half --gather patch --mesh uniform",
      "--reorder rcm --order 3 --gather patch",
      "--basis object --output solution --precision half --acceleration chebyshev --reorder rcm "
      "--gather final --pixel-grid 1 --gather-samples 4 --light-samples 4 --near-samples 1"};
  int n = 0;
  for (const std::string& v : variants) {
    const std::string prt = (dir / ("v" + std::to_string(n) + ".prt")).string();
    const std::string pre = (dir / ("p" + std::to_string(n) + ".json")).string();
    const std::string rel = (dir / ("r" + std::to_string(n) + ".json")).string();
    ++n;
    CommandRun a =
        run("precompute " + scene + " --patch-size 150 -o " + prt + " " + v + " --report " + pre);
    ASSERT_EQ(a.code, 0) << v << "\n" << a.err;
    CommandRun b = run("relight " + prt + " -o " + (dir / "x.pfm").string() + " --report " + rel);
    ASSERT_EQ(b.code, 0) << v << "\n" << b.err;
    const JsonValue p = test::read_json(pre), r = test::read_json(rel);
    ASSERT_NE(p.find("series"), nullptr);
    ASSERT_NE(r.find("series"), nullptr);
    expect_same_json(*p.find("series"), *r.find("series"), v + ": series");
  }
  // What the file once lost: a Chebyshev operator read back as a plain series.
  const JsonValue cheb = test::read_json(dir / "r0.json");
  const JsonValue& rep = *cheb.find("series")->find("report");
  EXPECT_EQ(rep.find("acceleration")->string, "chebyshev");
  EXPECT_GT(rep.find("residual_bound")->number, 0.0);
}

double relative_l1(const std::string& a, const std::string& b) {
  Image x = read_image(a), y = read_image(b);
  EXPECT_EQ(x.rgb.size(), y.rgb.size());
  double sum = 0.0, diff = 0.0;
  for (size_t k = 0; k < x.rgb.size() && k < y.rgb.size(); ++k) {
    sum += std::abs(y.rgb[k]);
    diff += std::abs(x.rgb[k] - y.rgb[k]);
  }
  return diff / sum;
}

TEST(Cli, PrecomputeTakesTheGatherFlagsOfRender) {
  // The gather a view operator folds in (and the one a solution operator's relight builds) is
  // the one `render` would use with the same flags; and a solution operator made with
  // --patch-size is meshed again at that size when it is relit.
  auto dir = test::temp_dir();
  const std::string scene = test::scene_path("cornell-glossy") + " --patch-size 150";
  const std::string gather =
      " --lobe-samples 4 --light-samples 1 --diffuse flat --pixel-grid 1 --gather-samples 4"
      " --near-samples 1";
  // Every count doubled: another picture, so that the equalities below are not those of two
  // gathers that ignore their flags.
  const std::string other =
      " --lobe-samples 8 --light-samples 2 --diffuse flat --pixel-grid 1 --gather-samples 8"
      " --near-samples 2";
  const std::string view = (dir / "v.prt").string(), sol = (dir / "s.prt").string(),
                    plain = (dir / "p.prt").string();
  ASSERT_EQ(run("precompute " + scene + " -o " + view + " --tolerance 1e-6" + gather).code, 0);
  ASSERT_EQ(
      run("precompute " + scene + " -o " + sol + " --tolerance 1e-6 --output solution" + gather)
          .code,
      0);
  ASSERT_EQ(run("precompute " + scene + " -o " + plain + " --tolerance 1e-6" + other).code, 0);
  const std::string v = (dir / "v.pfm").string(), s = (dir / "s.pfm").string(),
                    p = (dir / "p.pfm").string(), r = (dir / "r.pfm").string();
  ASSERT_EQ(run("relight " + view + " -o " + v).code, 0);
  ASSERT_EQ(run("relight " + sol + " -o " + s).code, 0);
  ASSERT_EQ(run("relight " + plain + " -o " + p).code, 0);
  ASSERT_EQ(run("render " + scene + " --tolerance 1e-8 -o " + r + gather).code, 0);
  EXPECT_LT(relative_l1(v, r), 1e-5);
  EXPECT_LT(relative_l1(s, r), 1e-5);
  EXPECT_GT(relative_l1(p, r), 1e-2);
  EXPECT_EQ(run("precompute " + scene + " -o " + view + " --light-samples -1").code, 2);
}

TEST(Cli, GatherFlagPicksTheKindAndTheReportSaysWhich) {
  // The final gather by default, the patch gather on request; the furnace reads E/(1-a) = 2
  // either way (within the final gather's noise at its default counts).
  auto dir = test::temp_dir();
  for (const char* kind : {"", "final", "patch"}) {
    const std::string img = (dir / "f.pfm").string(), rep = (dir / "f.json").string();
    const bool points = std::string(kind) == "final";  // and points on the reflectors (none here)
    const std::string flag = (*kind ? std::string(" --gather ") + kind : std::string()) +
                             (points ? " --reflector-samples 4 --through-mirrors never" : "");
    CommandRun r =
        run("render " + test::scene_path("furnace") + " -o " + img + " --report " + rep + flag);
    ASSERT_EQ(r.code, 0) << r.err;
    const JsonValue report = test::read_json(rep);
    ASSERT_NE(report.find("gather"), nullptr);
    const JsonValue* options = report.find("gather")->find("options");
    EXPECT_EQ(options->find("kind")->string, *kind ? kind : "final");
    const double expected_points = points ? 4.0 : *kind ? 0.0 : 64.0;  // the final gather's default
    EXPECT_EQ(options->find("reflector_samples")->number, expected_points);
    // No mirror in the furnace: no images drawn, and the report says so.
    EXPECT_EQ(options->find("mirror_image_samples")->number, 0.0);
    EXPECT_EQ(options->find("through_mirrors")->string, points ? "never" : "imaged");
    Image image = read_image(img);
    for (float v : image.rgb) ASSERT_NEAR(v, 2.0, 0.04);
  }
  EXPECT_EQ(run("render " + test::scene_path("furnace") + " -o " + (dir / "x.pfm").string() +
                " --gather photon")
                .code,
            2);
  EXPECT_EQ(run("render " + test::scene_path("furnace") + " -o " + (dir / "x.pfm").string() +
                " --through-mirrors sometimes")
                .code,
            2);
  EXPECT_EQ(run("render " + test::scene_path("furnace") + " -o " + (dir / "x.pfm").string() +
                " --mirror-images -1")
                .code,
            2);
  EXPECT_EQ(run("render " + test::scene_path("furnace") + " -o " + (dir / "x.pfm").string() +
                " --reflector-samples -1")
                .code,
            2);
}

TEST(Cli, MeshNearFlagsReachTheGatherWithTheIndirectLightFromTheMesh) {
  // The report gives what the gather drew: the mesh's near points with --indirect mesh (2
  // diameters and 64 cosine samples by default, or as given), none where rays read the mesh
  // anyway (the same image as without the flag). In the furnace's small box nearly every point
  // is near a wall, so the near points' cosine samples add rays to the mesh read everywhere.
  auto dir = test::temp_dir();
  const std::string furnace = test::scene_path("furnace");
  struct Case {
    std::string flags;
    double distance, samples;
    std::string read = "smooth";
  };
  const std::vector<Case> cases = {
      {" --indirect mesh --mesh-near-distance 0", 0.0, 64.0},
      {" --indirect mesh", 2.0, 64.0},
      {" --indirect mesh --mesh-near-distance 0.5 --mesh-near-samples 100 --mesh-read flat", 0.5,
       100.0, "flat"},
      {"", 0.0, 64.0},
      {" --mesh-near-distance 0.5", 0.0, 64.0}};
  std::vector<double> rays;
  std::vector<std::string> bytes;
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const Case& c = cases[k];
    const std::string img = (dir / ("n" + std::to_string(k) + ".pfm")).string(),
                      rep = (dir / "n.json").string();
    CommandRun r = run("render " + furnace + " -o " + img + " --report " + rep + c.flags);
    ASSERT_EQ(r.code, 0) << r.err;
    const JsonValue report = test::read_json(rep);
    const JsonValue* gather = report.find("gather");
    const JsonValue* options = gather->find("options");
    EXPECT_EQ(options->find("mesh_near_distance")->number, c.distance) << c.flags;
    EXPECT_EQ(options->find("mesh_near_samples")->number, c.samples) << c.flags;
    EXPECT_EQ(options->find("mesh_read")->string, c.read) << c.flags;
    rays.push_back(gather->find("rays")->number);
    bytes.push_back(test::read_text(img));
    // E / (1 - a) = 2 on average: every face emits, so with --indirect mesh the direct light is
    // the whole sky, read by 32 light points against 16 cosine samples (or, at the near points,
    // 64), and the pixels spread by about 2 percent.
    const Image image = read_image(img);
    double mean = 0.0;
    for (float v : image.rgb) mean += v / static_cast<double>(image.rgb.size());
    EXPECT_NEAR(mean, 2.0, 2e-3) << c.flags;
  }
  EXPECT_GT(rays[1], 2.0 * rays[0]);
  EXPECT_EQ(bytes[3], bytes[4]);
  for (const char* bad : {" --mesh-near-distance -1", " --mesh-near-distance nan",
                          " --mesh-near-samples 0", " --mesh-read sharp"})
    EXPECT_EQ(
        run("render " + furnace + " -o " + (dir / "x.pfm").string() + " --indirect mesh" + bad)
            .code,
        2)
        << bad;
}

TEST(Cli, LinkToleranceFollowsTheGatherUnlessGiven) {
  // A hierarchical mesh behind the final gather links more coarsely than behind the patch
  // gather, which reads the leaves at every pixel; a tolerance given wins over both.
  auto dir = test::temp_dir();
  const std::string img = (dir / "f.pfm").string(), rep = (dir / "f.json").string(),
                    prt = (dir / "f.prt").string();
  struct Case {
    std::string command, flags;
    double tau;
  };
  const Case cases[] = {
      {"render", "", link_tolerance_for(GatherKind::kFinal)},
      {"render", " --gather patch", link_tolerance_for(GatherKind::kPatch)},
      {"render", " --gather patch --link-tolerance 0.2", 0.2},
      {"precompute", "", link_tolerance_for(GatherKind::kFinal)},
      // The indirect light from the mesh reads the leaves at every pixel, as the patch gather.
      {"render", " --indirect mesh", link_tolerance_for(GatherKind::kPatch)},
      {"precompute", " --indirect mesh", link_tolerance_for(GatherKind::kPatch)},
  };
  EXPECT_GT(link_tolerance_for(GatherKind::kFinal), link_tolerance_for(GatherKind::kPatch));
  for (const Case& c : cases) {
    const std::string out = c.command == "render" ? img : prt;
    CommandRun r = run(c.command + " " + test::scene_path("furnace") + " -o " + out + " --report " +
                       rep + " --mesh hierarchical" + kQuickGather + c.flags);
    ASSERT_EQ(r.code, 0) << c.command << c.flags << ": " << r.err;
    const JsonValue report = test::read_json(rep);
    const JsonValue* h = report.find("system")->find("hierarchy");
    ASSERT_NE(h, nullptr) << c.command << c.flags;
    ASSERT_NE(h->find("link_tolerance"), nullptr) << c.command << c.flags;
    EXPECT_EQ(h->find("link_tolerance")->number, c.tau) << c.command << c.flags;
  }
}

TEST(Cli, MeshFollowsTheGatherUnlessGiven) {
  // Where the pixels read the mesh (the patch gather) it is hierarchical; behind the final
  // gather, and wherever rows need the uniform mesh's patches, uniform; a mesh given wins, and
  // a hierarchy's own option given alone asks for the hierarchy.
  auto dir = test::temp_dir();
  const std::string img = (dir / "m.pfm").string(), rep = (dir / "m.json").string(),
                    prt = (dir / "m.prt").string();
  struct Case {
    std::string command, flags, mesh;
  };
  const Case cases[] = {
      {"render", "", "uniform"},
      {"render", " --indirect mesh", "uniform"},
      {"render", " --mesh hierarchical", "hierarchical"},
      // A hierarchy's own option asks for it, unless --mesh says otherwise.
      {"render", " --link-tolerance 0.1", "hierarchical"},
      {"render", " --refine-passes 0", "hierarchical"},
      {"render", " --min-element-size 0.5", "hierarchical"},
      {"render", " --mirror-links true", "hierarchical"},
      {"render", " --refine-passes 0 --mesh uniform", "uniform"},
      {"render", " --gather patch", "hierarchical"},
      {"render", " --gather patch --mesh uniform", "uniform"},
      {"render", " --gather patch --specular-on-the-fly", "uniform"},
      {"render", " --gather patch --method series", "hierarchical"},
      {"render", " --gather patch --method series --reorder rcm", "uniform"},
      {"precompute", " --gather patch", "hierarchical"},
      {"precompute", " --gather patch --output solution", "uniform"},
      {"precompute", " --gather patch --reorder rcm", "uniform"},
  };
  for (const Case& c : cases) {
    const std::string out = c.command == "render" ? img : prt;
    CommandRun r = run(c.command + " " + test::scene_path("furnace") + " -o " + out + " --report " +
                       rep + kQuickGather + c.flags);
    ASSERT_EQ(r.code, 0) << c.command << c.flags << ": " << r.err;
    const JsonValue report = test::read_json(rep);
    EXPECT_EQ(report.find("system")->find("mesh")->string, c.mesh) << c.command << c.flags;
    EXPECT_EQ(report.find("system")->find("hierarchy") != nullptr, c.mesh == "hierarchical")
        << c.command << c.flags;
  }
}

// --mirror-links: the report counts the image links and the mirror planes they go through (the
// mirror cube's block: five faces), none without the flag; a value that is not a truth value is
// exit 2 with nothing written.
TEST(Cli, MirrorLinksAreCountedInTheReport) {
  auto dir = test::temp_dir();
  const std::string img = (dir / "i.pfm").string(), rep = (dir / "i.json").string();
  const std::string base = "render " + test::scene_path("cornell-mirror-cube") + " -o " + img +
                           " --report " + rep + kQuickGather +
                           " --gather patch --patch-size 100 --link-tolerance 0.2";
  for (bool on : {true, false}) {
    CommandRun r = run(base + (on ? " --mirror-links true" : ""));
    ASSERT_EQ(r.code, 0) << r.err;
    const JsonValue report = test::read_json(rep);
    const JsonValue* h = report.find("system")->find("hierarchy");
    ASSERT_NE(h, nullptr);
    EXPECT_EQ(h->find("mirror_planes")->number, on ? 5 : 0);
    if (on) {
      EXPECT_GT(h->find("image_links")->number, 0);
    } else {
      EXPECT_EQ(h->find("image_links")->number, 0);
    }
  }
  std::filesystem::remove(img);
  CommandRun bad = run(base + " --mirror-links maybe");
  EXPECT_EQ(bad.code, 2);
  EXPECT_FALSE(std::filesystem::exists(img));
}

// --indirect mesh: the report and the operator file say so, the render reports the mesh's
// direct light as a stage; what it cannot do is refused with exit 2 and no output.
TEST(Cli, IndirectFromTheMeshIsReportedAndItsLimitsAreExitTwo) {
  auto dir = test::temp_dir();
  const std::string scene = test::scene_path("cornell-box"), img = (dir / "m.pfm").string(),
                    rep = (dir / "m.json").string(), prt = (dir / "m.prt").string();
  CommandRun ok = run("render " + scene + " -o " + img + " --report " + rep +
                      " --patch-size 200 --indirect mesh" + kQuickGather);
  ASSERT_EQ(ok.code, 0) << ok.err;
  JsonValue report = test::read_json(rep);
  EXPECT_EQ(report.find("gather")->find("options")->find("indirect")->string, "mesh");
  EXPECT_NE(report.find("seconds")->find("mesh_direct"), nullptr);
  ok = run("precompute " + scene + " -o " + prt + " --report " + rep +
           " --patch-size 200 --order 3 --indirect mesh" + kQuickGather);
  ASSERT_EQ(ok.code, 0) << ok.err;
  CommandRun relit = run("relight " + prt + " -o " + img + " --report " + rep);
  ASSERT_EQ(relit.code, 0) << relit.err;
  report = test::read_json(rep);
  EXPECT_EQ(report.find("series")->find("gather")->find("indirect")->string, "mesh");
  std::filesystem::remove(img);
  for (const std::string& args :
       {"render " + scene + " -o " + img + " --indirect sideways",
        "render " + scene + " -o " + img + " --gather patch --indirect mesh",
        "render " + scene + " -o " + img + " --indirect mesh --light-samples 0"}) {
    CommandRun bad = run(args);
    EXPECT_EQ(bad.code, 2) << args << "\n" << bad.err;
    EXPECT_EQ(lines(bad.err), 1u) << bad.err;
  }
  EXPECT_FALSE(std::filesystem::exists(img));
}

TEST(Cli, RenderBySeriesMatchesIterative) {
  auto dir = test::temp_dir();
  std::string a = (dir / "s.pfm").string(), b = (dir / "i.pfm").string();
  ASSERT_EQ(run("render " + test::scene_path("cornell-mirror-cube") +
                " --method series --tolerance 1e-4 -o " + a + kQuickGather)
                .code,
            0);
  ASSERT_EQ(run("render " + test::scene_path("cornell-mirror-cube") + " --tolerance 1e-6 -o " + b +
                kQuickGather)
                .code,
            0);
  Image x = read_image(a), y = read_image(b);
  double sum = 0.0, diff = 0.0;
  for (size_t k = 0; k < x.rgb.size(); ++k) {
    sum += y.rgb[k];
    diff += std::abs(x.rgb[k] - y.rgb[k]);
  }
  EXPECT_LT(diff / sum, 2e-4);  // the image is a positive map of u: L1 error within the tolerance
}

}  // namespace
}  // namespace polyrad

namespace polyrad {
namespace {

std::vector<std::string> files_in(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    names.push_back(e.path().filename().string());
  return names;
}

TEST(Cli, InterruptedPrecomputeLeavesNothing) {
  auto dir = test::temp_dir();
  std::string prt = (dir / "big.prt").string();
  // A precompute of several seconds (fine patches), stopped by SIGTERM after one.
  std::string cmd = std::string(POLYRAD_CLI) + " --quiet precompute " +
                    test::scene_path("cornell-mirror-cube") + " --patch-size 15 -o " + prt +
                    " 2>/dev/null & pid=$!; sleep 1; kill -TERM $pid; wait $pid";
  int status = std::system(("sh -c '" + cmd + "'").c_str());
  EXPECT_NE(status, 0);
  EXPECT_TRUE(files_in(dir).empty())
      << files_in(dir).size() << " files left, first " << files_in(dir)[0];
}

TEST(Cli, FullDiskIsReportedAndLeavesNothing) {
  auto dir = test::temp_dir();
  std::string prt = (dir / "a.prt").string();
  // A file size limit of 64 KiB stands in for a full disk: the operator is megabytes.
  CommandRun r = run_shell("ulimit -f 128; " + std::string(POLYRAD_CLI) + " --quiet precompute " +
                           test::scene_path("cornell-box") + " -o " + prt + kQuickGather);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("cannot write"), std::string::npos) << r.err;
  EXPECT_TRUE(files_in(dir).empty() || files_in(dir) == std::vector<std::string>{"stderr.txt"});
}

}  // namespace
}  // namespace polyrad

namespace polyrad {
namespace {

// OpenImageIO lives in a module loaded for the first .exr or .png (io/image_codec.h): the
// program links none of its libraries, a run that writes only .pfm needs no module, and one that
// writes an .exr without it fails with where it looked, leaving nothing behind.
TEST(Cli, OnlyExrAndPngNeedTheImageCodecModule) {
  const CommandRun libraries = run_shell("ldd " + std::string(POLYRAD_CLI));
  ASSERT_EQ(libraries.code, 0) << libraries.err;
  EXPECT_NE(libraries.out.find("libembree3"), std::string::npos) << libraries.out;
  EXPECT_EQ(libraries.out.find("OpenImageIO"), std::string::npos) << libraries.out;

  auto dir = test::temp_dir();
  Image a(4, 3), b(4, 3);
  for (size_t k = 0; k < a.rgb.size(); ++k) a.rgb[k] = 0.5f + 0.01f * k, b.rgb[k] = 0.5f;
  const std::string pa = (dir / "a.pfm").string(), pb = (dir / "b.pfm").string();
  write_image(a, pa);
  write_image(b, pb);
  const std::string missing = (dir / "nowhere" / "libcodec.so").string();
  const std::string without = "POLYRAD_IMAGE_CODEC=" + missing + " " + POLYRAD_CLI +
                              " --quiet compare " + pa + " " + pb + " --heatmap ";
  const CommandRun pfm = run_shell(without + (dir / "h.pfm").string());
  EXPECT_EQ(pfm.code, 0) << pfm.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "h.pfm"));

  const CommandRun exr = run_shell(without + (dir / "h.exr").string());
  EXPECT_EQ(exr.code, 1) << exr.err;
  EXPECT_NE(exr.err.find("image codec module"), std::string::npos) << exr.err;
  EXPECT_NE(exr.err.find(missing + ": not there"), std::string::npos) << exr.err;
  std::vector<std::string> names = files_in(dir);
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"a.pfm", "b.pfm", "h.pfm"}));

  // Found by itself, beside the program: the same command writes the .exr, which reads back.
  const CommandRun found = run("compare " + pa + " " + pb + " --heatmap " + (dir / "h.exr").string());
  ASSERT_EQ(found.code, 0) << found.err;
  const Image heat = read_image((dir / "h.exr").string());
  EXPECT_EQ(heat.width, a.width);
  EXPECT_EQ(heat.height, a.height);
}

}  // namespace
}  // namespace polyrad
