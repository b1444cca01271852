// The command line as a user meets it: exit codes, one-line errors, no partial outputs.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "polyrad/json.h"
#include "test_support.h"

namespace polyrad {
namespace {

struct CliRun {
  int code;
  std::string err;
};

CliRun run(const std::string& args) {
  auto dir = test::temp_dir();
  std::string err_file = (dir / "stderr.txt").string();
  std::string cmd = std::string(POLYRAD_CLI) + " --quiet " + args + " 2>" + err_file + " >/dev/null";
  int status = std::system(cmd.c_str());
  std::ifstream in(err_file);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

size_t lines(const std::string& s) {
  size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

TEST(Cli, RenderWritesImageReportAndPatchTable) {
  auto dir = test::temp_dir();
  std::string img = (dir / "cb.exr").string(), rep = (dir / "r.json").string(),
              csv = (dir / "p.csv").string();
  CliRun r = run("render " + test::scene_path("cornell-box") + " -o " + img + " --report " + rep +
              " --patches " + csv + " --method iterative --tolerance 1e-4");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(img));
  std::ifstream rin(rep);
  std::stringstream rs;
  rs << rin.rdbuf();
  JsonValue report = parse_json(rs.str(), rep);
  for (const char* key : {"patches", "unknowns", "iterations", "residual", "seconds",
                          "peak_memory_bytes", "form_factors"})
    EXPECT_NE(report.find(key), nullptr) << key;
  EXPECT_LT(report.find("residual")->number, 1e-4);
  EXPECT_GT(report.find("peak_memory_bytes")->number, 1e6);
  EXPECT_NE(report.find("seconds")->find("form_factors"), nullptr);
  std::ifstream cin(csv);
  std::string header;
  std::getline(cin, header);
  EXPECT_EQ(header, "patch,object,area,cx,cy,cz,nx,ny,nz,r,g,b");
  size_t rows = 0;
  for (std::string line; std::getline(cin, line);) ++rows;
  EXPECT_EQ(static_cast<double>(rows), report.find("patches")->number);
}

TEST(Cli, BadInputIsExitTwoWithOneLineAndNoOutput) {
  auto dir = test::temp_dir();
  std::string img = (dir / "x.png").string();
  std::string bad = test::write_file(dir, "bad.json", "{\"camera\": 3}");
  for (const std::string& args : std::vector<std::string>
       {"render " + bad + " -o " + img, "render " + dir.string() + "/none.json -o " + img,
        "render " + test::scene_path("cornell-box") + " -o " + (dir / "x.bmp").string(),
        "render " + test::scene_path("cornell-box") + " -o " + (dir / "no" / "x.png").string(),
        "render " + test::scene_path("cornell-box") + " -o " + img + " --tolerance -1",
        "render " + test::scene_path("cornell-box") + " -o " + img + " --method magic",
        "render " + test::scene_path("cornell-box"), "frobnicate", ""}) {
    CliRun r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
    EXPECT_EQ(lines(r.err), 1u) << args << "\n" << r.err;
  }
  CliRun r = run("render " + bad + " -o " + img);
  EXPECT_NE(r.err.find("bad.json:1:"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(img));
}

TEST(Cli, DivergenceIsExitThreeAndWritesNothing) {
  auto dir = test::temp_dir();
  std::string scene = test::write_file(
      dir, "hot.json",
      test::closed_box_json(Vec3(1, 1, 1), 0.5, R"({"type": "diffuse", "reflectance": [1.3, 1.3, 1.3]})", 1.0));
  std::string img = (dir / "hot.exr").string();
  CliRun safe = run("render " + scene + " -o " + img);
  EXPECT_EQ(safe.code, 2) << safe.err;  // refused at load without the unsafe flag
  CliRun r = run("render " + scene + " -o " + img + " --allow-unsafe-albedo --report " +
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
