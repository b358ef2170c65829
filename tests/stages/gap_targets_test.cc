// The constraints' path across dropped frames (stages/constraints/gap_targets.h),
// on a one-node cyclic motion whose values at the scan phases are known.
#include "stages/constraints/gap_targets.h"

#include <cmath>

#include <catch2/catch.hpp>

namespace dg::stages {
namespace {

constexpr double kPeriod = 0.8;
constexpr int kPhases = 8;

// Node 0 moves along x by 5 mm sin(2 pi phase); with no smoothing the model
// passes through these values at phases k / 8, i.e. at t = k * 0.1 s.
double PhaseValue(int k) { return 5e-3 * std::sin(2 * M_PI * k / kPhases); }

std::shared_ptr<const sim::CyclicMotionModel> Motion() {
  std::vector<double> phases;
  for (int k = 0; k < kPhases; ++k) phases.insert(phases.end(), {PhaseValue(k), 0.0, 0.0});
  return std::make_shared<const sim::CyclicMotionModel>(phases, kPhases, 3, kPeriod);
}

NodeTargets Target(double x_m) {
  NodeTargets targets;
  targets.nodes = {0};
  targets.displacement_S_m = {x_m, 0, 0};
  return targets;
}

}  // namespace

TEST_CASE("gap targets: with the scan's motion, the model plus the interpolated residual", "[unit]") {
  GapTargets gap(Motion(), 0.0);
  // The node 0.2 mm off the model at t = 0.1 s; tracked 0.6 mm off it at
  // t = 0.5 s, four frame periods of 0.1 s later (three dropped).
  const double start[] = {PhaseValue(1) + 0.2e-3, 0, 0};
  gap.Begin(Target(PhaseValue(5) + 0.6e-3), start, 0.1, 0.5);
  std::vector<double> out;
  for (int k = 2; k <= 5; ++k) {
    gap.At(0.1 * k, &out);
    const double residual = 0.2e-3 + (k - 1) / 4.0 * 0.4e-3;
    CHECK(out[0] == Approx(PhaseValue(k) + residual).margin(1e-12));
    CHECK(out[1] == Approx(0).margin(1e-12));
  }
  gap.At(0.5, &out);
  CHECK(out[0] == PhaseValue(5) + 0.6e-3);  // the frame's own target at the end, exactly
}

TEST_CASE("gap targets: without a model, no faster than the tracked targets were seen to move", "[unit]") {
  GapTargets gap(nullptr, 0.0);
  std::vector<double> out;
  // First frame at t = 0: the speed bound is not known yet.
  const double zero[] = {0, 0, 0};
  gap.Begin(Target(0), zero, 0, 0);
  // Frame 1: tracked 1 mm further in 0.1 s: 10 mm/s seen, reached.
  gap.Begin(Target(1e-3), zero, 0, 0.1);
  CHECK(gap.speed_limit_m_per_s() == Approx(0.01));
  gap.At(0.1, &out);
  CHECK(out[0] == Approx(1e-3));
  // Then 4 mm further after three dropped frames (0.4 s at 10 mm/s): the
  // target moves 1 mm per frame period and reaches the new one at the end.
  const double one[] = {1e-3, 0, 0};
  gap.Begin(Target(5e-3), one, 0.1, 0.5);
  CHECK(gap.speed_limit_m_per_s() == Approx(0.01));  // 4 mm in 0.4 s is no faster
  for (int k = 2; k <= 5; ++k) {
    gap.At(0.1 * k, &out);
    CHECK(out[0] == Approx(1e-3 * k));
  }
  // A node 3 mm behind its new target (tied anew where the simulation has
  // it) moves 1 mm per period and lags at the end of a two-period gap; the
  // next frame carries on from there at the same speed.
  const double behind[] = {3e-3, 0, 0};
  gap.Begin(Target(6e-3), behind, 0.5, 0.7);  // tracked 1 mm in 0.2 s: the bound stays
  gap.At(0.6, &out);
  CHECK(out[0] == Approx(4e-3));
  gap.At(0.7, &out);
  CHECK(out[0] == Approx(5e-3));
  const double lagging[] = {5e-3, 0, 0};
  gap.Begin(Target(6.5e-3), lagging, 0.7, 0.8);
  gap.At(0.8, &out);
  CHECK(out[0] == Approx(6e-3));
  CHECK(gap.speed_limit_m_per_s() == Approx(0.01));
}

}  // namespace dg::stages
