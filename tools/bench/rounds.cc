#include "tools/bench/rounds.h"

#include <algorithm>
#include <chrono>

namespace dg::tools {

void TimeInRounds(std::vector<TimedConfiguration>& configurations, int repeats,
                  const std::function<void()>& between_rounds) {
  for (TimedConfiguration& configuration : configurations) {
    configuration.rates.clear();
    configuration.advance(configuration.steps_per_repeat / 4 + 1);  // warms caches and threads
    if (configuration.after_warm_up) configuration.after_warm_up();
  }
  for (int round = 0; round < repeats; ++round) {
    for (TimedConfiguration& configuration : configurations) {
      const auto start = std::chrono::steady_clock::now();
      configuration.advance(configuration.steps_per_repeat);
      const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      configuration.rates.push_back(configuration.work_per_step * configuration.steps_per_repeat / wall_s);
    }
    if (between_rounds) between_rounds();
  }
  for (TimedConfiguration& configuration : configurations) {
    std::sort(configuration.rates.begin(), configuration.rates.end());
  }
}

double MedianOfSorted(const std::vector<double>& sorted) { return sorted.empty() ? 0 : sorted[sorted.size() / 2]; }

}  // namespace dg::tools
