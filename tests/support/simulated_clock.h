#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>

#include "pipeline/run_clock.h"

namespace dg::testing {

// A run clock that moves only when something takes time on it, so that a
// real-time run's drops and latencies follow from the times a test gives its
// stages, whatever the machine's load. It starts at zero, as a run's clock
// does. A stage's work ends at a time the test gives (AdvanceTo), and a wait
// for a time moves the clock there at once; the clock is the latest end
// reached. A wait ends at once in wall time, so it may move the clock while
// another thread's frame is still under way: that frame's timings then read
// the later time. Times are exact where they do not depend on that order
// (see each test).
class SimulatedClock final : public pipeline::RunClock {
 public:
  TimePoint Now() const override { return TimePoint(std::chrono::nanoseconds(now_ns_.load())); }

  bool WaitUntil(std::unique_lock<std::mutex>&, std::condition_variable&, TimePoint due,
                 const std::function<bool()>& stop) const override {
    if (!stop()) AdvanceTo(due);
    return stop();
  }

  // Moves the clock to `t`, unless it is past `t` already.
  void AdvanceTo(TimePoint t) const {
    const std::int64_t to = std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
    std::int64_t now = now_ns_.load();
    while (now < to && !now_ns_.compare_exchange_weak(now, to)) {
    }
  }

 private:
  mutable std::atomic<std::int64_t> now_ns_{0};
};

}  // namespace dg::testing
