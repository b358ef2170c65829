#include "sim/step_team.h"

#include <atomic>
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
              StepTeam::ThenWaitsFor::kOwnRange);
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
// and a `then` chunk starts only after the `first` chunks it waits for, its
// own range's or all, whoever joins and whoever takes what.
TEST_CASE("step team: second-phase chunks after the first-phase chunks they wait for", "[sim][unit]") {
  constexpr int kFirst = 41, kThen = 29, kPasses = 400;
  for (StepTeam::ThenWaitsFor waits : {StepTeam::ThenWaitsFor::kOwnRange, StepTeam::ThenWaitsFor::kAllRanges}) {
    for (int workers : {1, 2, 3}) {
      StepTeam team(workers);
      // Uneven ranges, one of them empty in the second phase.
      const std::vector<int> first_homes = workers == 1   ? std::vector<int>{0, kFirst}
                                           : workers == 2 ? std::vector<int>{0, 30, kFirst}
                                                          : std::vector<int>{0, 3, 33, kFirst};
      const std::vector<int> then_homes = workers == 1   ? std::vector<int>{0, kThen}
                                          : workers == 2 ? std::vector<int>{0, 9, kThen}
                                                         : std::vector<int>{0, 12, 12, kThen};
      std::vector<std::atomic<int>> first_runs(kFirst), then_runs(kThen);
      std::atomic<int> early_starts{0};
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
                  int range = 0;
                  while (then_homes[range + 1] <= c) ++range;
                  const bool own = waits == StepTeam::ThenWaitsFor::kOwnRange;
                  const int begin = own ? first_homes[range] : 0, end = own ? first_homes[range + 1] : kFirst;
                  for (int f = begin; f < end; ++f) {
                    if (first_runs[f].load(std::memory_order_acquire) != pass + 1) early_starts.fetch_add(1);
                  }
                  then_runs[c].fetch_add(1, std::memory_order_relaxed);
                },
                waits);
          },
          [&](int pass) {
            for (const std::atomic<int>& r : first_runs) all_done_each_pass &= r.load() == pass + 1;
            for (const std::atomic<int>& r : then_runs) all_done_each_pass &= r.load() == pass + 1;
            return true;
          });
      INFO("workers " << workers << ", waiting for " << (waits == StepTeam::ThenWaitsFor::kOwnRange ? "own" : "all"));
      REQUIRE(all_done_each_pass);
      REQUIRE(early_starts.load() == 0);
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

}  // namespace
}  // namespace dg::sim
