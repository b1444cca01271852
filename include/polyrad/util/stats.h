// Summaries of repeated measurements: the median (robust to a burst of other load on a shared
// machine) and the fastest repeat (the least disturbed), and a timer of repeats.
//
//   RepeatTimes t = time_repeats(21, [&] { q.apply(e, out); });
//   report(t.median, t.min);
//
// Cost: a sort of the samples.
#pragma once

#include <vector>

#include "polyrad/util/timer.h"

namespace polyrad {

// The middle value (the mean of the two middle values for an even count); NaN when empty.
double median(std::vector<double> values);

struct RepeatTimes {
  double median = 0.0;  // seconds
  double min = 0.0;
  int repeats = 0;
  std::vector<double> seconds;  // each repeat, in order
};

// The summary of times measured elsewhere (at least one).
RepeatTimes repeat_times(std::vector<double> seconds);

// Runs f `repeats` times (at least once), timing each.
template <typename F>
RepeatTimes time_repeats(int repeats, F&& f) {
  std::vector<double> seconds;
  for (int r = 0; r < (repeats > 0 ? repeats : 1); ++r) seconds.push_back(time_seconds(f));
  return repeat_times(std::move(seconds));
}

}  // namespace polyrad
