#pragma once

namespace dg::sim {

// Forward steps per level of recovered forces (CoupledOptions::
// inverse_interval_steps): the inverse simulation runs one step in this many
// and the forward step blends the two levels around it. The blend's error
// grows with the square of the interval (docs/solver.md, "Recovered forces at
// a coarser rate").
constexpr int kDefaultInverseIntervalSteps = 8;
// The longest: blending over more than some ten milliseconds (at the paper's
// 0.2 ms step) would smooth the heartbeat's fastest changes.
constexpr int kMaxInverseIntervalSteps = 50;

}  // namespace dg::sim
