#include "sim/step_team.h"

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <vector>

#include <catch2/catch.hpp>

namespace dg::sim {
namespace {

// Every chunk of every pass runs exactly once, whoever joins, and each pass's
// serial section sees all of its chunks done (it runs after the barrier).
TEST_CASE("step team: each chunk once per pass, the serial section after all of them", "[sim][unit]") {
  constexpr int kChunks = 37, kPasses = 400;
  for (int workers : {1, 2, 3}) {
    StepTeam team(workers);
    std::vector<std::atomic<int>> runs(kChunks);
    int serial_calls = 0;
    bool all_done_each_pass = true;
    // Even ranges, uneven with three; no second phase.
    std::vector<int> homes(workers + 1);
    for (int w = 0; w <= workers; ++w) homes[w] = kChunks * w / workers;
    if (workers == 3) homes = {0, 5, 30, kChunks};
    const std::vector<int> none(workers + 1, 0);
    team.Run(
        kPasses,
        [&](int worker, int) {
          team.ForEachChunkThen(
              worker, homes, [&](int c) { runs[c].fetch_add(1, std::memory_order_relaxed); }, none, [](int) {},
              StepTeam::ThenOrder{true, {}, {}});
        },
        [&](int pass) {
          ++serial_calls;
          for (const std::atomic<int>& r : runs) all_done_each_pass &= r.load() == pass + 1;
          return true;
        });
    REQUIRE(serial_calls == kPasses);
    REQUIRE(all_done_each_pass);
  }
}

// ForEachChunkThen: every chunk of both phases runs exactly once per pass,
// and a `then` chunk starts only after the `first` chunks it reads are done
// (all of them, or the first `needs` of its own range), whoever joins and
// whoever takes what. Per range, a worker alone runs each `then` chunk as
// soon as those chunks are done, not after its whole range.
TEST_CASE("step team: second-phase chunks after the first-phase chunks they read", "[sim][unit]") {
  constexpr int kFirst = 41, kThen = 29, kPasses = 400;
  for (bool per_range : {true, false}) {
    for (int workers : {1, 2, 3}) {
      StepTeam team(workers);
      // Uneven ranges, one of them empty in the second phase.
      const std::vector<int> first_homes = workers == 1   ? std::vector<int>{0, kFirst}
                                           : workers == 2 ? std::vector<int>{0, 30, kFirst}
                                                          : std::vector<int>{0, 3, 33, kFirst};
      const std::vector<int> then_homes = workers == 1   ? std::vector<int>{0, kThen}
                                          : workers == 2 ? std::vector<int>{0, 9, kThen}
                                                         : std::vector<int>{0, 12, 12, kThen};
      // Per range: its `then` chunks in reverse, the k-th of n reading the
      // first (k + 1) / n of the range's `first` chunks, rounded down.
      StepTeam::ThenOrder then_order{per_range, {}, {}};
      std::vector<int> range_of_then(kThen), needs_of_then(kThen);
      for (int range = 0; range < workers && per_range; ++range) {
        const int count = then_homes[range + 1] - then_homes[range];
        for (int k = 0; k < count; ++k) {
          const int chunk = then_homes[range + 1] - 1 - k;
          then_order.order.push_back(chunk);
          then_order.needs.push_back((k + 1) * (first_homes[range + 1] - first_homes[range]) / count);
          needs_of_then[chunk] = then_order.needs.back();
        }
      }
      for (int range = 0; range < workers; ++range) {
        for (int c = then_homes[range]; c < then_homes[range + 1]; ++c) range_of_then[c] = range;
      }
      std::vector<std::atomic<int>> first_runs(kFirst), then_runs(kThen);
      std::atomic<int> early_starts{0}, late_starts{0};
      bool all_done_each_pass = true;
      team.Run(
          kPasses,
          [&](int worker, int pass) {
            team.ForEachChunkThen(
                worker, first_homes,
                [&](int c) {
                  // Some work, so that chunks are taken and still running when their range ends.
                  volatile double sink = 0;
                  for (int i = 0; i < 2000; ++i) sink = sink + i;
                  first_runs[c].fetch_add(1, std::memory_order_release);
                },
                then_homes,
                [&](int c) {
                  const int range = range_of_then[c];
                  const int begin = per_range ? first_homes[range] : 0;
                  const int end = per_range ? begin + needs_of_then[c] : kFirst;
                  for (int f = begin; f < end; ++f) {
                    if (first_runs[f].load(std::memory_order_acquire) != pass + 1) early_starts.fetch_add(1);
                  }
                  if (per_range && end < first_homes[range + 1] &&
                      first_runs[end].load(std::memory_order_acquire) == pass + 1) {
                    late_starts.fetch_add(1);
                  }
                  then_runs[c].fetch_add(1, std::memory_order_relaxed);
                },
                then_order);
          },
          [&](int pass) {
            for (const std::atomic<int>& r : first_runs) all_done_each_pass &= r.load() == pass + 1;
            for (const std::atomic<int>& r : then_runs) all_done_each_pass &= r.load() == pass + 1;
            return true;
          });
      INFO("workers " << workers << (per_range ? ", per range" : ", after all"));
      REQUIRE(all_done_each_pass);
      REQUIRE(early_starts.load() == 0);
      // Alone, nobody takes: each `then` chunk runs between the last `first`
      // chunk it reads and the next one.
      if (workers == 1) REQUIRE(late_starts.load() == 0);
    }
  }
}

// A serial section that throws stops the run at that pass, on every worker,
// and Run() rethrows it; one that returns false stops it quietly.
TEST_CASE("step team: a failing or stopping serial section ends the run", "[sim][unit]") {
  StepTeam team(2);
  int passes_run = 0;
  REQUIRE_THROWS_WITH(team.Run(
                          100, [&](int, int) {},
                          [&](int pass) {
                            passes_run = pass + 1;
                            if (pass == 41) throw std::runtime_error("inverted element");
                            return true;
                          }),
                      "inverted element");
  REQUIRE(passes_run == 42);
  team.Run(
      100, [&](int, int) {},
      [&](int pass) {
        passes_run = pass + 1;
        return pass < 9;
      });
  REQUIRE(passes_run == 10);
}

// Timing accounts for the caller's whole run: its time in passes, waiting
// and in serial sections adds up to the run's wall time (no interval lost or
// counted twice), each worker counts the passes it worked, and a reset clears it.
TEST_CASE("step team: each worker's time in passes, at barriers and in serial sections", "[sim][unit]") {
  constexpr int kPasses = 2000;  // some 30 ms
  StepTeam team(2);
  auto spin = [](int iterations) {
    volatile double sink = 0;
    for (int i = 0; i < iterations; ++i) sink = sink + i;
  };
  // The first run starts TBB's threads; timing starts over after it.
  team.Run(10, [&](int, int) { spin(100); }, [&](int) { return true; });
  team.ResetTiming();
  const auto start = std::chrono::steady_clock::now();
  team.Run(
      kPasses, [&](int worker, int) { spin(worker == 0 ? 2000 : 6000); }, [&](int) { return true; });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::vector<StepTeam::WorkerTime> times = team.Timing();
  REQUIRE(times.size() == 2);
  const StepTeam::WorkerTime& caller = times[0];
  CHECK(caller.passes == kPasses);
  CHECK(caller.working_s > 0);
  const double accounted_s = caller.working_s + caller.waiting_s + caller.serial_s;
  CHECK(accounted_s <= wall_s);
  // Unaccounted: Run()'s set-up and end, and the helper's launch (on a busy
  // machine the caller may be preempted there). A worker's waiting or serial
  // sections left out would miss half the run or more: the helper spins
  // three times as long a pass as the caller.
  CHECK(accounted_s >= 0.98 * wall_s - 1e-3);
  CHECK(caller.long_waiting_s <= caller.waiting_s);
  // The helper works from the pass after it joined (none on a busy machine).
  CHECK(times[1].passes <= kPasses);
  CHECK((times[1].passes > 0) == (times[1].working_s > 0));

  team.ResetTiming();
  for (const StepTeam::WorkerTime& time : team.Timing()) {
    CHECK(time.passes == 0);
    CHECK(time.working_s + time.waiting_s + time.serial_s == 0);
  }
  // A team of one has nothing to wait for and does not time its passes.
  StepTeam alone(1);
  alone.Run(10, [&](int, int) { spin(100); }, [&](int) { return true; });
  REQUIRE(alone.Timing().size() == 1);
  CHECK(alone.Timing()[0].passes == 0);
}

}  // namespace
}  // namespace dg::sim
