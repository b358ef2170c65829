#include "sim/phase_clock.h"

#include <cmath>

#include "sim/error.h"

namespace dg::sim {

PhaseClock::PhaseClock(double phase_at_start, double rate_per_step) : rate_after_(rate_per_step) {
  knots_[0] = {0, phase_at_start};
}

double PhaseClock::PhaseAt(long long step) const {
  const Knot& last = knots_[count_ - 1];
  if (count_ == 1 || step >= last.step) return last.phase + rate_after_ * double(step - last.step);
  int k = count_ - 2;
  while (k > 0 && knots_[k].step > step) --k;
  const Knot& a = knots_[k];
  const Knot& b = knots_[k + 1];
  // Before the oldest knot kept: its segment's slope, extended.
  return a.phase + (b.phase - a.phase) * double(step - a.step) / double(b.step - a.step);
}

void PhaseClock::Steer(long long from_step, long long at_step, double phase, double rate_per_step) {
  DG_CHECK(from_step < at_step);
  const double from_phase = PhaseAt(from_step);
  const double unsteered = PhaseAt(at_step);
  const double target = phase + std::round(unsteered - phase);
  // Knots after from_step were steering not yet reached: replaced.
  while (count_ > 1 && knots_[count_ - 1].step > from_step) --count_;
  DG_CHECK(knots_[count_ - 1].step <= from_step);
  const auto push = [this](const Knot& knot) {
    if (count_ == kKnots) {
      for (int k = 1; k < kKnots; ++k) knots_[k - 1] = knots_[k];
      --count_;
    }
    knots_[count_++] = knot;
  };
  if (knots_[count_ - 1].step < from_step) push({from_step, from_phase});
  push({at_step, target});
  rate_after_ = rate_per_step;
}

}  // namespace dg::sim
