#include "sim/step_team.h"

#include <algorithm>
#include <thread>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

namespace dg::sim {
namespace {

// Pauses before a waiter sleeps: about 100 us on current x86 cores (a PAUSE
// is some 40-140 cycles), longer than a balanced pass's imbalance, shorter
// than an oversubscribed core's time slice.
constexpr int kSpinPauses = 4096;

// The most a taken chunk may count for, in chunks of the taker's own range.
constexpr double kMaxTakeCost = 8;

inline void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

// Spins, then sleeps, until `value` differs from `seen`.
void WaitWhileEquals(const std::atomic<std::uint32_t>& value, std::uint32_t seen, std::atomic<int>& sleepers) {
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

// Moves `value` on and wakes its sleepers, if any.
void Publish(std::atomic<std::uint32_t>& value, std::atomic<int>& sleepers) {
  value.fetch_add(1, std::memory_order_seq_cst);
  if (sleepers.load(std::memory_order_seq_cst) > 0) value.notify_all();
}

}  // namespace

StepTeam::StepTeam(int workers, std::function<void(std::function<void()>)> launch)
    : size_(workers), launch_(std::move(launch)) {
  DG_CHECK(workers >= 1 && workers <= kMaxWorkers);
  if (!launch_) launch_ = [](std::function<void()> work) { tbb::this_task_arena::enqueue(std::move(work)); };
  state_ = std::make_shared<State>(workers);
}

StepTeam::~StepTeam() = default;

void StepTeam::Run(int passes, const std::function<void(int worker, int pass)>& pass,
                   const std::function<bool(int pass)>& after) {
  if (passes <= 0) return;
  State& s = *state_;
  WaitForHelpers();  // before the state is reset
  s.pass = &pass;
  s.after = &after;
  s.passes = passes;
  s.current_pass = 0;
  s.finished = false;
  s.failed = false;
  s.error = nullptr;
  s.members = 1;
  ResetClaims(s);
  const std::uint32_t id = ++s.last_run_id == 0 ? ++s.last_run_id : s.last_run_id;
  s.run_id.store(id, std::memory_order_seq_cst);
  for (int worker = 1; worker < size_; ++worker) {
    launch_([state = state_, worker, id] { Help(state, worker, id); });
  }
  WorkPasses(s, 0);
  s.run_id.store(0, std::memory_order_seq_cst);
  Publish(s.generation, s.sleepers);  // tasks still waiting to join find the run over
  if (s.error) std::rethrow_exception(s.error);
}

void StepTeam::Help(const std::shared_ptr<State>& state, int worker, std::uint32_t run_id) {
  State& s = *state;
  if (s.run_id.load(std::memory_order_acquire) != run_id) return;
  // Ask to join (a task of an earlier run never lowers a later one's request).
  std::uint32_t requested = s.join_request[worker].load(std::memory_order_seq_cst);
  while (requested < run_id &&
         !s.join_request[worker].compare_exchange_weak(requested, run_id, std::memory_order_seq_cst)) {
  }
  for (;;) {
    const std::uint32_t generation = s.generation.load(std::memory_order_acquire);
    if (s.admitted[worker].load(std::memory_order_acquire) == run_id) {
      // Admitted in a serial section: start once its barrier has released.
      const std::uint32_t released = s.admitted_generation[worker];
      while (s.generation.load(std::memory_order_acquire) != released) {
        WaitWhileEquals(s.generation, released - 1, s.sleepers);
      }
      WorkPasses(s, worker);
      s.helpers_in_run.fetch_sub(1, std::memory_order_release);
      return;
    }
    if (s.run_id.load(std::memory_order_acquire) != run_id) return;
    WaitWhileEquals(s.generation, generation, s.sleepers);
  }
}

void StepTeam::WaitForHelpers() const {
  // The last run's helpers leave right after its final barrier; one that the
  // machine has not scheduled since may still be on its way out.
  while (state_->helpers_in_run.load(std::memory_order_acquire) > 0) std::this_thread::yield();
}

std::vector<StepTeam::WorkerTime> StepTeam::Timing() const {
  WaitForHelpers();
  std::vector<WorkerTime> times;
  for (const State::Timed& timed : state_->timing) times.push_back(timed.time);
  return times;
}

void StepTeam::ResetTiming() {
  WaitForHelpers();
  for (State::Timed& timed : state_->timing) timed.time = {};
}

void StepTeam::WorkPasses(State& s, int worker) {
  // Two clock reads a pass; a team of one has nothing to wait for.
  const bool timed = s.timing.size() > 1;
  WorkerTime& time = s.timing[worker].time;
  Clock::time_point mark = timed ? Clock::now() : Clock::time_point{};
  while (!s.finished) {
    (*s.pass)(worker, s.current_pass);
    if (!timed) {
      Arrive(s);
      continue;
    }
    const Clock::time_point worked = Clock::now();
    const bool serial = Arrive(s);
    const Clock::time_point released = Clock::now();
    const double at_barrier_s = std::chrono::duration<double>(released - worked).count();
    ++time.passes;
    time.working_s += std::chrono::duration<double>(worked - mark).count();
    if (serial) {
      time.serial_s += at_barrier_s;
    } else {
      time.waiting_s += at_barrier_s;
      if (at_barrier_s >= kLongWait_s) {
        time.long_waiting_s += at_barrier_s;
        ++time.long_waits;
      }
    }
    mark = released;
  }
}

bool StepTeam::Arrive(State& s) {
  const std::uint32_t generation = s.generation.load(std::memory_order_acquire);
  if (s.arrived.fetch_add(1, std::memory_order_acq_rel) + 1 == s.members) {
    s.arrived.store(0, std::memory_order_relaxed);
    EndPass(s);
    Publish(s.generation, s.sleepers);
    return true;
  }
  WaitWhileEquals(s.generation, generation, s.sleepers);
  return false;
}

void StepTeam::EndPass(State& s) {
  const int pass = s.current_pass;
  bool go_on = false;
  if (!s.failed) {
    try {
      go_on = (*s.after)(pass);
    } catch (...) {
      s.failed = true;
      s.error = std::current_exception();
    }
  }
  s.current_pass = pass + 1;
  s.finished = !go_on || s.current_pass >= s.passes;
  if (!s.finished) {
    // Workers whose task has started join from the next pass on.
    const std::uint32_t id = s.run_id.load(std::memory_order_relaxed);
    for (size_t worker = 1; worker < s.admitted.size(); ++worker) {
      if (s.join_request[worker].load(std::memory_order_seq_cst) == id &&
          s.admitted[worker].load(std::memory_order_relaxed) != id) {
        s.helpers_in_run.fetch_add(1, std::memory_order_relaxed);
        s.admitted_generation[worker] = s.generation.load(std::memory_order_relaxed) + 1;
        s.admitted[worker].store(id, std::memory_order_release);
        ++s.members;
      }
    }
  }
  ResetClaims(s);
}

void StepTeam::ResetClaims(State& s) {
  for (State::Claim& claim : s.claims) {
    claim.first_ends.store(0, std::memory_order_relaxed);
    claim.first_done.store(0, std::memory_order_relaxed);
    claim.next_then.store(0, std::memory_order_relaxed);
    claim.adopted.store(false, std::memory_order_relaxed);
  }
}

int StepTeam::ClaimFirst(int range, int count, bool from_end, int leave) {
  constexpr std::uint64_t kOneFromEnd = std::uint64_t(1) << 32;
  std::atomic<std::uint64_t>& ends = state_->claims[range].first_ends;
  std::uint64_t seen = ends.load(std::memory_order_relaxed);
  for (;;) {
    const int from_start = static_cast<int>(seen & 0xffffffffu), from_back = static_cast<int>(seen >> 32);
    if (count - from_start - from_back <= leave) return -1;
    if (ends.compare_exchange_weak(seen, seen + (from_end ? kOneFromEnd : 1), std::memory_order_relaxed)) {
      return from_end ? count - 1 - from_back : from_start;
    }
  }
}

void StepTeam::Backoff(int waits) {
  if (waits < kSpinPauses) {
    CpuRelax();
  } else {
    std::this_thread::yield();  // the chunk's worker may be waiting for this core
  }
}

bool StepTeam::InRun(int worker) const {
  const State& s = *state_;
  return worker == 0 || s.admitted[worker].load(std::memory_order_relaxed) == s.run_id.load(std::memory_order_relaxed);
}

int StepTeam::Reserve(int taker, int owner, double own_ns) const {
  if (!InRun(owner) || own_ns <= 0) return 0;
  return static_cast<int>(2 * state_->take_cost[taker].own_chunks);
}

void StepTeam::RecordTake(int taker, double taken_ns, double own_ns) {
  if (own_ns <= 0) return;
  double& cost = state_->take_cost[taker].own_chunks;
  // A sample beyond kMaxTakeCost is a preemption or a page fault, not the
  // cost of moving a chunk's data: clamped, it cannot stop all taking.
  const double sample = std::min(taken_ns / own_ns, kMaxTakeCost);
  cost = cost == 0 ? sample : cost + 0.25 * (sample - cost);
}

int DefaultTeamSize() {
  const int allowed =
      static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return std::clamp(std::min(allowed, tbb::this_task_arena::max_concurrency()), 1, StepTeam::kMaxWorkers);
}

}  // namespace dg::sim
