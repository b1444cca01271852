#include "polyrad/util/progress.h"

#include <unistd.h>

#include <cstdio>

namespace polyrad {

namespace {
std::atomic<int> g_enabled{-1};  // -1: not decided, ask isatty
}

void Progress::set_enabled(bool on) { g_enabled.store(on ? 1 : 0); }

bool Progress::enabled() {
  int e = g_enabled.load();
  if (e < 0) {
    e = ::isatty(STDERR_FILENO) ? 1 : 0;
    g_enabled.store(e);
  }
  return e == 1;
}

Progress::Progress(std::string stage, long long total, bool visible)
    : stage_(std::move(stage)),
      total_(total),
      start_(std::chrono::steady_clock::now()),
      visible_(visible) {}

Progress::~Progress() { finish(); }

void Progress::advance(long long n) {
  long long done = done_.fetch_add(n, std::memory_order_relaxed) + n;
  if (!visible_ || !enabled()) return;
  const long long now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::steady_clock::now() - start_)
                            .count();
  if (now - last_draw_ns_.load(std::memory_order_relaxed) < 200'000'000) return;  // 0.2 s
  std::unique_lock<std::mutex> lock(draw_mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  last_draw_ns_.store(now, std::memory_order_relaxed);
  draw(done);
}

void Progress::draw(long long done) {
  double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  double fraction = total_ > 0 ? static_cast<double>(done) / total_ : 1.0;
  if (fraction > 1.0) fraction = 1.0;
  if (fraction > 0.0 && fraction < 1.0) {
    double left = elapsed * (1.0 - fraction) / fraction;
    std::fprintf(stderr, "\r\033[K[%s] %5.1f%%  %.1fs elapsed, about %.0fs left", stage_.c_str(),
                 100.0 * fraction, elapsed, left);
  } else {
    std::fprintf(stderr, "\r\033[K[%s] %5.1f%%  %.1fs", stage_.c_str(), 100.0 * fraction, elapsed);
  }
  std::fflush(stderr);
}

void Progress::finish() {
  std::lock_guard<std::mutex> lock(draw_mutex_);
  if (finished_) return;
  finished_ = true;
  if (!visible_ || !enabled()) return;
  draw(total_);
  std::fputc('\n', stderr);
}

}  // namespace polyrad
