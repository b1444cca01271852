// Replays the fuzz seeds (fuzz/corpus) and every saved finding (fuzz/regressions) through the
// same code as the libFuzzer targets (fuzz/fuzz_inputs.h): bad input may throw InputError and
// nothing else may escape. The .prt loader's seeds follow the file format of the day, so they are
// made here, by this polyrad, and damaged in many small ways. Under the sanitizer build
// (build/asan in scripts/test.sh) a memory error or undefined behaviour in any of them fails the
// run too. See docs/testing.md.
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
#include "polyrad/io/prt_file.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/error.h"
#include "test_support.h"

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

// Runs one input; anything but success or InputError is a test failure naming the input.
Outcome replay_bytes(Run run, const std::string& bytes, const std::string& what) {
  try {
    run(bytes);
    return Outcome::kAccepted;
  } catch (const InputError&) {
    return Outcome::kInputError;
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": " << typeid(e).name()
                  << " escaped instead of InputError: " << e.what();
  } catch (...) {
    ADD_FAILURE() << what << ": a non-standard exception escaped instead of InputError";
  }
  return Outcome::kOther;
}

Outcome replay(Run run, const fs::path& path) {
  return replay_bytes(run, read_bytes(path), path.string());
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
TEST(FuzzRegression, PrtFindings) { replay_findings("regressions/prt", fuzz::prt_input); }

// The bytes of a .prt file that this polyrad writes for the fuzz seed scene.
std::string prt_bytes(const RadiositySystem& sys, const Gather& gather, const SeriesOptions& o) {
  SeriesOperator q = precompute_series(sys.transport, *sys.world, o,
                                       o.output == SeriesOutput::kView ? &gather : nullptr);
  std::string path = (test::temp_dir() / "seed.prt").string();
  write_prt(q, path);
  return read_bytes(path);
}

// read_prt_bytes on an aligned copy, without the checksum repair of fuzz::prt_input.
Outcome read_as_is(const std::string& bytes, const std::string& what) {
  return replay_bytes(
      [](const std::string& b) {
        fuzz::AlignedBytes file(b);
        SeriesOperator q = read_prt_bytes(file.data, file.size, "damaged.prt");
      },
      bytes, what);
}

// The seeds scripts/fuzz.sh writes with `polyrad precompute`, made here in-process in the
// layouts, precisions and bases there are: each must be accepted. Then each is cut short at many
// lengths and has every byte changed in turn (one at a time). Without the checksum repaired,
// every such file must be refused; with it (fuzz::prt_input), refused with InputError or accepted
// as a consistent operator, and nothing else.
TEST(FuzzRegression, PrtSeedsAndTheirDamage) {
  auto sys = build_system(World::load(std::string(POLYRAD_FUZZ_DIR) + "/prt_seed_scene.json"));
  Gather gather = build_gather(*sys->world, sys->transport.layout());
  struct Variant {
    SeriesOutput output;
    ValuePrecision precision;
    SeriesBasis basis;
    double drop;
    IndirectMode indirect = IndirectMode::kRays;
  };
  const Variant variants[] = {
      {SeriesOutput::kView, ValuePrecision::kFloat, SeriesBasis::kPatch, 0.0},
      {SeriesOutput::kView, ValuePrecision::kHalf, SeriesBasis::kObject, 0.0},
      {SeriesOutput::kSolution, ValuePrecision::kFloat, SeriesBasis::kPatch, 0.3},
      {SeriesOutput::kSolution, ValuePrecision::kHalf, SeriesBasis::kObject, 0.0},
      {SeriesOutput::kSolution, ValuePrecision::kFloat, SeriesBasis::kObject, 0.0,
       IndirectMode::kMesh},
  };
  bool dense = false, sparse = false, links = false, direct = false;
  for (const Variant& v : variants) {
    SeriesOptions o;
    o.order = 3;
    o.output = v.output;
    o.precision = v.precision;
    o.basis = v.basis;
    o.drop = v.drop;
    if (v.indirect == IndirectMode::kMesh) {  // as polyrad precompute takes it by default
      o.gather = GatherOptions::final_gather();
      o.gather.indirect = v.indirect;
    }
    o.progress = false;
    const std::string bytes = prt_bytes(*sys, gather, o);
    const std::string name = std::string(enum_name(v.output)) + "-" + enum_name(v.precision) + "-" +
                             enum_name(v.basis) + "-" + enum_name(v.indirect);
    ASSERT_EQ(replay_bytes(fuzz::prt_input, bytes, name), Outcome::kAccepted) << name;
    {
      fuzz::AlignedBytes file(bytes);
      SeriesOperator q = read_prt_bytes(file.data, file.size, name);
      (q.dense() ? dense : sparse) = true;
      links = links || !q.layout.links.empty();
      direct = direct || (q.direct && q.direct->has_links() && !q.direct->mirrored.empty());
    }
    for (std::size_t n = 0; n < bytes.size(); n += n < 64 ? 1 : 37) {
      const std::string cut = bytes.substr(0, n), what = name + " cut to " + std::to_string(n);
      EXPECT_EQ(read_as_is(cut, what), Outcome::kInputError) << what;
      replay_bytes(fuzz::prt_input, cut, what);
    }
    const unsigned char patterns[3] = {0x01, 0x80, 0xff};
    for (std::size_t at = 0; at < bytes.size(); ++at) {
      std::string damaged = bytes;
      const unsigned char p = patterns[at % 3];
      damaged[at] = static_cast<char>(p == 0xff ? 0xff : damaged[at] ^ p);
      if (damaged == bytes) continue;
      const std::string what = name + " with byte " + std::to_string(at) + " changed";
      EXPECT_EQ(read_as_is(damaged, what), Outcome::kInputError) << what;
      replay_bytes(fuzz::prt_input, damaged, what);
    }
  }
  EXPECT_TRUE(dense && sparse && links && direct)
      << "the seeds should cover both layouts, the links and the mesh's direct light";
}

}  // namespace
}  // namespace polyrad
