// How `bench sim` times its configurations: in rounds, every configuration
// once a round, so that each samples the same minutes of a drifting host; and
// what its records then hold. No time is asserted, only the schedule and how
// the repeats are summarised.
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "io/gmsh_mesher.h"
#include "tests/support/temporary_folder.h"
#include "tools/bench/host_interruptions.h"
#include "tools/bench/rounds.h"
#include "tools/bench/sim_bench.h"

namespace dg::tools {
namespace {

TEST_CASE("TimeInRounds warms every configuration, then runs one repeat of each per round", "[tools][unit]") {
  std::vector<std::string> calls;
  std::vector<TimedConfiguration> configurations(3);
  for (int k = 0; k < 3; ++k) {
    configurations[k].steps_per_repeat = 40 * (k + 1);
    configurations[k].work_per_step = 10;
    configurations[k].advance = [&calls, k](int steps) {
      calls.push_back(std::to_string(k) + ":" + std::to_string(steps));
    };
  }
  configurations[1].after_warm_up = [&calls] { calls.push_back("1 warm"); };
  TimeInRounds(configurations, 2, [&calls] { calls.push_back("between"); });
  const std::vector<std::string> expected = {"0:11", "1:21", "1 warm", "2:31",      // warm-ups, a quarter and one step
                                             "0:40", "1:80", "2:120", "between",  // round 1
                                             "0:40", "1:80", "2:120", "between"}; // round 2
  CHECK(calls == expected);
  for (const TimedConfiguration& configuration : configurations) {
    REQUIRE(configuration.rates.size() == 2);
    CHECK(configuration.rates[0] <= configuration.rates[1]);
    CHECK(configuration.rates[0] > 0);
  }
  CHECK(MedianOfSorted({1, 2, 3}) == 2);
  CHECK(MedianOfSorted({}) == 0);
}

TEST_CASE("bench sim: every thread count's record from the same rounds, with its controls",
          "[tools][integration]") {
  SimBenchOptions options;
  options.tets = {600};
  options.threads = {1, 2};
  options.precisions = {sim::Precision::kFloat};
  options.repeats = 3;
  options.simulated_per_repeat_s = 0.004;  // 20 steps
  const std::vector<SimBenchRecord> records = RunSimBench(options, false);
  REQUIRE(records.size() == 2);
  for (const SimBenchRecord& r : records) {
    CHECK(r.mode == "forward");
    CHECK(r.repeats == 3);
    CHECK(r.steps_per_repeat == 20);
    CHECK(r.tet_steps_per_s_min <= r.tet_steps_per_s);
    CHECK(r.tet_steps_per_s <= r.tet_steps_per_s_max);
    CHECK(r.tet_steps_per_s_min > 0);
    CHECK(r.resident_mb > 0);
  }
  const SimBenchRecord &one = records[0], &two = records[1];
  CHECK(one.threads == 1);
  CHECK(one.speedup_over_1_thread == 1.0);
  CHECK(one.barrier_ns == 0);  // no team to synchronise
  CHECK(one.nothing_shared_tet_steps_per_s == 0);
  CHECK(one.working_us_per_step.empty());  // one thread: nothing to wait for
  CHECK(one.host.per_core_percent == 0);
  CHECK(two.threads == 2);
  CHECK(two.speedup_over_1_thread == Approx(two.tet_steps_per_s / one.tet_steps_per_s));
  CHECK(two.barrier_ns > 0);
  CHECK(two.nothing_shared_tet_steps_per_s > 0);
  // Each one-thread solver's own rate: in every repeat it ends no later than
  // the last, whose end times their rate together, so its median is at least
  // half of theirs (an order statistic of larger values).
  CHECK(one.each_core_alone_tet_steps_per_s.empty());
  REQUIRE(two.each_core_alone_tet_steps_per_s.size() == 2);
  for (double rate : two.each_core_alone_tet_steps_per_s) CHECK(rate >= two.nothing_shared_tet_steps_per_s / 2);
  // Each worker that joined (the helper may not on a busy machine) worked, and
  // the long waits are part of the time at the barrier.
  CHECK(two.working_us_per_step.size() >= 1);
  CHECK(two.working_us_per_step.size() <= 2);
  for (double us : two.working_us_per_step) CHECK(us > 0);
  CHECK(two.long_waits_us_per_step >= 0);
  CHECK(two.long_waits_us_per_step <= two.barrier_us_per_step);
  CHECK(two.host.any_core_percent >= two.host.per_core_percent);
  CHECK(one.mesh_tets == two.mesh_tets);
  // Each core's load/store speed, sampled between the same rounds: one figure a core, in both records.
  REQUIRE(one.core_load_store_gb_s.size() == std::max(1u, std::thread::hardware_concurrency()));
  REQUIRE(two.core_load_store_gb_s.size() == one.core_load_store_gb_s.size());
  for (size_t core = 0; core < one.core_load_store_gb_s.size(); ++core) {
    CHECK(std::isnan(two.core_load_store_gb_s[core]) == std::isnan(one.core_load_store_gb_s[core]));
    if (!std::isnan(one.core_load_store_gb_s[core])) CHECK(two.core_load_store_gb_s[core] == one.core_load_store_gb_s[core]);
  }
  for (double gb_s : one.core_load_store_gb_s) CHECK((std::isnan(gb_s) || gb_s > 0));  // NaN: outside the cpuset
  CHECK(one.core_load_store_gb_s[sched_getcpu()] > 0);  // a core this thread runs on
}

TEST_CASE("bench sim: a mesh and its shuffled copy are timed in the same rounds", "[tools][integration]") {
  SimBenchOptions options;
  options.tets = {600};
  options.threads = {1, 2};
  options.precisions = {sim::Precision::kFloat};
  options.repeats = 3;
  options.simulated_per_repeat_s = 0.004;
  options.shuffled_too = true;
  const std::vector<SimBenchRecord> records = RunSimBench(options, false);
  REQUIRE(records.size() == 4);
  const SimBenchRecord &shuffled = records[1], &original = records[3];
  CHECK(shuffled.mesh == "Gmsh box, nodes shuffled");
  CHECK(original.mesh == "Gmsh box");
  CHECK(shuffled.mesh_tets == original.mesh_tets);
  // The machine is sampled between rounds: one set of samples serves both
  // orders, so their barrier and host figures are the same numbers.
  CHECK(shuffled.threads == 2);
  CHECK(original.threads == 2);
  CHECK(shuffled.barrier_ns == original.barrier_ns);
  CHECK(shuffled.host.any_core_percent == original.host.any_core_percent);
  CHECK(shuffled.nothing_shared_tet_steps_per_s > 0);
  CHECK(original.nothing_shared_tet_steps_per_s > 0);
  CHECK(records[0].speedup_over_1_thread == 1.0);
  CHECK(original.speedup_over_1_thread == Approx(original.tet_steps_per_s / records[2].tet_steps_per_s));
}

// A mesh file and boxes asked for beside it (`--mesh` with `--tets`): the
// boxes are timed in the file's rounds, so the two share one sample of the
// machine; the file, written from a generated box, is that box's mesh.
TEST_CASE("bench sim: boxes beside a mesh file are timed in the file's rounds", "[tools][integration]") {
  const testing::TemporaryFolder folder("bench_boxes_beside_file");
  const std::string path = folder.File("box.msh");
  io::WriteMsh(io::MeshBox({Eigen::Vector3d(0.05, 0.05, 0.05), 600}), path, 41);
  SimBenchOptions options;
  options.mesh_path = path;
  options.tets = {600};
  options.boxes_beside_file = true;
  options.threads = {1, 2};
  options.precisions = {sim::Precision::kFloat};
  options.repeats = 3;
  options.simulated_per_repeat_s = 0.004;
  const std::vector<SimBenchRecord> records = RunSimBench(options, false);
  REQUIRE(records.size() == 4);
  const SimBenchRecord &file = records[1], &box = records[3];
  CHECK(records[0].mesh == path);
  CHECK(records[2].mesh == "Gmsh box");
  CHECK(file.mesh == path);
  CHECK(box.mesh == "Gmsh box");
  CHECK(file.mesh_tets == box.mesh_tets);
  CHECK(file.mesh_nodes == box.mesh_nodes);
  CHECK(file.threads == 2);
  CHECK(box.threads == 2);
  CHECK(file.barrier_ns == box.barrier_ns);
  CHECK(file.host.any_core_percent == box.host.any_core_percent);
  CHECK(box.speedup_over_1_thread == Approx(box.tet_steps_per_s / records[2].tet_steps_per_s));
  // Without the option the file is timed alone.
  options.boxes_beside_file = false;
  options.threads = {1};
  const std::vector<SimBenchRecord> alone = RunSimBench(options, false);
  REQUIRE(alone.size() == 1);
  CHECK(alone[0].mesh == path);
}

// The share of a span the union of gap intervals covers: overlapping,
// nested, unsorted and partly outside intervals, counted once.
TEST_CASE("host interruptions: the union of gaps, clipped to the span", "[tools][unit]") {
  // Over [0, 10): [0, 0.5) + [1, 5) + [7, 8) + [9, 10) = 6.5.
  CHECK(CoveredFraction({{2, 5}, {1, 3}, {7, 8}, {-1, 0.5}, {9, 12}, {1.5, 2.5}}, 0, 10) == Approx(0.65));
  CHECK(CoveredFraction({}, 0, 10) == 0);
  CHECK(CoveredFraction({{11, 12}}, 0, 10) == 0);
  CHECK(CoveredFraction({{-5, 15}}, 0, 10) == 1);
  CHECK(CoveredFraction({{1, 2}}, 3, 3) == 0);
  // Two cores probed at once: at least one is interrupted whenever either is.
  const HostInterruptions host = MeasureHostInterruptions(2, std::chrono::milliseconds(20));
  CHECK(host.per_core_percent >= 0);
  CHECK(host.any_core_percent >= host.per_core_percent);
  CHECK(host.any_core_percent <= 100);
  CHECK(host.gaps_per_ms >= 0);
}

}  // namespace
}  // namespace dg::tools
