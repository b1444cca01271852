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
#include <string>
#include <thread>
#include <vector>

#include "polyrad/util/machine.h"
#include "polyrad/util/progress.h"
#include "polyrad/util/stats.h"
#include "polyrad/util/timer.h"

namespace polyrad::bench {

// Runs body once per iteration, timing each on its own as the iteration time (the benchmark
// must be registered with UseManualTime()); returns the times, for medians.
template <typename Body>
std::vector<double> timed_loop(benchmark::State& state, Body&& body) {
  std::vector<double> times;
  for (auto _ : state) {
    const Stopwatch watch;
    body();
    benchmark::ClobberMemory();
    times.push_back(watch.seconds());
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
  benchmark::AddCustomContext("cpu_model", cpu_model());
  benchmark::AddCustomContext("omp_max_threads", std::to_string(omp_get_max_threads()));
  benchmark::AddCustomContext("hardware_threads",
                              std::to_string(std::thread::hardware_concurrency()));
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
