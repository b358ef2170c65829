#include "tools/bench/host_interruptions.h"

#include <algorithm>

#include "tools/bench/run_together.h"

namespace dg::tools {

double CoveredFraction(std::vector<std::pair<double, double>> intervals, double begin, double end) {
  if (!(end > begin)) return 0;
  std::sort(intervals.begin(), intervals.end());
  double covered = 0, reached = begin;
  for (auto [first, second] : intervals) {
    first = std::max(first, reached);
    second = std::min(second, end);
    if (second > first) {
      covered += second - first;
      reached = second;
    }
  }
  return covered / (end - begin);
}

HostInterruptions MeasureHostInterruptions(int threads, std::chrono::milliseconds duration) {
  using Clock = std::chrono::steady_clock;
  // Per thread, its gaps in seconds from the common start.
  std::vector<std::vector<std::pair<double, double>>> gaps(threads);
  RunTogether(threads, [&](int t, Clock::time_point start) {
    std::vector<std::pair<double, double>>& mine = gaps[t];
    const Clock::time_point end = start + duration;
    Clock::time_point last = Clock::now();
    while (last < end) {
      const Clock::time_point now = Clock::now();
      if (now - last >= kHostGap) {
        mine.emplace_back(std::chrono::duration<double>(last - start).count(),
                          std::chrono::duration<double>(now - start).count());
      }
      last = now;
    }
  });

  HostInterruptions result;
  std::vector<std::pair<double, double>> all;
  const double span_s = std::chrono::duration<double>(duration).count();
  for (const auto& mine : gaps) {
    result.per_core_percent += 100 * CoveredFraction(mine, 0, span_s) / threads;
    result.gaps_per_ms += mine.size() / (span_s * 1e3) / threads;
    all.insert(all.end(), mine.begin(), mine.end());
  }
  result.any_core_percent = 100 * CoveredFraction(all, 0, span_s);
  return result;
}

}  // namespace dg::tools
