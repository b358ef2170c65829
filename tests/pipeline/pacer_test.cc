// The real-time pacer: each tick comes on the pacer's thread no earlier than
// its scheduled time and in order, and Stop() ends a pending wait at once
// without its tick (a stage failing, or the recording ending, never waits out
// a frame period).
#include "pipeline/pacer.h"

#include <atomic>
#include <chrono>
#include <future>
#include <vector>

#include <catch2/catch.hpp>

namespace dg::pipeline {
namespace {

using Clock = std::chrono::steady_clock;

TEST_CASE("pacer: ticks in order, each no earlier than its time", "[pipeline][unit]") {
  constexpr int kTicks = 20;
  const Clock::time_point first = Clock::now();
  const auto due = [first](int k) { return first + std::chrono::microseconds(500 * k); };
  std::vector<Clock::time_point> ticked;
  std::promise<void> exited;
  Pacer* self = nullptr;
  Pacer pacer(
      [&] {
        ticked.push_back(Clock::now());  // only the pacer's thread writes it
        if (ticked.size() < kTicks) {
          self->Schedule(due(static_cast<int>(ticked.size())));
        } else {
          self->Stop();
        }
      },
      [&] { exited.set_value(); });
  self = &pacer;
  pacer.Start();
  pacer.Schedule(due(0));
  exited.get_future().wait();
  pacer.Join();
  REQUIRE(ticked.size() == kTicks);
  for (int k = 0; k < kTicks; ++k) {
    CAPTURE(k);
    REQUIRE(ticked[k] >= due(k));
  }
}

TEST_CASE("pacer: Stop() ends a pending wait without its tick", "[pipeline][unit]") {
  std::atomic<int> ticks{0};
  std::atomic<bool> exited{false};
  Pacer pacer([&] { ++ticks; }, [&] { exited = true; });
  pacer.Start();
  pacer.Schedule(Clock::now() + std::chrono::hours(1));
  pacer.Stop();
  pacer.Join();  // returns at once: a pacer that waited out its tick would time the test out
  REQUIRE(ticks == 0);
  REQUIRE(exited);
  pacer.Schedule(Clock::now());  // after Stop(): ignored
  REQUIRE(ticks == 0);
}

TEST_CASE("pacer: the caller's own wait returns at a past time, and not after Stop()", "[pipeline][unit]") {
  Pacer pacer([] {});
  REQUIRE(pacer.WaitUntil(Clock::now() - std::chrono::seconds(1)));
  pacer.Stop();
  REQUIRE_FALSE(pacer.WaitUntil(Clock::now() + std::chrono::hours(1)));
}

}  // namespace
}  // namespace dg::pipeline
