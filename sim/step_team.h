#pragma once

#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <span>
#include <thread>
#include <vector>

#include "sim/error.h"

namespace dg::sim {

// A fixed team of threads that runs a time-stepping loop together, in the
// shape explicit FEM and molecular-dynamics codes use (docs/solver.md,
// "Threading"):
//  - the workers live as long as the team, parked between runs, so a step
//    costs no task spawning and no wake-up;
//  - each pass of a step hands out fixed chunks, every worker starting on its
//    own home range (the same chunks every step, so their data stays in that
//    core's cache) and taking the rest of another's range once its own is
//    done, so a worker the machine delays does not hold up the step;
//  - a barrier ends each pass, and its serial section (the step's few
//    reductions and checks) runs on the last worker to arrive before any
//    leaves.
// Waiting spins briefly, then sleeps on a futex (std::atomic::wait), so a team
// on an oversubscribed machine does not burn the core another thread needs.
// Which worker runs a chunk never changes what the chunk computes: results do
// not depend on the team's size.
//
// Run() is called from one thread at a time.
class StepTeam {
 public:
  // threads >= 1: the caller of Run() is worker 0; threads - 1 more start here.
  explicit StepTeam(int threads);
  ~StepTeam();
  StepTeam(const StepTeam&) = delete;
  StepTeam& operator=(const StepTeam&) = delete;

  int size() const { return size_; }
  // The largest team ForEachChunk(worker, count, body) splits on the stack.
  static constexpr int kMaxEvenSplit = 64;

  // Runs body(worker) on every worker at once; returns when all have returned.
  // Every worker must make the same sequence of Sync() calls. Rethrows the
  // first exception a serial section threw.
  void Run(const std::function<void(int worker)>& body);

  // Inside Run(): body(chunk) for every chunk in [homes[0], homes[size()]),
  // each exactly once over the team, worker w starting on its home range
  // [homes[w], homes[w + 1]) (non-decreasing). The pass must end with Sync()
  // before the next one.
  template <typename Body>
  void ForEachChunk(int worker, std::span<const int> homes, Body&& body);
  // The same with [0, count) split evenly.
  template <typename Body>
  void ForEachChunk(int worker, int count, Body&& body);

  // Inside Run(): waits until every worker has arrived; serial() runs on
  // exactly one of them before any leaves, and its writes are visible to all
  // after. Returns false once a serial section has thrown: every worker then
  // sees false at the same Sync() and must return from its body.
  template <typename Serial>
  bool Sync(Serial&& serial);
  bool Sync() {
    return Sync([] {});
  }

 private:
  struct alignas(64) Claim {
    std::atomic<int> next{0};
  };

  void WorkerLoop(int worker);
  // Spins, then sleeps, until `value` differs from `seen`.
  static void WaitWhileEquals(const std::atomic<std::uint32_t>& value, std::uint32_t seen,
                              std::atomic<int>& sleepers);
  static void Publish(std::atomic<std::uint32_t>& value, std::atomic<int>& sleepers);
  // A serial section: serial() unless one already threw, then the claims reset for the next pass.
  template <typename Serial>
  void RunSerial(Serial& serial);

  int size_ = 1;
  std::vector<Claim> claims_;  // per worker: the next chunk of its home range to hand out
  std::vector<std::thread> threads_;

  // Start of a run: workers wait for run_generation_ to move on.
  alignas(64) std::atomic<std::uint32_t> run_generation_{0};
  std::atomic<int> run_sleepers_{0};
  const std::function<void(int)>* body_ = nullptr;
  bool stopping_ = false;

  // The barrier: arrivals counted, released by moving barrier_generation_ on.
  alignas(64) std::atomic<int> arrived_{0};
  alignas(64) std::atomic<std::uint32_t> barrier_generation_{0};
  std::atomic<int> barrier_sleepers_{0};
  bool failed_ = false;               // a serial section threw (written in a serial section)
  std::exception_ptr error_;

  // End of a run: workers still inside the body.
  alignas(64) std::atomic<int> running_{0};
  std::atomic<std::uint32_t> done_generation_{0};
  std::atomic<int> done_sleepers_{0};
};

// The team size the process's parallelism allows: TBB's active
// max_allowed_parallelism (set by tbb::global_control, e.g. --threads), at
// most the current arena's concurrency.
int DefaultTeamSize();

template <typename Body>
void StepTeam::ForEachChunk(int worker, int count, Body&& body) {
  if (size_ == 1) {
    for (int chunk = 0; chunk < count; ++chunk) body(chunk);
    return;
  }
  int homes[kMaxEvenSplit + 1];
  DG_CHECK(size_ <= kMaxEvenSplit);
  for (int w = 0; w <= size_; ++w) homes[w] = static_cast<int>(std::int64_t(count) * w / size_);
  ForEachChunk(worker, std::span<const int>(homes, size_ + 1), std::forward<Body>(body));
}

template <typename Body>
void StepTeam::ForEachChunk(int worker, std::span<const int> homes, Body&& body) {
  for (int k = 0; k < size_; ++k) {
    const int owner = (worker + k) % size_;
    const int begin = homes[owner];
    const int end = homes[owner + 1];
    for (;;) {
      const int chunk = begin + claims_[owner].next.fetch_add(1, std::memory_order_relaxed);
      if (chunk >= end) break;
      body(chunk);
    }
  }
}

template <typename Serial>
bool StepTeam::Sync(Serial&& serial) {
  if (size_ == 1) {
    RunSerial(serial);
    return !failed_;
  }
  const std::uint32_t generation = barrier_generation_.load(std::memory_order_acquire);
  if (arrived_.fetch_add(1, std::memory_order_acq_rel) == size_ - 1) {
    arrived_.store(0, std::memory_order_relaxed);
    RunSerial(serial);
    Publish(barrier_generation_, barrier_sleepers_);
  } else {
    WaitWhileEquals(barrier_generation_, generation, barrier_sleepers_);
  }
  return !failed_;
}

template <typename Serial>
void StepTeam::RunSerial(Serial& serial) {
  if (!failed_) {
    try {
      serial();
    } catch (...) {
      failed_ = true;
      error_ = std::current_exception();
    }
  }
  for (Claim& claim : claims_) claim.next.store(0, std::memory_order_relaxed);
}

}  // namespace dg::sim
