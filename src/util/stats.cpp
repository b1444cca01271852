// Summaries of repeated measurements (util/stats.h).
#include "polyrad/util/stats.h"

#include <algorithm>
#include <limits>

namespace polyrad {

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  if (v.size() % 2) return v[mid];
  const double upper = v[mid];
  return 0.5 * (*std::max_element(v.begin(), v.begin() + mid) + upper);
}

RepeatTimes repeat_times(std::vector<double> seconds) {
  RepeatTimes t;
  t.repeats = static_cast<int>(seconds.size());
  t.median = median(seconds);
  t.min = seconds.empty() ? t.median : *std::min_element(seconds.begin(), seconds.end());
  t.seconds = std::move(seconds);
  return t;
}

}  // namespace polyrad
