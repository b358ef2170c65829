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
    const std::vector<int> homes = workers == 3 ? std::vector<int>{0, 5, 30, kChunks} : std::vector<int>{};
    team.Run(
        kPasses,
        [&](int worker, int) {
          auto body = [&](int c) { runs[c].fetch_add(1, std::memory_order_relaxed); };
          if (homes.empty()) {
            team.ForEachChunk(worker, kChunks, body);
          } else {
            team.ForEachChunk(worker, homes, body);
          }
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
