#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>

namespace dg::pipeline {

// The clock a real-time run is paced by and timed on: the steady clock in
// every run. A test substitutes a simulated one, on which a stage's work
// takes exactly the time the test gives it, so that what the real-time
// policy drops, and each frame's latency, are exact rather than at the
// mercy of the machine's load.
class RunClock {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;

  virtual ~RunClock() = default;
  virtual TimePoint Now() const = 0;
  // Blocks on `wake`, whose mutex `lock` holds, until the clock reaches `due`
  // or `stop()` holds (checked under the lock, as a condition variable's
  // predicate). @returns stop().
  virtual bool WaitUntil(std::unique_lock<std::mutex>& lock, std::condition_variable& wake, TimePoint due,
                         const std::function<bool()>& stop) const = 0;
};

// std::chrono::steady_clock, waited on with condition_variable::wait_until
// (pthread_cond_clockwait: a change of the wall clock moves no tick).
const RunClock& SteadyRunClock();

}  // namespace dg::pipeline
