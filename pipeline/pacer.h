#pragma once

#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

#include "pipeline/run_clock.h"

namespace dg::pipeline {

// Real-time pacing without a sleeping TBB worker (docs/design.md#threads):
// the graph's source asks for its next tick at the time the camera delivers
// the next frame, and the pacer's own thread waits for that time on a
// condition variable and then calls tick(), which puts a token into the
// graph. Stop() ends a wait at once, so a failing stage or the end of the
// recording never waits out a frame period. The same wait is available on
// the caller's thread (WaitUntil) for a run without the graph.
//
// Threading: Schedule() comes from one thread at a time (the graph's serial
// source); Stop() from any thread; tick() and on_exit() run on the pacer's
// thread. Start/Stop/Join are explicit: no thread runs before Start() or
// after Join().
class Pacer {
 public:
  using TimePoint = RunClock::TimePoint;

  // tick: called at each scheduled time on `clock`, which outlives the pacer.
  // on_exit: called last on the pacer's thread, after its last tick (the
  // graph releases its wait there).
  explicit Pacer(std::function<void()> tick, std::function<void()> on_exit = {},
                 const RunClock& clock = SteadyRunClock());
  ~Pacer();  // Stop() and Join()
  Pacer(const Pacer&) = delete;
  Pacer& operator=(const Pacer&) = delete;

  // Starts the pacer's thread. @pre not started.
  void Start();
  // The next tick at `due` (at once if it has passed).
  // @pre the tick scheduled before has been called (one tick pending at most).
  void Schedule(TimePoint due);
  // Ends the pacer: a pending tick is not called, and none is called after
  // the tick under way (if any) returns. Idempotent; never blocks for long.
  void Stop();
  // Waits for the pacer's thread to end (after Stop()). Idempotent.
  void Join();

  // Without the thread: blocks the caller until `due`; false if Stop() came first.
  bool WaitUntil(TimePoint due);

 private:
  void Loop();

  std::function<void()> tick_, on_exit_;
  const RunClock& clock_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<TimePoint> due_;  // the pending tick's time
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace dg::pipeline
