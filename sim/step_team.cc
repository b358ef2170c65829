#include "sim/step_team.h"

#include <algorithm>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "sim/error.h"

namespace dg::sim {
namespace {

// Pauses before a waiter sleeps: about 100 us on current x86 cores (a PAUSE
// is some 40-140 cycles), longer than a balanced pass's imbalance, shorter
// than an oversubscribed core's time slice.
constexpr int kSpinPauses = 4096;

inline void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

}  // namespace

StepTeam::StepTeam(int threads) : size_(threads), claims_(std::max(threads, 1)) {
  DG_CHECK(threads >= 1 && threads <= kMaxEvenSplit);
  threads_.reserve(size_ - 1);
  for (int worker = 1; worker < size_; ++worker) threads_.emplace_back([this, worker] { WorkerLoop(worker); });
}

StepTeam::~StepTeam() {
  stopping_ = true;
  Publish(run_generation_, run_sleepers_);
  for (std::thread& thread : threads_) thread.join();
}

void StepTeam::Run(const std::function<void(int worker)>& body) {
  failed_ = false;
  error_ = nullptr;
  for (Claim& claim : claims_) claim.next.store(0, std::memory_order_relaxed);
  if (size_ > 1) {
    body_ = &body;
    running_.store(size_ - 1, std::memory_order_relaxed);
    const std::uint32_t done = done_generation_.load(std::memory_order_acquire);
    Publish(run_generation_, run_sleepers_);
    body(0);
    WaitWhileEquals(done_generation_, done, done_sleepers_);
  } else {
    body(0);
  }
  if (error_) std::rethrow_exception(error_);
}

void StepTeam::WorkerLoop(int worker) {
  std::uint32_t seen = 0;
  for (;;) {
    WaitWhileEquals(run_generation_, seen, run_sleepers_);
    seen = run_generation_.load(std::memory_order_acquire);
    if (stopping_) return;
    (*body_)(worker);
    if (running_.fetch_sub(1, std::memory_order_acq_rel) == 1) Publish(done_generation_, done_sleepers_);
  }
}

void StepTeam::WaitWhileEquals(const std::atomic<std::uint32_t>& value, std::uint32_t seen,
                               std::atomic<int>& sleepers) {
  for (int i = 0; i < kSpinPauses; ++i) {
    if (value.load(std::memory_order_acquire) != seen) return;
    CpuRelax();
  }
  // Announce the sleep before checking once more: Publish() moves the value
  // on before it reads the count, so either it sees this sleeper or this
  // check sees the new value (both sequentially consistent).
  sleepers.fetch_add(1, std::memory_order_seq_cst);
  while (value.load(std::memory_order_seq_cst) == seen) value.wait(seen, std::memory_order_seq_cst);
  sleepers.fetch_sub(1, std::memory_order_relaxed);
}

void StepTeam::Publish(std::atomic<std::uint32_t>& value, std::atomic<int>& sleepers) {
  value.fetch_add(1, std::memory_order_seq_cst);
  if (sleepers.load(std::memory_order_seq_cst) > 0) value.notify_all();
}

int DefaultTeamSize() {
  const int allowed =
      static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return std::clamp(std::min(allowed, tbb::this_task_arena::max_concurrency()), 1, StepTeam::kMaxEvenSplit);
}

}  // namespace dg::sim
