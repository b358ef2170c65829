#pragma once

#include <chrono>
#include <utility>
#include <vector>

namespace dg::tools {

// What the host takes from the cores a benchmark runs on: each of `threads`
// threads reads the clock in a tight loop for `duration`, all at once, and a
// gap of kHostGap or more between two reads is time its core spent elsewhere (a
// timer tick, an interrupt, the host running another virtual CPU on it). A
// threaded solver waits at its barrier whenever any of its cores is taken,
// two solvers sharing nothing each only when its own is (docs/benchmarks.md).
struct HostInterruptions {
  double per_core_percent = 0;  // the threads' mean share of time in gaps
  double any_core_percent = 0;  // the share of time in a gap on at least one thread
  double gaps_per_ms = 0;       // per thread
};
inline constexpr std::chrono::nanoseconds kHostGap{2000};
HostInterruptions MeasureHostInterruptions(int threads, std::chrono::milliseconds duration);

// The share of [begin, end) covered by the union of `intervals` (each
// [first, second)), clipped to it; 0 for an empty span.
double CoveredFraction(std::vector<std::pair<double, double>> intervals, double begin, double end);

}  // namespace dg::tools
