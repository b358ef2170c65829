#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sim/aligned_vector.h"
#include "sim/force_resolution.h"
#include "sim/inverse_dynamics.h"
#include "sim/inverse_interval.h"
#include "sim/motion_model.h"
#include "sim/phase_clock.h"
#include "sim/simulation_mode.h"
#include "sim/tled_solver.h"

namespace dg::sim {

struct CoupledOptions {
  SimulationMode mode = SimulationMode::kCombined;
  SolverOptions solver;         // dt_s, damping, stability policy (kSubstep is refused: see below)
  double phase_at_start = 0;    // the motion model's phase at t = 0
  bool concurrent = true;       // inverse of the next step beside the forward step; false: one after the other
  // Forward steps per level of recovered forces (docs/solver.md, "Recovered
  // forces at a coarser rate"): the inverse side runs one step in this many,
  // and the forward step blends the two levels around it. 1: every step.
  int inverse_interval_steps = kDefaultInverseIntervalSteps;
  std::string Validate() const;  // empty when valid
};

// The forward TLED simulation driven by positional constraints and/or by
// forces recovered from a cyclic motion model, inverse and forward run step by
// step (paper section 2.6). With k = inverse_interval_steps, at step n
// (t = n dt, n = a k + j, 0 <= j < k):
//   forward:  U_{n+1} from the solver's update with the constraints and the
//             resolved forces of weights (1 - j/k) w_a + (j/k) w_{a+1}
//             applied in the current geometry U_n (eq. 5), inside the
//             solver's element pass (k = 1: w_n itself);
//   inverse:  when j = 0, level a + 2 of InverseSimulation (w_{a+2} at step
//             (a + 2) k; motion model Um at the phase clock's phase, which is
//             phase_at_start + t / period until SteerPhase() steers it).
// The two are independent, so with `concurrent` they run side by side: the
// step is one pass of a StepTeam over both sides' fixed chunks (elements,
// then nodes), one barrier per step, however many threads.
// Only three motion-model levels and three weight sets are kept. Every partial
// sum runs in fixed chunks, so results are bitwise the same for any thread
// The mesh starts in the motion model's geometry at t = 0 with its velocity
// (at rest in the reference geometry without a motion model); the mount's
// nodes stay at zero; constrained nodes follow the targets given to Advance().
// One instance must not be advanced from two threads at once.
template <typename T>
class CoupledSimulation {
 public:
  // `motion` may be null in surface mode. `stability` (optional) must have been
  // estimated with at most the fixed nodes held: it then bounds every set of
  // constrained nodes (holding more nodes only lowers omega_max).
  // @throws dg::Error for invalid options, a missing or mismatched motion model,
  // a time step above the safe limit, or a motion model geometry with a
  // degenerate element at any of 4 samples per scan phase.
  CoupledSimulation(std::shared_ptr<const TledModel<T>> model, std::shared_ptr<const CyclicMotionModel> motion,
                    std::vector<int> fixed_nodes, const CoupledOptions& options,
                    const StabilityReport* stability = nullptr);

  // Nodes held at prescribed targets (all three axes) from now on. Changing the
  // set rebuilds the forward solver around the same state (positions and velocities).
  // @throws dg::Error for an out-of-range or fixed node.
  void SetConstrainedNodes(std::vector<int> nodes);
  const std::vector<int>& constrained_nodes() const { return constrained_nodes_; }

  // Advances `steps` steps; each constrained node moves linearly from its
  // current displacement to its target (3 per constrained node, in the order
  // of constrained_nodes()), reaching it at the last step.
  // @throws dg::Error as TledSolver::Advance and ForceResolution::Resolve do.
  void Advance(int steps, std::span<const double> targets_m);

  // The motion model's displacement at step n into out (3 per node).
  // @pre a motion model was given.
  void MotionAtStep(long long step, std::span<T> out) const;

  // A live estimate of the heart's phase (docs/phase.md): at the current step
  // the phase is `phase` (in [0, 1), or unwrapped) and advances at rate_hz
  // cycles per second. The motion's phase is steered onto that line over
  // settle_s, starting kSteerLead_s ahead of the current step (or at the
  // newest step the inverse side has evaluated, if that is later: its phase
  // is kept), and runs on at rate_hz after. The lead is a time, not a count
  // of steps, so that the phase the simulation sees does not depend on dt.
  // Without an inverse side only MotionAtStep follows it.
  // @pre settle_s >= dt, rate_hz > 0.
  void SteerPhase(double phase, double rate_hz, double settle_s);
  // More than the inverse side's look-ahead at the default interval and dt (about 5 ms).
  static constexpr double kSteerLead_s = 0.010;
  // The motion's phase at step n (unwrapped), and its rate (cycles per second) beyond the last steering.
  double PhaseAtStep(long long step) const { return phase_clock().PhaseAt(step); }
  double phase_rate_hz() const { return phase_clock().rate_per_step() / options_.solver.dt_s; }

  const TledSolver<T>& solver() const { return *solver_; }
  std::span<const T> displacement() const { return solver_->displacement(); }
  long long steps_taken() const { return steps_; }
  double time_s() const { return steps_ * options_.solver.dt_s; }
  const StabilityReport& stability() const { return stability_; }
  const CoupledOptions& options() const { return options_; }
  bool has_inverse() const { return options_.mode != SimulationMode::kSurface; }

 private:
  void BuildSolver(std::span<const double> u_m, std::span<const double> v_m_s);
  // Runs `steps` steps of forward and inverse simulation on the team.
  void AdvanceCoupled(int steps);
  // The blended loads of step n's forward update.
  ElementLoads<T> LoadsAtStep(long long step) const;

  std::shared_ptr<const TledModel<T>> model_;
  std::shared_ptr<const CyclicMotionModel> motion_;
  CoupledOptions options_;
  StabilityReport stability_;
  std::vector<int> fixed_nodes_, constrained_nodes_;
  std::shared_ptr<StepTeam> team_;  // every solver built steps on it
  std::unique_ptr<TledSolver<T>> solver_;
  long long steps_ = 0;
  // The motion's phase by step: the inverse side's clock when it has one
  // (steered through it), else this one.
  PhaseClock clock_;
  const PhaseClock& phase_clock() const { return inverse_ ? inverse_->phase_clock() : clock_; }

  // Its newest level at step n: n / k + 1 at the start of an interval, n / k + 2 within one.
  std::unique_ptr<InverseSimulation<T>> inverse_;
};

extern template class CoupledSimulation<float>;
extern template class CoupledSimulation<double>;

}  // namespace dg::sim
