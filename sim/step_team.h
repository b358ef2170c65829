#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "sim/error.h"

namespace dg::sim {

// A team of workers that runs a time-stepping loop together, in the shape
// explicit FEM and molecular-dynamics codes use (docs/solver.md, "Threads"):
//  - a run is a sequence of passes, each over fixed chunks, each ended by a
//    barrier whose serial section (the step's few reductions and checks)
//    runs on the last worker to arrive before any leaves;
//  - in every pass worker w starts on its home range of chunks (the same
//    chunks every step, so their data stay in that core's cache) and then
//    takes what is left of the others' ranges, leaving a working owner the
//    chunks it would finish before a taken one is done (the reserve, below);
//  - the caller is worker 0; workers 1.. are tasks of the caller's TBB arena
//    that join at the next barrier once a thread of the arena is free, and
//    then stay for the rest of the run. A run never waits for a worker that
//    has not joined: on a machine whose cores are busy with other work (the
//    run's graph, other solvers) the caller steps alone, stealing every
//    range, rather than stalling at a barrier behind a thread that is not
//    running.
// Waiting spins briefly, then sleeps on a futex (std::atomic::wait).
// Which worker runs a chunk never changes what the chunk computes: results do
// not depend on how many workers joined.
//
// Run() is called from one thread at a time. The team may be destroyed while
// tasks it enqueued are still queued: they find the run over and return.
class StepTeam {
 public:
  // The largest team.
  static constexpr int kMaxWorkers = 64;

  // workers in [1, kMaxWorkers]: the most that may work on a run. `launch`
  // starts the tasks of workers 1.. (default: enqueued in the caller's TBB
  // arena); a caller whose arena is always busy can give them priority.
  explicit StepTeam(int workers, std::function<void(std::function<void()>)> launch = {});
  ~StepTeam();
  StepTeam(const StepTeam&) = delete;
  StepTeam& operator=(const StepTeam&) = delete;

  int size() const { return size_; }

  // Where a worker's time went in the passes it worked (docs/solver.md,
  // "Threads"). A team of one does not time its passes.
  struct WorkerTime {
    long long passes = 0;
    double working_s = 0;  // in pass()
    double waiting_s = 0;  // at the barriers, for the others
    double serial_s = 0;   // at the barriers where it arrived last: the serial section and the release
    // Of waiting_s, the waits of kLongWait_s or more, and how many: the other
    // workers were stopped (the host interrupted their cores, a page fault)
    // rather than behind by their share of the work.
    double long_waiting_s = 0;
    long long long_waits = 0;
  };
  static constexpr double kLongWait_s = 10e-6;
  // Whether worker `worker` works on the current run's passes: called from
  // inside a pass, the same for the whole pass. Worker 0 always does.
  bool Working(int worker) const { return InRun(worker); }
  // One wait of a loop that waits for a working thread: spins, then yields.
  static void Backoff(int waits);
  // Each worker's time since the team was built or the last ResetTiming().
  // Call between runs.
  std::vector<WorkerTime> Timing() const;
  void ResetTiming();

  // Runs passes 0, 1, ..., passes - 1: pass(worker, p) on every worker in the
  // team at that pass, then after(p) once, serially, when all have finished
  // it. Stops early when after() returns false. Rethrows what after() threw.
  // pass() must not throw.
  void Run(int passes, const std::function<void(int worker, int pass)>& pass,
           const std::function<bool(int pass)>& after);

  // When a `then` chunk may start (ForEachChunkThen). Without per_range,
  // `then` chunks may read what any `first` chunk wrote and start once all
  // are done. With per_range, range w's `then` chunks read only what range
  // w's `first` chunks wrote: order[k], for k in [then_homes[w],
  // then_homes[w + 1]), lists them in the order they start, and needs[k]
  // (non-decreasing within the range) says how many of range w's `first`
  // chunks, counted from its start, order[k] reads.
  struct ThenOrder {
    bool per_range = false;
    std::vector<int> order, needs;
  };
  // Inside a pass, two phases: first(c) for every chunk of first_homes, then
  // then(c) for every chunk of then_homes, each exactly once over the team,
  // worker w starting on its home ranges [homes[w], homes[w + 1])
  // (non-decreasing). A range's `first` chunks are handed out from its start
  // to its owner and from its end to takers, who leave a working owner its
  // reserve; `then` chunks are taken only from a worker not in the run.
  // Per range, one pass and one barrier do what two passes did, and the owner
  // runs each `then` chunk as soon as the `first` chunks it reads are done:
  // the forces it gathers are still in the core's nearest caches
  // (docs/solver.md, "Threads").
  template <typename First, typename Then>
  void ForEachChunkThen(int worker, std::span<const int> first_homes, First&& first,
                        std::span<const int> then_homes, Then&& then, const ThenOrder& then_order);

 private:
  // Everything a run shares, owned jointly by the team and the tasks it
  // enqueued (a task may start after its run, or its team, has ended).
  struct State {
    struct alignas(64) Claim {
      // The range's first-phase chunks handed out from its start (low half)
      // and from its end (high half), in one word so that the two ends never
      // hand out the same chunk.
      std::atomic<std::uint64_t> first_ends{0};
      std::atomic<int> first_done{0};      // the range's first-phase chunks done
      std::atomic<int> next_then{0};       // the next of its second-phase chunks to hand out
      std::atomic<bool> adopted{false};    // per_range: a worker runs the range of an owner not in the run
    };
    explicit State(int workers)
        : claims(workers),
          take_cost(workers),
          timing(workers),
          join_request(workers),
          admitted(workers),
          admitted_generation(workers) {}

    std::vector<Claim> claims;  // per home range, reset for every pass

    // Per worker: what a chunk taken from another's range costs, in chunks of
    // its own range, smoothed over the chunks it took (0: none taken yet).
    struct alignas(64) TakeCost {
      double own_chunks = 0;
    };
    std::vector<TakeCost> take_cost;

    // Per worker, written by that worker only.
    struct alignas(64) Timed {
      WorkerTime time;
    };
    std::vector<Timed> timing;

    // The run in progress: its id (0: none), its functions and its pass.
    std::atomic<std::uint32_t> run_id{0};
    std::uint32_t last_run_id = 0;  // touched by Run()'s thread only
    const std::function<void(int, int)>* pass = nullptr;
    const std::function<bool(int)>* after = nullptr;
    int passes = 0;
    int current_pass = 0;  // written in serial sections
    bool finished = false;  // written in serial sections
    bool failed = false;
    std::exception_ptr error;

    // Joining: a worker's task asks with its run's id; a serial section admits
    // it, naming the barrier generation from which it works.
    std::vector<std::atomic<std::uint32_t>> join_request, admitted;
    std::vector<std::uint32_t> admitted_generation;
    int members = 1;  // workers in the run, written in serial sections
    std::atomic<int> helpers_in_run{0};  // admitted workers other than 0 not yet gone

    // The barrier: arrivals counted, released by moving `generation` on.
    alignas(64) std::atomic<int> arrived{0};
    alignas(64) std::atomic<std::uint32_t> generation{0};
    std::atomic<int> sleepers{0};
  };

  // How many unclaimed chunks `taker` leaves in `owner`'s range: none if the
  // owner is not in the run, else twice what one taken chunk costs the taker
  // in chunks of its own range (each `own_ns` long), since the chunk's data
  // cross cores twice: to the taker, and its results back to the owner's
  // next pass. Taking a chunk the owner would reach before then only makes
  // the pass end later (docs/solver.md, "Threads").
  int Reserve(int taker, int owner, double own_ns) const;
  // Whether worker `worker` works on the current run.
  bool InRun(int worker) const;
  // Folds the time a taken chunk took into the taker's cost estimate.
  void RecordTake(int taker, double taken_ns, double own_ns);

  using Clock = std::chrono::steady_clock;
  // Hands out the next first-phase chunk of `range` (of `count` chunks), from
  // its start or its end, as an offset in the range; -1 when no more than
  // `leave` chunks are left unclaimed.
  int ClaimFirst(int range, int count, bool from_end, int leave);
  struct OwnChunks {
    int count = 0;
    double mean_ns = 0;  // 0 in a team of one, which does not time them
  };
  // Runs `range`'s first-phase chunks from its start until none is left.
  template <typename Body>
  OwnChunks RunFirstFromStart(int range, std::span<const int> homes, Body& body);
  // Runs `range`'s first-phase chunks from its start and, as the chunks they
  // read are done, its `then` chunks in `then_order` (per_range).
  template <typename First, typename Then>
  OwnChunks RunRangeInterleaved(int range, std::span<const int> first_homes, First& first,
                                std::span<const int> then_homes, Then& then, const ThenOrder& then_order);
  // Takes first-phase chunks from the end of `owner`'s range, leaving a
  // working owner its reserve.
  template <typename Body>
  void TakeFirstFromEnd(int worker, int owner, std::span<const int> homes, double own_ns, Body& body);
  // Whether all of `range`'s first-phase chunks are done.
  bool FirstDone(int range, std::span<const int> homes) const {
    return state_->claims[range].first_done.load(std::memory_order_acquire) == homes[range + 1] - homes[range];
  }
  // Spins, then yields, until ready(): for a chunk a working thread is finishing.
  template <typename Ready>
  static void WaitUntil(Ready&& ready) {
    for (int waits = 0; !ready(); ++waits) Backoff(waits);
  }
  // Clears every range's claims and counts for the next pass.
  static void ResetClaims(State& state);

  // Worker `worker`'s passes from the current one to the run's end.
  static void WorkPasses(State& state, int worker);
  // The serial section after a pass: after(), the next pass, admissions.
  static void EndPass(State& state);
  // Worker `worker`'s task for run `run_id`: joins if the run is still on.
  static void Help(const std::shared_ptr<State>& state, int worker, std::uint32_t run_id);
  // The barrier at the end of a pass; the last to arrive runs the serial
  // section (and returns true).
  static bool Arrive(State& state);
  // Waits until the last run's helpers have left it.
  void WaitForHelpers() const;

  int size_ = 1;
  std::function<void(std::function<void()>)> launch_;
  std::shared_ptr<State> state_;
};

// Starts a team's helper work somewhere it can run: a task for a thread that
// is or will be free.
using HelperLauncher = std::function<void(std::function<void()> work)>;

// The team size the process's parallelism allows: TBB's active
// max_allowed_parallelism (set by tbb::global_control, e.g. --threads), at
// most the current arena's concurrency.
int DefaultTeamSize();

template <typename First, typename Then>
void StepTeam::ForEachChunkThen(int worker, std::span<const int> first_homes, First&& first,
                                std::span<const int> then_homes, Then&& then, const ThenOrder& then_order) {
  DG_CHECK(first_homes.size() == size_t(size_) + 1 && then_homes.size() == size_t(size_) + 1);
  std::vector<State::Claim>& claims = state_->claims;
  if (then_order.per_range) {
    DG_CHECK(then_order.order.size() == size_t(then_homes.back()) &&
             then_order.needs.size() == then_order.order.size());
    const OwnChunks own = RunRangeInterleaved(worker, first_homes, first, then_homes, then, then_order);
    for (int k = 1; k < size_; ++k) {
      const int owner = (worker + k) % size_;
      // A range whose owner is not in the run is run by the first worker to
      // get there, in its own order; the others take from its end.
      if (!InRun(owner) && !claims[owner].adopted.exchange(true, std::memory_order_relaxed)) {
        RunRangeInterleaved(owner, first_homes, first, then_homes, then, then_order);
      }
      TakeFirstFromEnd(worker, owner, first_homes, own.mean_ns, first);
    }
    return;
  }
  const OwnChunks own_first = RunFirstFromStart(worker, first_homes, first);
  for (int k = 1; k < size_; ++k) {
    TakeFirstFromEnd(worker, (worker + k) % size_, first_homes, own_first.mean_ns, first);
  }
  WaitUntil([&] {
    for (int range = 0; range < size_; ++range) {
      if (!FirstDone(range, first_homes)) return false;
    }
    return true;
  });
  // Second-phase chunks are taken only from an owner not in the run. A taken
  // chunk's results are what its owner reads first in the next pass (a node
  // chunk writes the next state of its part's nodes): taking one from a
  // working owner slows the owner's next pass, which the taker's timing does
  // not see, so the next pass is more out of balance and more is taken
  // (docs/solver.md, "Threads").
  for (int k = 0; k < size_; ++k) {
    const int owner = (worker + k) % size_;
    if (k > 0 && InRun(owner)) continue;
    std::atomic<int>& next = claims[owner].next_then;
    for (;;) {
      const int chunk = then_homes[owner] + next.fetch_add(1, std::memory_order_relaxed);
      if (chunk >= then_homes[owner + 1]) break;
      then(chunk);
    }
  }
}

template <typename Body>
StepTeam::OwnChunks StepTeam::RunFirstFromStart(int range, std::span<const int> homes, Body& body) {
  const int count = homes[range + 1] - homes[range];
  const Clock::time_point start = size_ > 1 ? Clock::now() : Clock::time_point{};
  OwnChunks own;
  for (int chunk; (chunk = ClaimFirst(range, count, false, 0)) >= 0; ++own.count) body(homes[range] + chunk);
  state_->claims[range].first_done.fetch_add(own.count, std::memory_order_release);
  if (size_ > 1 && own.count > 0) {
    own.mean_ns = std::chrono::duration<double, std::nano>(Clock::now() - start).count() / own.count;
  }
  return own;
}

template <typename First, typename Then>
StepTeam::OwnChunks StepTeam::RunRangeInterleaved(int range, std::span<const int> first_homes, First& first,
                                                  std::span<const int> then_homes, Then& then,
                                                  const ThenOrder& then_order) {
  const int count = first_homes[range + 1] - first_homes[range];
  const Clock::time_point start = size_ > 1 ? Clock::now() : Clock::time_point{};
  OwnChunks own;
  int next = then_homes[range];
  const int end = then_homes[range + 1];
  // Only this worker hands out the range's chunks from its start, so those
  // it ran are the range's first own.count.
  auto run_ready = [&] {
    for (; next < end && then_order.needs[next] <= own.count; ++next) then(then_order.order[next]);
  };
  run_ready();
  for (int chunk; (chunk = ClaimFirst(range, count, false, 0)) >= 0;) {
    first(first_homes[range] + chunk);
    ++own.count;
    run_ready();
  }
  state_->claims[range].first_done.fetch_add(own.count, std::memory_order_release);
  if (next < end) {
    // The rest read chunks taken from the range's end, which may still be running.
    WaitUntil([&] { return FirstDone(range, first_homes); });
    for (; next < end; ++next) then(then_order.order[next]);
  }
  if (size_ > 1 && own.count > 0) {
    own.mean_ns = std::chrono::duration<double, std::nano>(Clock::now() - start).count() / own.count;
  }
  return own;
}

template <typename Body>
void StepTeam::TakeFirstFromEnd(int worker, int owner, std::span<const int> homes, double own_ns, Body& body) {
  const int count = homes[owner + 1] - homes[owner];
  for (int chunk; (chunk = ClaimFirst(owner, count, true, Reserve(worker, owner, own_ns))) >= 0;) {
    const Clock::time_point start = Clock::now();
    body(homes[owner] + chunk);
    state_->claims[owner].first_done.fetch_add(1, std::memory_order_release);
    RecordTake(worker, std::chrono::duration<double, std::nano>(Clock::now() - start).count(), own_ns);
  }
}

}  // namespace dg::sim
