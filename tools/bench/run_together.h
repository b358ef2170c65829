#pragma once

#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

namespace dg::tools {

// The CPUs this thread may run on, in ascending order.
inline std::vector<int> AllowedCpus() {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  std::vector<int> cpus;
  if (pthread_getaffinity_np(pthread_self(), sizeof allowed, &allowed) != 0) return cpus;
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
    if (CPU_ISSET(cpu, &allowed)) cpus.push_back(cpu);
  }
  return cpus;
}

// Runs work(t, start) for t = 0 .. threads - 1 at once: t = 0 on the caller,
// the others on threads of their own, all released together at `start` once
// every thread is running, so that what they time or probe overlaps. Returns
// `start` when all have finished.
//
// With no more threads than allowed CPUs, thread t works pinned to the t-th
// of them (the caller's own affinity is restored after; where the system
// refuses, they run unpinned). Unpinned, two new threads now and then start
// on one CPU and share it for milliseconds before the scheduler spreads
// them, and what they measure is then the sharing, not the machine
// (docs/benchmarks.md, "dynaguide bench sim": the nothing-shared rate).
template <typename Work>
std::chrono::steady_clock::time_point RunTogether(int threads, const Work& work) {
  const std::vector<int> cpus = AllowedCpus();
  const bool pin = threads <= static_cast<int>(cpus.size());
  auto pin_to = [&](int t) {
    if (!pin) return;
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpus[t], &one);
    pthread_setaffinity_np(pthread_self(), sizeof one, &one);
  };
  std::atomic<int> ready{0};
  std::atomic<bool> go{false};
  std::chrono::steady_clock::time_point start;
  std::vector<std::thread> others;
  for (int t = 1; t < threads; ++t) {
    others.emplace_back([&, t] {
      pin_to(t);
      ready.fetch_add(1);
      while (!go.load(std::memory_order_acquire)) std::this_thread::yield();
      work(t, start);
    });
  }
  cpu_set_t caller_cpus;
  const bool restore = pin && pthread_getaffinity_np(pthread_self(), sizeof caller_cpus, &caller_cpus) == 0;
  pin_to(0);
  // Yielding while the others start: on a machine of as many cores as
  // threads, a spinning caller would hold a core they need.
  while (ready.load() < threads - 1) std::this_thread::yield();
  start = std::chrono::steady_clock::now();
  go.store(true, std::memory_order_release);
  work(0, start);
  for (std::thread& thread : others) thread.join();
  if (restore) pthread_setaffinity_np(pthread_self(), sizeof caller_cpus, &caller_cpus);
  return start;
}

}  // namespace dg::tools
