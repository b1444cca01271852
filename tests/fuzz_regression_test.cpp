// Replays the fuzz seeds (fuzz/corpus) and every saved finding (fuzz/regressions) through the
// same code as the libFuzzer targets (fuzz/fuzz_inputs.h): bad input may throw InputError and
// nothing else may escape. Under the sanitizer build (build/asan in scripts/test.sh) a memory
// error or undefined behaviour in any of them fails the run too. See docs/testing.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <typeinfo>
#include <vector>

#include "fuzz_inputs.h"
#include "polyrad/error.h"

namespace polyrad {
namespace {

namespace fs = std::filesystem;

using Run = void (*)(const std::string&);

// The input files of fuzz/<folder>, sorted; a missing folder has none.
std::vector<fs::path> inputs_in(const std::string& folder) {
  fs::path dir = fs::path(POLYRAD_FUZZ_DIR) / folder;
  std::vector<fs::path> files;
  if (!fs::is_directory(dir)) return files;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file() && entry.path().filename() != "README.md")
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << "cannot open " << path;
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

enum class Outcome { kAccepted, kInputError, kOther };

// Runs one input; anything but success or InputError is a test failure naming the file.
Outcome replay(Run run, const fs::path& path) {
  std::string bytes = read_bytes(path);
  try {
    run(bytes);
    return Outcome::kAccepted;
  } catch (const InputError&) {
    return Outcome::kInputError;
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": " << typeid(e).name() << " escaped instead of InputError: "
                  << e.what();
  } catch (...) {
    ADD_FAILURE() << path << ": a non-standard exception escaped instead of InputError";
  }
  return Outcome::kOther;
}

// Seeds: files named invalid_* must be refused with InputError, the others accepted.
void replay_corpus(const std::string& folder, Run run) {
  auto files = inputs_in(folder);
  ASSERT_FALSE(files.empty()) << "no seeds in fuzz/" << folder;
  for (const auto& path : files) {
    bool invalid = path.filename().string().rfind("invalid_", 0) == 0;
    Outcome got = replay(run, path);
    if (got == Outcome::kOther) continue;
    EXPECT_EQ(got, invalid ? Outcome::kInputError : Outcome::kAccepted)
        << path << (invalid ? " should be refused" : " should be accepted");
  }
}

// Findings: whatever the outcome, only InputError may escape.
void replay_findings(const std::string& folder, Run run) {
  for (const auto& path : inputs_in(folder)) replay(run, path);
}

TEST(FuzzRegression, SceneSeeds) { replay_corpus("corpus/scene", fuzz::scene_input); }
TEST(FuzzRegression, ObjSeeds) { replay_corpus("corpus/obj", fuzz::obj_input); }
TEST(FuzzRegression, SceneFindings) { replay_findings("regressions/scene", fuzz::scene_input); }
TEST(FuzzRegression, ObjFindings) { replay_findings("regressions/obj", fuzz::obj_input); }

}  // namespace
}  // namespace polyrad
