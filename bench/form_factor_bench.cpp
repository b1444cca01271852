// The form-factor benchmark: the form factors of the Cornell box, and how close their shadow rays
// come to what Embree can cast on the same scene.
//
//   form_factors          compute_form_factors as the pipeline calls it (exposed areas, pair
//                         culling, contour integrals, quadrature and shadow rays), and the
//                         exposed-area probes alone, for the share of time they take
//   form_factors_vs_bare  the targets: the form factors alternated in one loop with a bare
//                         occlusion loop that casts as many shadow rays through the same
//                         RayCaster with the same OpenMP team; ray_ratio = form-factor rays/s
//                         over bare rays/s (target >= 0.7), and seconds, the form factors' median
//                         time (target < 30 s at patch_size 25)
//
// Both on scenes/cornell-box.json with PipelineOptions' patch_size override at 50 and 25 (the
// lamp included). The rays counted for the form factors are their shadow rays
// (FormFactorStats::rays); their time is the whole computation, so the ratio is the share of the
// form factors' time that pure ray casting would need: what is left is quadrature, contour
// integrals, pair culling and the exposed-area probes.
//
// The bare loop's segments are laid out as the form factors cast theirs: random pairs of
// mutually facing patches (both exposed, as the form factors require), visited in row order,
// each with as many rays as the form factors cast per facing pair on average, in groups of
// FormFactorOptions::visibility_rays from one random point of the smaller patch to random points
// of the other with a non-zero kernel; each end is lifted off its patch by
// RayCaster::segment_occluded exactly as theirs are. Rays from one point to one patch are
// coherent, and Embree is faster on them, so the grouping matters. The segments are generated
// once, deterministically, before any timing, into a pool of at most 2^21 segments that the
// loop walks round as often as it needs to cast the same number of rays.
// The scene, patches and ray caster are built once per patch size and kept. Targets are
// reported, never enforced: scripts/bench_summary.py prints PASS/FAIL.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench_common.h"
#include "polyrad/geometry/mesher.h"
#include "polyrad/raycast/ray_caster.h"
#include "polyrad/scene/scene.h"
#include "polyrad/transport/form_factors.h"
#include "polyrad/util/sampling.h"

namespace polyrad {

const std::string kScene = std::string(POLYRAD_SCENES_DIR) + "/cornell-box.json";

namespace {

// CPU time of the whole process (every thread): on a loaded machine the wall time of a kernel
// includes the slices other processes took, its CPU time does not.
double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// What build_system does before the form factors, with PipelineOptions::patch_size applied the
// same way. Not movable: the ray caster refers to the patches.
struct Setup {
  Scene scene;
  PatchSet patches;
  std::unique_ptr<RayCaster> caster;
  // The form factors' shadow rays and facing pairs: deterministic, set by the first run.
  long long ff_rays = -1, ff_pairs_facing = 0;
};

Setup& setup(int patch_size) {
  static std::map<int, std::unique_ptr<Setup>> cache;
  auto& s = cache[patch_size];
  if (!s) {
    s = std::make_unique<Setup>();
    s->scene = load_scene(kScene);
    for (auto& obj : s->scene.objects) obj.patch_size = patch_size;  // as PipelineOptions does
    s->patches = mesh_scene(s->scene);
    s->caster = std::make_unique<RayCaster>(s->patches);
  }
  return *s;
}

FormFactors run_form_factors(Setup& s) {
  FormFactors ff = compute_form_factors(s.patches, *s.caster, FormFactorOptions{});
  s.ff_rays = ff.stats.rays;
  s.ff_pairs_facing = ff.stats.pairs_facing;
  return ff;
}

long long ff_rays(Setup& s) {
  if (s.ff_rays < 0) run_form_factors(s);
  return s.ff_rays;
}

void common_counters(benchmark::State& state, const Setup& s, const FormFactors& ff) {
  state.counters["patches"] = static_cast<double>(s.patches.size());
  state.counters["nnz"] = static_cast<double>(ff.f.nnz());
  state.counters["bytes"] = bench::bytes_counter(static_cast<double>(ff.bytes()));
  state.counters["pairs_facing"] = static_cast<double>(ff.stats.pairs_facing);
  state.counters["pairs_visible"] = static_cast<double>(ff.stats.pairs_visible);
}

// ---- the form factors ------------------------------------------------------------------------

void form_factors(benchmark::State& state) {
  Setup& s = setup(static_cast<int>(state.range(0)));
  const FormFactorOptions options;
  FormFactors ff;
  std::vector<double> t_ff, t_exposure;
  for (auto _ : state) {
    Stopwatch t0;
    ff = run_form_factors(s);
    benchmark::DoNotOptimize(ff.f.value.data());
    benchmark::ClobberMemory();
    t_ff.push_back(t0.seconds());
    state.SetIterationTime(t_ff.back());
    // The exposed-area probes on their own (a part of the above), outside the iteration time.
    t0.restart();
    std::vector<double> area =
        exposed_areas(s.patches, *s.caster, options.exposure_points, options.exposure_refined);
    benchmark::DoNotOptimize(area.data());
    t_exposure.push_back(t0.seconds());
  }
  const double seconds = median(t_ff);
  common_counters(state, s, ff);
  state.counters["seconds"] = seconds;
  state.counters["rays"] = static_cast<double>(ff.stats.rays);
  state.counters["rays_per_second"] = seconds > 0.0 ? ff.stats.rays / seconds : 0.0;
  state.counters["exposure_seconds"] = median(t_exposure);
  state.SetLabel("cornell-box");
}
// Few iterations: one at patch_size 25 takes seconds.
BENCHMARK(form_factors)
    ->ArgNames({"patch_size"})
    ->Arg(50)
    ->Iterations(5)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);
BENCHMARK(form_factors)
    ->ArgNames({"patch_size"})
    ->Arg(25)
    ->Iterations(3)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);

// ---- the reference: a bare occlusion loop ----------------------------------------------------

struct Segment {
  Vec3 x, y;  // x on patch a, y on patch b
  PatchId a, b;
};

bool faces(const Patch& p, const Patch& plane) {
  const double eps = 1e-9 * std::max(p.diameter(), plane.diameter());
  for (int c = 0; c < p.corners; ++c)
    if ((p.corner[c] - plane.centroid).dot(plane.normal) > eps) return true;
  return false;
}

// `count` segments: random mutually facing, exposed pairs, `per_pair` rays each, in groups of
// `group` from one point x of the smaller patch a to points y of b, with x in front of b and y
// in front of a (a non-zero kernel); pairs in row order, as the form factors visit them.
// Deterministic.
std::vector<Segment> make_segments(const Setup& s, std::size_t count, int per_pair, int group) {
  const PatchSet& ps = s.patches;
  const auto n = static_cast<PatchId>(ps.size());
  const FormFactorOptions options;
  const std::vector<double> exposed =
      exposed_areas(ps, *s.caster, options.exposure_points, options.exposure_refined);
  std::vector<Segment> out;
  out.reserve(count + per_pair);
  Rng rng(20260101);
  while (out.size() < count) {
    auto a = static_cast<PatchId>(rng.uniform() * n), b = static_cast<PatchId>(rng.uniform() * n);
    if (a == b || exposed[a] <= 0.0 || exposed[b] <= 0.0) continue;
    if (ps[a].area > ps[b].area) std::swap(a, b);
    const Patch &pa = ps[a], &pb = ps[b];
    if (!faces(pa, pb) || !faces(pb, pa)) continue;
    double density;
    for (int g = 0; g < per_pair; g += group) {
      Vec3 x = pa.sample(rng.uniform2(), &density);
      for (int r = 0; r < group; ++r)
        for (int attempt = 0; attempt < 16; ++attempt) {
          Vec3 y = pb.sample(rng.uniform2(), &density);
          Vec3 d = y - x;
          if (d.dot(pa.normal) > 0.0 && d.dot(pb.normal) < 0.0) {
            out.push_back({x, y, a, b});
            break;
          }
        }
    }
  }
  out.resize(count);
  auto row_order = [](const Segment& u, const Segment& v) {
    return std::min(u.a, u.b) != std::min(v.a, v.b) ? std::min(u.a, u.b) < std::min(v.a, v.b)
                                                    : std::max(u.a, u.b) < std::max(v.a, v.b);
  };
  std::stable_sort(out.begin(), out.end(), row_order);
  return out;
}

// `rays` occlusion tests walking round the pool (a power of two long), in chunks as dynamically
// scheduled as the form factors' rows, cast as they cast theirs: a packet of consecutive
// segments (RayCaster::SegmentPacket; the form factors fill one with a pair's rays from several
// outer points). Returns how many were blocked.
long long bare_occlusion(const Setup& s, const std::vector<Segment>& pool, long long rays) {
  const PatchSet& ps = s.patches;
  const RayCaster& caster = *s.caster;
  const std::size_t mask = pool.size() - 1;
  constexpr long long kChunk = 1024;
  constexpr long long kPacket = RayCaster::SegmentPacket::kSize;
  static_assert(kChunk % kPacket == 0);
  const long long chunks = (rays + kChunk - 1) / kChunk;
  long long blocked = 0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : blocked)
  for (long long c = 0; c < chunks; ++c) {
    const long long end = std::min(rays, (c + 1) * kChunk);
    RayCaster::SegmentPacket packet;
    for (long long r0 = c * kChunk; r0 < end; r0 += kPacket) {
      packet.clear();
      for (long long r = r0; r < std::min(end, r0 + kPacket); ++r) {
        const Segment& g = pool[static_cast<std::size_t>(r) & mask];
        caster.add_segment(packet, g.x, ps[g.a], g.y, ps[g.b]);
      }
      caster.cast(packet);
      for (int k = 0; k < packet.count; ++k) blocked += packet.blocked[k] ? 1 : 0;
    }
  }
  return blocked;
}

// ---- the targets: form factors against the bare loop -----------------------------------------

// Both kernels in one loop, alternating which goes first, each timed on its own: a burst of
// load from elsewhere hits both, and the medians ignore the iterations it spoiled.
void form_factors_vs_bare(benchmark::State& state) {
  Setup& s = setup(static_cast<int>(state.range(0)));
  const long long rays = ff_rays(s);
  std::size_t pool_size = 1024;
  while (pool_size < static_cast<std::size_t>(rays) && pool_size < (std::size_t{1} << 21))
    pool_size *= 2;
  const int group = FormFactorOptions{}.visibility_rays;
  const int per_pair = std::max(
      group, group * static_cast<int>(std::lround(static_cast<double>(rays) /
                                                  std::max(s.ff_pairs_facing, 1LL) / group)));
  const std::vector<Segment> pool = make_segments(s, pool_size, per_pair, group);

  FormFactors ff;
  long long blocked = 0;
  std::vector<double> t_ff, t_bare, cpu_ff, cpu_bare;
  bool ff_first = true;
  for (auto _ : state) {
    auto run_ff = [&] {
      const double c0 = process_cpu_seconds();
      Stopwatch t0;
      ff = run_form_factors(s);
      benchmark::DoNotOptimize(ff.f.value.data());
      benchmark::ClobberMemory();
      t_ff.push_back(t0.seconds());
      cpu_ff.push_back(process_cpu_seconds() - c0);
    };
    auto run_bare = [&] {
      const double c0 = process_cpu_seconds();
      Stopwatch t0;
      blocked = bare_occlusion(s, pool, rays);
      benchmark::DoNotOptimize(blocked);
      t_bare.push_back(t0.seconds());
      cpu_bare.push_back(process_cpu_seconds() - c0);
    };
    if (ff_first) {
      run_ff();
      run_bare();
    } else {
      run_bare();
      run_ff();
    }
    ff_first = !ff_first;
    state.SetIterationTime(t_ff.back());
  }
  const double ff_s = median(t_ff), bare_s = median(t_bare);
  const double ff_rps = ff_s > 0.0 ? ff.stats.rays / ff_s : 0.0;
  const double bare_rps = bare_s > 0.0 ? rays / bare_s : 0.0;
  common_counters(state, s, ff);
  state.counters["rays"] = static_cast<double>(rays);
  state.counters["seconds"] = ff_s;  // target at patch_size 25: < 30 s
  state.counters["bare_seconds"] = bare_s;
  state.counters["ff_rays_per_second"] = ff_rps;
  state.counters["bare_rays_per_second"] = bare_rps;
  state.counters["ray_ratio"] = bare_rps > 0.0 ? ff_rps / bare_rps : 0.0;  // target >= 0.7
  // The same ratio from CPU seconds (all threads), which other processes' load leaves alone.
  state.counters["ff_cpu_seconds"] = median(cpu_ff);
  state.counters["bare_cpu_seconds"] = median(cpu_bare);
  state.counters["ray_ratio_cpu"] = median(cpu_ff) > 0.0 ? median(cpu_bare) / median(cpu_ff) : 0.0;
  state.counters["bare_blocked_fraction"] = rays > 0 ? static_cast<double>(blocked) / rays : 0.0;
  state.counters["pool_segments"] = static_cast<double>(pool.size());
  state.counters["bare_rays_per_pair"] = per_pair;
  state.SetLabel("time: the form factors");
}
// An even number of iterations: each kernel goes first in half of them.
BENCHMARK(form_factors_vs_bare)
    ->ArgNames({"patch_size"})
    ->Arg(50)
    ->Iterations(6)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);
BENCHMARK(form_factors_vs_bare)
    ->ArgNames({"patch_size"})
    ->Arg(25)
    ->Iterations(4)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace polyrad

int main(int argc, char** argv) {
  return polyrad::bench::run_benchmarks(argc, argv, polyrad::kScene);
}
