// What the benchmark programs share: timing by iteration with medians, counters, the machine.
//
// On a machine busy with other work, benchmark's mean per iteration follows the load: a
// burst elsewhere stalls an OpenMP team for a scheduler slice. Each program therefore times
// iterations one by one (timed_loop, with UseManualTime) and reports medians in its counters,
// and compares against a reference kernel timed in the same loop. scripts/bench_summary.py
// reads those counters.
#pragma once

#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "polyrad/util/progress.h"

namespace polyrad::bench {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// Runs body once per iteration, timing each on its own as the iteration time (the benchmark
// must be registered with UseManualTime()); returns the times, for medians.
template <typename Body>
std::vector<double> timed_loop(benchmark::State& state, Body&& body) {
  std::vector<double> times;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    body();
    benchmark::ClobberMemory();
    times.push_back(seconds_since(t0));
    state.SetIterationTime(times.back());
  }
  return times;
}

// Bytes, printed with binary prefixes on the console (the JSON holds the plain number).
inline benchmark::Counter bytes_counter(double b) {
  return benchmark::Counter(b, benchmark::Counter::kDefaults, benchmark::Counter::OneK::kIs1024);
}

// The machine, for the JSON's context: benchmark records the caches and the load average, not
// the CPU's name or the OpenMP thread count.
inline void add_machine_context(const std::string& scene) {
  std::string model = "unknown CPU";
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string line; std::getline(cpu, line);)
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  benchmark::AddCustomContext("cpu_model", model);
  benchmark::AddCustomContext("omp_max_threads", std::to_string(omp_get_max_threads()));
  benchmark::AddCustomContext("hardware_threads", std::to_string(std::thread::hardware_concurrency()));
  benchmark::AddCustomContext("scene", scene);
}

// main() of every program: no progress display, the machine in the context.
inline int run_benchmarks(int argc, char** argv, const std::string& scene) {
  Progress::set_enabled(false);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  add_machine_context(scene);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace polyrad::bench
