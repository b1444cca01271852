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

// Runs f `repeats` times (at least once), timing each.
template <typename F>
RepeatTimes time_repeats(int repeats, F&& f) {
  RepeatTimes t;
  for (int r = 0; r < (repeats > 0 ? repeats : 1); ++r) t.seconds.push_back(time_seconds(f));
  t.repeats = static_cast<int>(t.seconds.size());
  t.median = median(t.seconds);
  t.min = t.seconds[0];
  for (double s : t.seconds) t.min = s < t.min ? s : t.min;
  return t;
}

}  // namespace polyrad
