#include "pipeline/run_clock.h"

namespace dg::pipeline {
namespace {

class SteadyClock final : public RunClock {
 public:
  TimePoint Now() const override { return std::chrono::steady_clock::now(); }
  bool WaitUntil(std::unique_lock<std::mutex>& lock, std::condition_variable& wake, TimePoint due,
                 const std::function<bool()>& stop) const override {
    return wake.wait_until(lock, due, stop);
  }
};

}  // namespace

const RunClock& SteadyRunClock() {
  static const SteadyClock clock;
  return clock;
}

}  // namespace dg::pipeline
