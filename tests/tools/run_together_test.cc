// RunTogether, which the host probes and the nothing-shared solvers run on:
// each thread works on a CPU of its own, and the caller keeps its affinity.
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <vector>

#include <catch2/catch.hpp>

#include "tools/bench/run_together.h"

namespace dg::tools {
namespace {

bool SameAffinity(const cpu_set_t& a, const cpu_set_t& b) { return CPU_EQUAL(&a, &b); }

TEST_CASE("RunTogether: each thread on a CPU of its own, the caller's affinity kept", "[tools][unit]") {
  const std::vector<int> cpus = AllowedCpus();
  REQUIRE(!cpus.empty());
  CHECK(std::is_sorted(cpus.begin(), cpus.end()));
  CHECK(std::find(cpus.begin(), cpus.end(), sched_getcpu()) != cpus.end());
  cpu_set_t before;
  REQUIRE(pthread_getaffinity_np(pthread_self(), sizeof before, &before) == 0);

  const int threads = static_cast<int>(std::min<size_t>(cpus.size(), 4));
  std::vector<int> ran_on(threads, -1);
  std::atomic<int> calls{0};
  RunTogether(threads, [&](int t, std::chrono::steady_clock::time_point) {
    ran_on[t] = sched_getcpu();
    calls.fetch_add(1);
  });
  CHECK(calls.load() == threads);
  // Pinned: thread t ran on the t-th allowed CPU, so no two shared one.
  for (int t = 0; t < threads; ++t) CHECK(ran_on[t] == cpus[t]);

  cpu_set_t after;
  REQUIRE(pthread_getaffinity_np(pthread_self(), sizeof after, &after) == 0);
  CHECK(SameAffinity(before, after));
}

TEST_CASE("RunTogether: more threads than CPUs run unpinned, each once", "[tools][unit]") {
  cpu_set_t caller;
  REQUIRE(pthread_getaffinity_np(pthread_self(), sizeof caller, &caller) == 0);
  const int threads = static_cast<int>(AllowedCpus().size()) + 1;
  std::vector<int> ran(threads, 0);
  std::vector<char> kept_caller_cpus(threads, 0);
  RunTogether(threads, [&](int t, std::chrono::steady_clock::time_point) {
    ++ran[t];
    cpu_set_t mine;
    kept_caller_cpus[t] = pthread_getaffinity_np(pthread_self(), sizeof mine, &mine) == 0 && SameAffinity(mine, caller);
  });
  for (int t = 0; t < threads; ++t) {
    CHECK(ran[t] == 1);
    CHECK(kept_caller_cpus[t]);
  }
}

}  // namespace
}  // namespace dg::tools
