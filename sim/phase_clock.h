#pragma once

#include <array>

namespace dg::sim {

// The motion model's phase as a function of the simulation step. Unsteered,
// it runs at one rate from its start (phase_at_start + t / period, the
// registration's constant shift). A live estimate of the heart's phase steers
// it (docs/phase.md): from a step on, the phase moves linearly to a target
// phase at a later step, then on at the estimate's rate. The phase stays
// continuous, and every step before the steering step keeps the phase it had,
// so motion already evaluated (the inverse simulation runs ahead of the
// forward step) is never contradicted. Phases are unwrapped: whole cycles count.
class PhaseClock {
 public:
  PhaseClock(double phase_at_start, double rate_per_step);

  double PhaseAt(long long step) const;
  double rate_per_step() const { return rate_after_; }

  // From from_step on, the phase moves linearly to `phase` at at_step, then
  // on at rate_per_step; the phase at from_step and before is unchanged.
  // `phase` may be wrapped: the whole cycles nearest the unsteered phase at at_step are added.
  // @pre from_step < at_step, and from_step is not before the previous steering's from_step.
  void Steer(long long from_step, long long at_step, double phase, double rate_per_step);

 private:
  struct Knot {
    long long step;
    double phase;
  };
  // The oldest knots drop out: queries reach back a few inverse levels, never many frames.
  static constexpr int kKnots = 6;
  std::array<Knot, kKnots> knots_{};
  int count_ = 1;
  double rate_after_ = 0;  // beyond the last knot
};

}  // namespace dg::sim
