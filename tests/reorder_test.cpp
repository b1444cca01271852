// Reverse Cuthill-McKee (reorder.h) and the series precompute on the renumbered operator: the
// ordering is a permutation that narrows the band, and Q does not change.
#include "polyrad/transport/reorder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <stdexcept>

#include "polyrad/io/prt_file.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/transport/system.h"
#include "polyrad/util/hash.h"
#include "test_support.h"

namespace polyrad {
namespace {

// A square pattern from (row, column) pairs; values 1.
Csr<float> pattern(std::int64_t n, std::vector<std::pair<std::int32_t, std::int32_t>> entries) {
  std::sort(entries.begin(), entries.end());
  Csr<float> m;
  m.cols = n;
  std::size_t k = 0;
  for (std::int64_t r = 0; r < n; ++r) {
    for (; k < entries.size() && entries[k].first == r; ++k) {
      m.column.push_back(entries[k].second);
      m.value.push_back(1.0f);
    }
    m.push_row();
  }
  return m;
}

void expect_permutation(const Permutation& p, std::int64_t n) {
  ASSERT_EQ(p.size(), n);
  std::vector<std::int32_t> sorted = p.order;
  std::sort(sorted.begin(), sorted.end());
  for (std::int64_t k = 0; k < n; ++k) ASSERT_EQ(sorted[k], k);  // each index once
  for (std::int64_t k = 0; k < n; ++k) ASSERT_EQ(p.position[p.order[k]], k);
}

std::vector<std::int32_t> scrambled(std::int32_t n, unsigned seed) {
  std::vector<std::int32_t> label(n);
  std::iota(label.begin(), label.end(), 0);
  std::shuffle(label.begin(), label.end(), std::mt19937(seed));
  return label;
}

TEST(Reorder, PermutationRefusesRepeatsAndGaps) {
  EXPECT_NO_THROW(Permutation::from_order({2, 0, 1}));
  EXPECT_THROW(Permutation::from_order({0, 0, 1}), std::invalid_argument);
  EXPECT_THROW(Permutation::from_order({0, 3, 1}), std::invalid_argument);
  EXPECT_THROW(Permutation::from_order({0, -1, 1}), std::invalid_argument);
}

TEST(Reorder, ScrambledPathGetsBandwidthOne) {
  // The path 0 - 1 - ... - n-1, its nodes labelled at random and each edge stored one way only
  // (the ordering must symmetrise), with the diagonal (which it must ignore).
  const std::int32_t n = 200;
  std::vector<std::int32_t> label = scrambled(n, 7);
  std::vector<std::pair<std::int32_t, std::int32_t>> entries;
  for (std::int32_t v = 0; v < n; ++v) entries.push_back({label[v], label[v]});
  for (std::int32_t v = 0; v + 1 < n; ++v) entries.push_back({label[v + 1], label[v]});
  Csr<float> m = pattern(n, entries);
  Permutation p = reverse_cuthill_mckee(m);
  expect_permutation(p, n);
  EXPECT_GT(bandwidth(m), n / 2);
  EXPECT_EQ(bandwidth(m, p), 1);
}

TEST(Reorder, EveryComponentAndIsolatedNodeIsPlacedOnce) {
  // Two scrambled paths, a star, and isolated nodes; and the same ordering twice.
  const std::int32_t n = 60;
  std::vector<std::int32_t> label = scrambled(n, 3);
  std::vector<std::pair<std::int32_t, std::int32_t>> entries;
  for (std::int32_t v = 0; v + 1 < 20; ++v) entries.push_back({label[v], label[v + 1]});
  for (std::int32_t v = 20; v + 1 < 35; ++v) entries.push_back({label[v + 1], label[v]});
  for (std::int32_t v = 36; v < 50; ++v) entries.push_back({label[35], label[v]});
  Csr<float> m = pattern(n, entries);
  Permutation p = reverse_cuthill_mckee(m);
  expect_permutation(p, n);
  EXPECT_EQ(reverse_cuthill_mckee(m).order, p.order);  // deterministic
  EXPECT_LE(bandwidth(m, p), 14);  // the star's: no more than its 14 leaves; the paths' 1
  EXPECT_EQ(bandwidth(pattern(5, {})), 0);
}

// ---- the precompute on the renumbered operator ------------------------------------------------

std::unique_ptr<RadiositySystem> coarse(const std::string& scene) {
  return build_system(World::load(test::scene_path(scene), {.patch_size = 100}));
}

SeriesOperator precompute(const RadiositySystem& sys, SeriesReorder reorder, const Gather* gather,
                          SeriesAcceleration acceleration = SeriesAcceleration::kNone) {
  SeriesOptions o;
  o.order = 8;
  o.output = gather ? SeriesOutput::kView : SeriesOutput::kSolution;
  o.acceleration = acceleration;
  o.chebyshev_radius = 0.8;
  o.reorder = reorder;
  o.progress = false;
  return precompute_series(sys.transport, *sys.world, o, gather);
}

// Largest |a - b| / max |b| over all stored values (both dense, or both in the same layout).
double relative_difference(const SeriesOperator& a, const SeriesOperator& b) {
  EXPECT_EQ(a.nnz(), b.nnz());
  EXPECT_EQ(a.dense(), b.dense());
  const auto* x = static_cast<const float*>(a.values());
  const auto* y = static_cast<const float*>(b.values());
  double diff = 0.0, scale = 0.0;
  for (std::int64_t k = 0; k < 3 * a.nnz(); ++k) {
    diff = std::max(diff, static_cast<double>(std::abs(x[k] - y[k])));
    scale = std::max(scale, static_cast<double>(std::abs(y[k])));
  }
  EXPECT_GT(scale, 0.0);
  return diff / scale;
}

void expect_same_operator(const SeriesOperator& plain, const SeriesOperator& rcm) {
  EXPECT_EQ(plain.report.reorder, SeriesReorder::kNone);
  EXPECT_EQ(rcm.report.reorder, SeriesReorder::kRcm);
  EXPECT_EQ(plain.report.bandwidth_after, plain.report.bandwidth_before);
  EXPECT_EQ(rcm.report.bandwidth_before, plain.report.bandwidth_before);
  EXPECT_LE(rcm.report.bandwidth_after, rcm.report.bandwidth_before);
  EXPECT_GE(rcm.report.reorder_seconds, 0.0);
  EXPECT_EQ(rcm.report.order, plain.report.order);
  ASSERT_EQ(rcm.rows(), plain.rows());
  EXPECT_LT(relative_difference(rcm, plain), 1e-6);
  // Each row of the renumbered T sums its terms in T's order: not only close, the same bits.
  EXPECT_EQ(relative_difference(rcm, plain), 0.0);
}

TEST(Reorder, CornellBoxPrecomputeGivesTheSameQ) {
  auto sys = coarse("cornell-box");
  expect_same_operator(precompute(*sys, SeriesReorder::kNone, nullptr),
                       precompute(*sys, SeriesReorder::kRcm, nullptr));
  expect_same_operator(
      precompute(*sys, SeriesReorder::kNone, nullptr, SeriesAcceleration::kChebyshev),
      precompute(*sys, SeriesReorder::kRcm, nullptr, SeriesAcceleration::kChebyshev));
  Gather g = build_gather(*sys->world, sys->transport.layout());
  expect_same_operator(precompute(*sys, SeriesReorder::kNone, &g),
                       precompute(*sys, SeriesReorder::kRcm, &g));
}

TEST(Reorder, MirrorLinksPrecomputeGivesTheSameQ) {
  auto sys = coarse("cornell-mirror-cube");
  ASSERT_GT(sys->transport.num_links(), 0);
  SeriesOperator plain = precompute(*sys, SeriesReorder::kNone, nullptr);
  SeriesOperator rcm = precompute(*sys, SeriesReorder::kRcm, nullptr);
  expect_same_operator(plain, rcm);
  EXPECT_LT(rcm.report.bandwidth_after, rcm.report.bandwidth_before);
}

TEST(Reorder, OnTheFlyLinkRowsAreRefused) {
  SystemOptions o;
  o.specular_on_the_fly = true;
  auto sys =
      build_system(World::load(test::scene_path("cornell-mirror-cube"), {.patch_size = 200}), o);
  EXPECT_THROW(precompute(*sys, SeriesReorder::kRcm, nullptr), InputError);
}

// ---- the .prt header --------------------------------------------------------------------------

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The bytes with their checksum recomputed, written to dir/name.
std::string with_checksum(std::string bytes, const std::filesystem::path& dir,
                          const std::string& name) {
  std::uint64_t sum = checksum64(bytes.data(), bytes.size() - 8);
  std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
  return test::write_file(dir, name, bytes);
}

TEST(Reorder, FileKeepsTheReportAndReadsFilesWithoutIt) {
  auto sys = coarse("cornell-box");
  SeriesOperator q = precompute(*sys, SeriesReorder::kRcm, nullptr);
  auto dir = test::temp_dir();
  const std::string path = (dir / "rcm.prt").string();
  write_prt(q, path);
  SeriesOperator back = read_prt(path);
  EXPECT_EQ(back.report.reorder, SeriesReorder::kRcm);
  EXPECT_EQ(back.report.bandwidth_before, q.report.bandwidth_before);
  EXPECT_EQ(back.report.bandwidth_after, q.report.bandwidth_after);
  EXPECT_DOUBLE_EQ(back.report.reorder_seconds, q.report.reorder_seconds);

  // A file from before the reordering existed: its report has none of the four fields (blanked
  // here with spaces, so that no offset moves).
  const std::string bytes = read_bytes(path);
  const std::size_t from = bytes.find("\"reorder\":");
  const std::size_t to = bytes.find(',', bytes.find("\"reorder_seconds\":")) + 1;
  ASSERT_NE(from, std::string::npos);
  std::string old = bytes;
  std::fill(old.begin() + from, old.begin() + to, ' ');
  SeriesOperator before = read_prt(with_checksum(old, dir, "old.prt"));
  EXPECT_EQ(before.report.reorder, SeriesReorder::kNone);
  EXPECT_EQ(before.report.bandwidth_after, 0);
  EXPECT_EQ(relative_difference(before, q), 0.0);

  std::string unknown = bytes;
  unknown.replace(bytes.find("\"rcm\"", from), 5, "\"xyz\"");
  try {
    read_prt(with_checksum(unknown, dir, "unknown.prt"));
    ADD_FAILURE() << "accepted an unknown reorder";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown reorder"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace polyrad
