// Progress of long work on stderr: stage, percent, elapsed and remaining time.
//
// Shown only when stderr is a terminal (or when forced on), redrawn at most five times a
// second, from whichever thread advances it. Thread-safe and cheap: advance() is one atomic add
// and, rarely, a try_lock.
//
//   Progress bar("form factors", patches.size());
//   #pragma omp parallel for
//   for (...) { work(); bar.advance(); }
//   bar.finish();
#pragma once

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>

namespace polyrad {

class Progress {
 public:
  // visible = false keeps this one quiet whatever set_enabled says.
  Progress(std::string stage, long long total, bool visible = true);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(long long n = 1);
  void finish();

  // Default: on when stderr is a terminal. Tests and scripted runs may force it either way.
  static void set_enabled(bool on);
  static bool enabled();

 private:
  void draw(long long done);
  std::string stage_;
  long long total_;
  std::atomic<long long> done_{0};
  std::chrono::steady_clock::time_point start_;
  // When it last drew, in nanoseconds after start_: read by every advance() outside the lock.
  std::atomic<long long> last_draw_ns_{0};
  std::mutex draw_mutex_;
  bool finished_ = false;
  bool visible_ = true;
};

// Turns displays off for its lifetime (and back as they were): a workflow that runs many inner
// stages shows its own display only.
class QuietProgress {
 public:
  QuietProgress() : was_(Progress::enabled()) { Progress::set_enabled(false); }
  ~QuietProgress() { Progress::set_enabled(was_); }
  QuietProgress(const QuietProgress&) = delete;
  QuietProgress& operator=(const QuietProgress&) = delete;

 private:
  bool was_;
};

}  // namespace polyrad
