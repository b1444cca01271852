// The series benchmarks: the precomputed power series and the single product that relights.
//
//   triad                  the reference kernel: a STREAM triad a = b + s c over floats, OpenMP
//                          like the product, at sizes from in-cache to far beyond
//   product                SeriesOperator::apply on view-mode operators of growing size (the
//                          scene's camera at 64^2 .. 1024^2 pixels, one column per light patch),
//                          alternated in one loop with a triad over the same number of bytes;
//                          bandwidth_ratio = product bytes/s over triad bytes/s. Target: >= 0.6
//                          once the operator no longer fits in cache (> 32 MiB)
//   precompute             precompute_series against the order K = 1, 5, 10, 20, 40
//   precompute_reorder     precompute_series with SeriesOptions::reorder none and rcm,
//                          alternated in one loop; ratio = none's median over rcm's (above 1:
//                          reverse Cuthill-McKee makes the precompute faster), K = 10, 20
//   relight_product        the product of an operator precomputed to a tolerance (median)
//   iterative_same_error   Gauss-Seidel + camera gather to the same image error as that
//                          product; speedup = its median over the product's. Target: >= 1000.
//                          Both on the scene as written and with every patch size 25: the
//                          product's cost follows pixels x lamp patches, the solve's the patches
//
// All on cornell-mirror-cube, as written (patch size 50, the lamp 20) unless said otherwise.
// Bytes touched by a product: the operator
// (SeriesOperator::bytes()) plus the emission and output vectors, as `polyrad relight` reports.
// The systems, gathers and operators are built once in the fixtures' SetUp and kept, outside
// every timing loop. Targets are reported, never enforced: scripts/bench_summary.py prints
// PASS/FAIL.
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "bench_common.h"
#include "polyrad/util/stats.h"
#include "polyrad/render/camera_gather.h"
#include "polyrad/solve/series_precompute.h"
#include "polyrad/solve/solver.h"
#include "polyrad/transport/system.h"

namespace polyrad {

const std::string kScene = std::string(POLYRAD_SCENES_DIR) + "/cornell-mirror-cube.json";

namespace {

constexpr double kCacheBytes = 32.0 * 1024 * 1024;  // beyond this the bandwidth target applies

using bench::bytes_counter;
using bench::timed_loop;

// ---- the reference kernel --------------------------------------------------------------------

// Three float arrays, first touched by the threads that will stream them (the same static
// schedule as the triad), so that pages sit where the work is.
class TriadArrays {
 public:
  explicit TriadArrays(std::int64_t n)
      : n_(n), a_(new float[n]), b_(new float[n]), c_(new float[n]) {
    float* a = a_.get();
    float* b = b_.get();
    float* c = c_.get();
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i) {
      a[i] = 0.0f;
      b[i] = 1.0f;
      c[i] = 2.0f;
    }
  }
  // STREAM's triad. STREAM counts 3 arrays of bytes (the write-allocate read of a is not
  // counted), and so does bytes().
  void run(float s) {
    float* a = a_.get();
    const float* b = b_.get();
    const float* c = c_.get();
    const std::int64_t n = n_;
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    benchmark::DoNotOptimize(a);
    benchmark::ClobberMemory();
  }
  double bytes() const { return 3.0 * sizeof(float) * static_cast<double>(n_); }

 private:
  std::int64_t n_;
  std::unique_ptr<float[]> a_, b_, c_;
};

void triad(benchmark::State& state) {
  const std::int64_t bytes = state.range(0) << 20;
  TriadArrays arrays(bytes / (3 * static_cast<std::int64_t>(sizeof(float))));
  std::vector<double> times = timed_loop(state, [&] { arrays.run(3.0f); });
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * arrays.bytes()));
  state.counters["bytes"] = bytes_counter(arrays.bytes());
  state.counters["median_bytes_per_second"] = bytes_counter(arrays.bytes() / median(times));
}
BENCHMARK(triad)
    ->ArgNames({"MiB"})
    ->RangeMultiplier(4)
    ->Range(1, 1024)
    ->MinTime(0.5)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

// ---- what the benchmarks share, built once ---------------------------------------------------

// cornell-mirror-cube as written (patch_size 0: 50, the lamp 20, so 42 lamp patches and as
// many columns in the patch basis), or with every patch size set to one value.
RadiositySystem& mirror_cube(int patch_size = 0) {
  static std::map<int, std::unique_ptr<RadiositySystem>> cache;
  auto& sys = cache[patch_size];
  if (!sys) {
    sys = build_system(World::load(kScene, {.patch_size = static_cast<double>(patch_size)}));
  }
  return *sys;
}

std::string patch_size_name(int patch_size) {
  return patch_size > 0 ? "patch size " + std::to_string(patch_size) : "the scene's patch sizes";
}

// The camera gather of the scene's camera at width x width pixels (the scene's is 256).
const Gather& gather_at(int patch_size, int width) {
  static std::map<std::pair<int, int>, std::unique_ptr<Gather>> cache;
  auto& g = cache[{patch_size, width}];
  if (!g) {
    RadiositySystem& sys = mirror_cube(patch_size);
    Camera camera = sys.scene().camera;
    camera.width = camera.height = width;
    g = std::make_unique<Gather>(build_gather(*sys.world, camera, sys.transport.layout()));
  }
  return *g;
}

SeriesOptions view_options(SeriesBasis basis) {
  SeriesOptions o;
  o.output = SeriesOutput::kView;
  o.basis = basis;
  o.progress = false;
  return o;
}

// Relative L1 difference of two images over every channel of every pixel.
double image_error(const Image& a, const Image& reference) {
  double diff = 0.0, norm = 0.0;
  for (size_t k = 0; k < reference.rgb.size(); ++k) {
    diff += std::abs(static_cast<double>(a.rgb[k]) - reference.rgb[k]);
    norm += std::abs(static_cast<double>(reference.rgb[k]));
  }
  return norm > 0.0 ? diff / norm : diff;
}

Image product_image(const SeriesOperator& q) {
  std::vector<float> e = q.column_emission(), out(3 * static_cast<size_t>(q.rows()));
  q.apply(e.data(), out.data());
  return series_image(q, out);
}

// ---- the product against the triad, at growing sizes -----------------------------------------

class ProductFixture : public benchmark::Fixture {
 public:
  void SetUp(const benchmark::State& state) override {
    const int width = static_cast<int>(state.range(0));
    static std::map<int, std::unique_ptr<SeriesOperator>> cache;
    auto& q = cache[width];
    if (!q) {
      RadiositySystem& sys = mirror_cube();
      SeriesOptions o = view_options(SeriesBasis::kPatch);
      // A fixed order: past a few terms the pattern of non-zeros, which is all the product's
      // speed depends on, no longer changes.
      o.order = 20;
      q = std::make_unique<SeriesOperator>(
          precompute_series(sys.transport, *sys.world, o, &gather_at(0, width)));
    }
    op = q.get();
    e = op->column_emission();
    out.assign(3 * static_cast<size_t>(op->rows()), 0.0f);
    bytes = static_cast<double>(op->bytes()) +
            3.0 * sizeof(float) * static_cast<double>(op->cols() + op->rows());
    arrays = std::make_unique<TriadArrays>(static_cast<std::int64_t>(bytes / (3 * sizeof(float))));
  }
  void TearDown(const benchmark::State&) override { arrays.reset(); }

  const SeriesOperator* op = nullptr;
  std::vector<float> e, out;
  double bytes = 0.0;
  std::unique_ptr<TriadArrays> arrays;
};

// The product and the triad alternate, each timed on its own: a burst of load from elsewhere
// spoils a few iterations of both, which the medians then ignore.
BENCHMARK_DEFINE_F(ProductFixture, product)(benchmark::State& state) {
  std::vector<double> tp, tt;
  for (auto _ : state) {
    Stopwatch t0;
    op->apply(e.data(), out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    tp.push_back(t0.seconds());
    t0.restart();
    arrays->run(3.0f);
    tt.push_back(t0.seconds());
    state.SetIterationTime(tp.back());
  }
  const double product_bps = bytes / median(tp), triad_bps = arrays->bytes() / median(tt);
  state.counters["rows"] = static_cast<double>(op->rows());
  state.counters["cols"] = static_cast<double>(op->cols());
  state.counters["nnz"] = static_cast<double>(op->nnz());
  state.counters["bytes"] = bytes_counter(bytes);
  state.counters["product_bytes_per_second"] = bytes_counter(product_bps);
  state.counters["triad_bytes_per_second"] = bytes_counter(triad_bps);
  state.counters["bandwidth_ratio"] = product_bps / triad_bps;
  state.counters["beyond_cache"] = bytes > kCacheBytes ? 1 : 0;
  state.SetLabel("view " + std::to_string(op->width) + "x" + std::to_string(op->height) +
                 ", patch basis, K " + std::to_string(op->report.order));
}
BENCHMARK_REGISTER_F(ProductFixture, product)
    ->ArgNames({"pixels_per_side"})
    ->Arg(64)
    ->Arg(128)
    ->Arg(256)
    ->Arg(512)
    ->Arg(1024)
    ->MinTime(1.0)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

// ---- precompute time against K ---------------------------------------------------------------

class PrecomputeFixture : public benchmark::Fixture {
 public:
  void SetUp(const benchmark::State&) override {
    sys = &mirror_cube();
    gather = &gather_at(0, sys->scene().camera.width);
  }
  RadiositySystem* sys = nullptr;
  const Gather* gather = nullptr;
};

BENCHMARK_DEFINE_F(PrecomputeFixture, precompute)(benchmark::State& state) {
  SeriesOptions o = view_options(SeriesBasis::kPatch);
  o.order = static_cast<int>(state.range(0));
  SeriesOperator q;
  std::vector<double> times = timed_loop(state, [&] {
    q = precompute_series(sys->transport, *sys->world, o, gather);
    benchmark::DoNotOptimize(q.values());
  });
  state.counters["median_ms"] = 1e3 * median(times);
  state.counters["order"] = q.report.order;
  state.counters["cols"] = static_cast<double>(q.cols());
  state.counters["nnz"] = static_cast<double>(q.nnz());
  state.counters["bytes"] = bytes_counter(static_cast<double>(q.bytes()));
  state.counters["apriori_bound"] = q.report.apriori_bound;
  state.counters["aposteriori_estimate"] = q.report.aposteriori_estimate;
  state.SetLabel("view " + std::to_string(q.width) + "x" + std::to_string(q.height) +
                 ", patch basis");
}
BENCHMARK_REGISTER_F(PrecomputeFixture, precompute)
    ->ArgNames({"order"})
    ->Arg(1)
    ->Arg(5)
    ->Arg(10)
    ->Arg(20)
    ->Arg(40)
    ->MinTime(1.0)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// The same precompute with T's unknowns as built and renumbered by reverse Cuthill-McKee, each
// iteration running both, each timed on its own, so that both medians see the same load.
BENCHMARK_DEFINE_F(PrecomputeFixture, precompute_reorder)(benchmark::State& state) {
  SeriesOptions plain = view_options(SeriesBasis::kPatch);
  plain.order = static_cast<int>(state.range(0));
  SeriesOptions rcm = plain;
  rcm.reorder = SeriesReorder::kRcm;
  SeriesOperator q;
  std::vector<double> tn, tr;
  for (auto _ : state) {
    Stopwatch t0;
    q = precompute_series(sys->transport, *sys->world, plain, gather);
    benchmark::DoNotOptimize(q.values());
    tn.push_back(t0.seconds());
    t0.restart();
    q = precompute_series(sys->transport, *sys->world, rcm, gather);
    benchmark::DoNotOptimize(q.values());
    tr.push_back(t0.seconds());
    state.SetIterationTime(tn.back() + tr.back());
  }
  state.counters["none_median_s"] = median(tn);
  state.counters["rcm_median_s"] = median(tr);
  state.counters["ratio"] = median(tn) / median(tr);
  state.counters["reorder_ms"] = 1e3 * q.report.reorder_seconds;
  state.counters["bandwidth_before"] = static_cast<double>(q.report.bandwidth_before);
  state.counters["bandwidth_after"] = static_cast<double>(q.report.bandwidth_after);
  state.counters["unknowns"] = static_cast<double>(sys->transport.size());
  state.SetLabel("view " + std::to_string(q.width) + "x" + std::to_string(q.height) +
                 ", patch basis, K " + std::to_string(q.report.order) + ", none then rcm");
}
// A fixed count of pairs: at 1 to 3 s a pair, a minimum time would leave K = 20 two or three,
// too few for a median under load.
BENCHMARK_REGISTER_F(PrecomputeFixture, precompute_reorder)
    ->ArgNames({"order"})
    ->Arg(10)
    ->Arg(20)
    ->Iterations(9)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// ---- relighting against the iterative solve to the same error --------------------------------

// An operator precomputed to a tolerance, and the cheapest Gauss-Seidel run that renders the
// scene's view with no larger an image error: as many sweeps as it needs and no more (a
// tolerance on the residual would stop later, which would flatter the product).
struct RelightCase {
  SeriesOperator q;
  double series_error = 0.0;     // relative L1 image error of the product
  int sweeps = 0;                // Gauss-Seidel sweeps to reach it
  double iterative_error = 0.0;  // and the error they reach
};

constexpr int kMaxSweeps = 200;

// The scene's view of a tightly converged solve.
const Image& reference_image(int patch_size) {
  static std::map<int, Image> cache;
  auto it = cache.find(patch_size);
  if (it != cache.end()) return it->second;
  RadiositySystem& sys = mirror_cube(patch_size);
  const TransportOperator& t = sys.transport;
  SolveResult r = solve(t, t.emission(), {.method = SolveMethod::kGaussSeidel, .tolerance = 1e-12});
  return cache[patch_size] = apply_gather(gather_at(patch_size, sys.scene().camera.width), r.u);
}

const RelightCase& relight_case(int patch_size, SeriesBasis basis, int tolerance_exponent) {
  static std::map<std::tuple<int, int, int>, std::unique_ptr<RelightCase>> cache;
  auto& c = cache[{patch_size, static_cast<int>(basis), tolerance_exponent}];
  if (c) return *c;
  c = std::make_unique<RelightCase>();
  RadiositySystem& sys = mirror_cube(patch_size);
  const TransportOperator& t = sys.transport;
  const Gather& g = gather_at(patch_size, sys.scene().camera.width);
  const Image& reference = reference_image(patch_size);
  SeriesOptions o = view_options(basis);
  o.tolerance = std::pow(10.0, -tolerance_exponent);
  c->q = precompute_series(t, *sys.world, o, &g);
  c->series_error = image_error(product_image(c->q), reference);
  for (int n = 1; n <= kMaxSweeps; ++n) {
    SolveResult r =
        solve(t, t.emission(), {.method = SolveMethod::kGaussSeidel, .fixed_sweeps = n});
    c->sweeps = n;
    c->iterative_error = image_error(apply_gather(g, r.u), reference);
    if (c->iterative_error <= c->series_error) break;
  }
  return *c;
}

class RelightFixture : public benchmark::Fixture {
 public:
  void SetUp(const benchmark::State& state) override {
    patch_size = static_cast<int>(state.range(0));
    basis = state.range(1) == 0 ? SeriesBasis::kPatch : SeriesBasis::kObject;
    tolerance_exponent = static_cast<int>(state.range(2));
    c = &relight_case(patch_size, basis, tolerance_exponent);
    sys = &mirror_cube(patch_size);
    gather = &gather_at(patch_size, sys->scene().camera.width);
  }
  // Median of single products, timed one by one (the way `polyrad relight` reports it).
  double product_median(int repeats) const {
    std::vector<float> e = c->q.column_emission(), out(3 * static_cast<size_t>(c->q.rows()));
    std::vector<double> times;
    for (int r = 0; r < repeats; ++r) {
      Stopwatch t0;
      c->q.apply(e.data(), out.data());
      benchmark::DoNotOptimize(out.data());
      benchmark::ClobberMemory();
      times.push_back(t0.seconds());
    }
    return median(times);
  }
  std::string label() const {
    return patch_size_name(patch_size) + ", " + std::to_string(sys->patches().size()) +
           " patches, " + enum_name(basis) + " basis, tolerance 1e-" +
           std::to_string(tolerance_exponent) + ", K " + std::to_string(c->q.report.order) + ", " +
           std::to_string(c->sweeps) + " Gauss-Seidel sweeps";
  }

  int patch_size = 0;
  SeriesBasis basis = SeriesBasis::kPatch;
  int tolerance_exponent = 3;
  const RelightCase* c = nullptr;
  RadiositySystem* sys = nullptr;
  const Gather* gather = nullptr;
};

BENCHMARK_DEFINE_F(RelightFixture, relight_product)(benchmark::State& state) {
  std::vector<float> e = c->q.column_emission(), out(3 * static_cast<size_t>(c->q.rows()));
  std::vector<double> times = timed_loop(state, [&] {
    c->q.apply(e.data(), out.data());
    benchmark::DoNotOptimize(out.data());
  });
  const double bytes = static_cast<double>(c->q.bytes()) +
                       3.0 * sizeof(float) * static_cast<double>(c->q.cols() + c->q.rows());
  state.counters["order"] = c->q.report.order;
  state.counters["cols"] = static_cast<double>(c->q.cols());
  state.counters["nnz"] = static_cast<double>(c->q.nnz());
  state.counters["bytes"] = bytes_counter(bytes);
  state.counters["median_ms"] = 1e3 * median(times);
  state.counters["bytes_per_second"] = bytes_counter(bytes / median(times));
  state.counters["image_error"] = c->series_error;
  state.counters["patches"] = static_cast<double>(sys->patches().size());
  state.SetLabel(label());
}
BENCHMARK_REGISTER_F(RelightFixture, relight_product)
    ->ArgNames({"patch_size", "basis", "tolerance_exp"})
    ->ArgsProduct({{0, 25}, {0, 1}, {3, 4}})
    ->MinTime(1.0)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

// Each iteration: the solve and the gather that turn the scene's emission into the image.
// The product is timed again right after the loop, so that the speedup compares two figures
// taken under the same load.
BENCHMARK_DEFINE_F(RelightFixture, iterative_same_error)(benchmark::State& state) {
  const TransportOperator& t = sys->transport;
  const Field e = t.emission();
  std::vector<double> times = timed_loop(state, [&] {
    SolveResult r = solve(t, e, {.method = SolveMethod::kGaussSeidel, .fixed_sweeps = c->sweeps});
    Image img = apply_gather(*gather, r.u);
    benchmark::DoNotOptimize(img.rgb.data());
  });
  const double product = product_median(201);
  state.counters["patches"] = static_cast<double>(sys->patches().size());
  state.counters["sweeps"] = c->sweeps;
  state.counters["image_error"] = c->iterative_error;
  state.counters["series_image_error"] = c->series_error;
  state.counters["median_ms"] = 1e3 * median(times);
  state.counters["product_median_ms"] = 1e3 * product;
  state.counters["speedup"] = median(times) / product;
  state.SetLabel(label());
}
BENCHMARK_REGISTER_F(RelightFixture, iterative_same_error)
    ->ArgNames({"patch_size", "basis", "tolerance_exp"})
    ->ArgsProduct({{0, 25}, {0, 1}, {3, 4}})
    ->MinTime(1.0)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// ---- the same with the final gather ------------------------------------------------------------

// cornell-mirror-cube as written through the final gather: the operator (view rows folded from
// the deferred gather), the stored gather (to judge errors against a tight solve through it),
// and the Gauss-Seidel sweeps that give no larger an image error.
struct FinalCase {
  SeriesOperator q;
  Gather stored;
  double series_error = 0.0, iterative_error = 0.0;
  int sweeps = 0;
};

const FinalCase& final_case(SeriesBasis basis) {
  static std::map<int, std::unique_ptr<FinalCase>> cache;
  auto& c = cache[static_cast<int>(basis)];
  if (c) return *c;
  c = std::make_unique<FinalCase>();
  RadiositySystem& sys = mirror_cube(0);
  const World& world = *sys.world;
  const TransportOperator& t = sys.transport;
  const GatherOptions go = GatherOptions::final_gather();
  c->stored = build_gather(world, t.layout(), go);
  const std::vector<Rgb> emission = scene_emission(world.patches());
  SolveResult tight = solve(t, t.emission(), {.method = SolveMethod::kGaussSeidel, .tolerance = 1e-12});
  const Image reference = apply_gather(c->stored, tight.u, emission);
  SeriesOptions o = view_options(basis);
  o.tolerance = 1e-3;
  o.gather = go;
  c->q = precompute_series(t, world, o);
  c->series_error = image_error(product_image(c->q), reference);
  for (int n = 1; n <= kMaxSweeps; ++n) {
    SolveResult r = solve(t, t.emission(), {.method = SolveMethod::kGaussSeidel, .fixed_sweeps = n});
    c->sweeps = n;
    c->iterative_error = image_error(apply_gather(c->stored, r.u, emission), reference);
    if (c->iterative_error <= c->series_error) break;
  }
  return *c;
}

// What a change of lights costs without the precompute, with the final gather: the solve to
// the product's image error, and the camera's final gather built and applied (its rows in
// blocks, as `polyrad render` does). Also, for an honest comparison, the solve and the apply of
// a gather kept in memory (about 300 MB here), which a change of lights alone does not have to
// rebuild. The product is timed right after, under the same load.
void final_gather_same_error(benchmark::State& state) {
  const SeriesBasis basis = state.range(0) == 0 ? SeriesBasis::kPatch : SeriesBasis::kObject;
  const FinalCase& c = final_case(basis);
  RadiositySystem& sys = mirror_cube(0);
  const World& world = *sys.world;
  const TransportOperator& t = sys.transport;
  const Field e = t.emission();
  const std::vector<Rgb> emission = scene_emission(world.patches());
  std::vector<double> times = timed_loop(state, [&] {
    SolveResult r = solve(t, e, {.method = SolveMethod::kGaussSeidel, .fixed_sweeps = c.sweeps});
    const Gather g = defer_gather(world, world.camera(), t.layout(), c.q.gather);
    Image img = apply_gather(g, r.u, emission);
    benchmark::DoNotOptimize(img.rgb.data());
  });
  const RepeatTimes stored = time_repeats(5, [&] {
    SolveResult r = solve(t, e, {.method = SolveMethod::kGaussSeidel, .fixed_sweeps = c.sweeps});
    Image img = apply_gather(c.stored, r.u, emission);
    benchmark::DoNotOptimize(img.rgb.data());
  });
  std::vector<float> ce = c.q.column_emission(), out(3 * static_cast<size_t>(c.q.rows()));
  const RepeatTimes product = time_repeats(201, [&] {
    c.q.apply(ce.data(), out.data());
    benchmark::DoNotOptimize(out.data());
  });
  state.counters["sweeps"] = c.sweeps;
  state.counters["order"] = c.q.report.order;
  state.counters["image_error"] = c.iterative_error;
  state.counters["series_image_error"] = c.series_error;
  state.counters["median_ms"] = 1e3 * median(times);
  state.counters["stored_gather_ms"] = 1e3 * stored.median;
  state.counters["product_median_ms"] = 1e3 * product.median;
  state.counters["speedup"] = median(times) / product.median;
  state.counters["speedup_stored_gather"] = stored.median / product.median;
  state.SetLabel(std::string("final gather, ") + enum_name(basis) + " basis, tolerance 1e-3, K " +
                 std::to_string(c.q.report.order) + ", " + std::to_string(c.sweeps) +
                 " Gauss-Seidel sweeps");
}
// A final gather is seconds: three iterations.
BENCHMARK(final_gather_same_error)
    ->ArgNames({"basis"})
    ->Arg(0)
    ->Arg(1)
    ->Iterations(3)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace polyrad

int main(int argc, char** argv) {
  return polyrad::bench::run_benchmarks(argc, argv, polyrad::kScene);
}
