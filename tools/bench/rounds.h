#pragma once

#include <functional>
#include <vector>

namespace dg::tools {

// One configuration a benchmark times: `advance(steps)` runs that many steps,
// each worth `work_per_step` units (tet-steps, frames, ...).
struct TimedConfiguration {
  std::function<void(int steps)> advance;
  int steps_per_repeat = 1;
  double work_per_step = 1;
  std::function<void()> after_warm_up;  // optional: called once, before the first timed repeat
  std::vector<double> rates;  // filled by TimeInRounds: work per second of each repeat, ascending
};

// Times `repeats` repeats of every configuration in rounds: after a warm-up of
// each (a quarter of a repeat, then its after_warm_up), each round runs one repeat of every
// configuration in turn, then calls `between_rounds` (e.g. to sample the
// machine). Interleaved, every configuration samples the same minutes of a
// host whose speed drifts, and the ratio of two configurations' medians
// compares them on the same machine (docs/benchmarks.md, `bench sim`).
void TimeInRounds(std::vector<TimedConfiguration>& configurations, int repeats,
                  const std::function<void()>& between_rounds = {});

// The median of ascending values (the upper one of an even count); 0 if empty.
double MedianOfSorted(const std::vector<double>& sorted);

}  // namespace dg::tools
