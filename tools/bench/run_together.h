#pragma once

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

namespace dg::tools {

// Runs work(t, start) for t = 0 .. threads - 1 at once: t = 0 on the caller,
// the others on threads of their own, all released together at `start` once
// every thread is running, so that what they time or probe overlaps. Returns
// `start` when all have finished.
template <typename Work>
std::chrono::steady_clock::time_point RunTogether(int threads, const Work& work) {
  std::atomic<int> ready{0};
  std::atomic<bool> go{false};
  std::chrono::steady_clock::time_point start;
  std::vector<std::thread> others;
  for (int t = 1; t < threads; ++t) {
    others.emplace_back([&, t] {
      ready.fetch_add(1);
      while (!go.load(std::memory_order_acquire)) std::this_thread::yield();
      work(t, start);
    });
  }
  // Yielding while the others start: on a machine of as many cores as
  // threads, a spinning caller would hold a core they need.
  while (ready.load() < threads - 1) std::this_thread::yield();
  start = std::chrono::steady_clock::now();
  go.store(true, std::memory_order_release);
  work(0, start);
  for (std::thread& thread : others) thread.join();
  return start;
}

}  // namespace dg::tools
