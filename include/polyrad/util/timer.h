// Wall-clock timing: the one stopwatch every stage, workflow and benchmark reads.
//
//   Stopwatch watch;
//   build();
//   double build_s = watch.lap();   // since the last lap (or the start); starts the next lap
//   solve();
//   double total_s = watch.seconds();  // since the start
//
// Cost: one steady_clock read per call.
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace polyrad {

class Stopwatch {
 public:
  using Clock = std::chrono::steady_clock;
  Stopwatch() : start_(Clock::now()), lap_(start_) {}

  // Seconds since construction (or restart()).
  double seconds() const { return since(start_); }
  // Seconds since the previous lap (or the start), and a new lap begins.
  double lap() {
    const Clock::time_point now = Clock::now();
    const double s = std::chrono::duration<double>(now - lap_).count();
    lap_ = now;
    return s;
  }
  void restart() { start_ = lap_ = Clock::now(); }

 private:
  static double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  }
  Clock::time_point start_, lap_;
};

// A named stage's wall time, as reports list them in order.
struct StageTime {
  std::string name;
  double seconds = 0.0;
};
using StageTimes = std::vector<StageTime>;
// The seconds of a stage, 0 if the list has none of that name.
inline double stage_seconds(const StageTimes& times, const std::string& name) {
  for (const auto& t : times)
    if (t.name == name) return t.seconds;
  return 0.0;
}

// Seconds that f() takes.
template <typename F>
double time_seconds(F&& f) {
  Stopwatch watch;
  f();
  return watch.seconds();
}

}  // namespace polyrad
