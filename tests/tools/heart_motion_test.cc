#include "tools/phantom/heart_motion.h"

#include <cmath>
#include <random>

#include <Eigen/LU>
#include <catch2/catch.hpp>

namespace dg::tools::phantom {
namespace {

std::vector<Eigen::Vector3d> SamplePoints(const PhantomSpec& spec, int count) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> xy(-spec.semi_axes_m.x(), spec.semi_axes_m.x());
  std::uniform_real_distribution<double> z(0, spec.height_m());
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) points.emplace_back(xy(rng), xy(rng), z(rng));
  return points;
}

}  // namespace

// The mount does not move: every state leaves points on z = 0 (and below) in place.
TEST_CASE("heart motion: zero at the mount", "[tools][unit]") {
  const PhantomSpec spec = PresetSpec("extreme");
  const HeartMotion motion(spec, 5.0);
  for (double t = 0; t < 5.0; t += 0.0137) {
    const MotionState state = motion.StateAt(t);
    for (const Eigen::Vector3d& X : {Eigen::Vector3d(0.01, -0.02, 0), Eigen::Vector3d(-0.03, 0.004, 0),
                                     Eigen::Vector3d(0.02, 0.02, -0.003)}) {
      REQUIRE((motion.Deform(X, state) - X).norm() == 0.0);
    }
  }
}

// The closed-form inverse undoes the map, and the map never inverts volume
// (its Jacobian, by central differences, stays positive) even in the extreme preset.
TEST_CASE("heart motion: invertible and orientation-preserving", "[tools][unit]") {
  const PhantomSpec spec = PresetSpec("extreme");
  const HeartMotion motion(spec, 5.0);
  for (double t = 0; t < 5.0; t += 0.031) {
    const MotionState state = motion.StateAt(t);
    for (const Eigen::Vector3d& X : SamplePoints(spec, 50)) {
      const Eigen::Vector3d x = motion.Deform(X, state);
      REQUIRE((motion.Undeform(x, state) - X).norm() < 1e-15);
      Eigen::Matrix3d F;
      for (int i = 0; i < 3; ++i) {
        Eigen::Vector3d h = Eigen::Vector3d::Zero();
        h[i] = 1e-7;
        F.col(i) = (motion.Deform(X + h, state) - motion.Deform(X - h, state)) / 2e-7;
      }
      REQUIRE(F.determinant() > 0.3);
    }
  }
}

// Without cycle variation the motion repeats exactly every period; with it,
// each cycle is the nominal beat scaled in time and amplitude by factors
// within four standard deviations of one.
TEST_CASE("heart motion: periodic up to the stated variation", "[tools][unit]") {
  PhantomSpec spec;
  spec.amplitude_variation = 0;
  spec.period_variation = 0;
  const HeartMotion exact(spec, 10.0);
  const Eigen::Vector3d X(0.01, 0.005, 0.03);
  for (double t = 0; t < 8.0; t += 0.0213) {
    const Eigen::Vector3d a = exact.Deform(X, exact.StateAt(t));
    const Eigen::Vector3d b = exact.Deform(X, exact.StateAt(t + spec.period_s()));
    REQUIRE((a - b).norm() < 1e-12);
  }
  const PhantomSpec varied;
  const HeartMotion motion(varied, 10.0);
  REQUIRE(motion.cycles().size() > 10);
  bool some_differ = false;
  for (const HeartMotion::Cycle& cycle : motion.cycles()) {
    REQUIRE(std::abs(cycle.period_s / varied.period_s() - 1) < 4 * varied.period_variation);
    REQUIRE(std::abs(cycle.amplitude - 1) < 4 * varied.amplitude_variation);
    some_differ |= std::abs(cycle.period_s - varied.period_s()) > 1e-3;
    for (double phase : {0.1, 0.37, 0.5, 0.81}) {
      const MotionState state = motion.StateAt(cycle.start_s + phase * cycle.period_s);
      const MotionState nominal = HeartMotion::NominalState(phase);
      REQUIRE(state.activation == Approx(cycle.amplitude * nominal.activation).epsilon(1e-9));
      REQUIRE(state.sway == Approx(cycle.amplitude * nominal.sway).margin(1e-12));
    }
  }
  REQUIRE(some_differ);
}

// An early beat every N cycles: that cycle lasts kPrematurePeriodFactor of
// its period and the next one is longer by the same time, so the beats after
// the pair keep the regular rhythm's timing.
TEST_CASE("heart motion: premature beats with a compensatory pause", "[tools][unit]") {
  PhantomSpec regular;
  regular.period_variation = 0;
  PhantomSpec premature = regular;
  premature.premature_beat_every = 3;
  const HeartMotion a(regular, 6.0), b(premature, 6.0);
  REQUIRE(b.cycles().size() >= 7);
  const double T = regular.period_s(), early = PhantomSpec::kPrematurePeriodFactor * T;
  for (size_t c = 0; c + 1 < b.cycles().size(); ++c) {
    const double expected = c % 3 == 2 ? early : (c % 3 == 0 && c > 0 ? 2 * T - early : T);
    CHECK(b.cycles()[c].period_s == Approx(expected).epsilon(1e-12));
    CHECK(b.cycles()[c].amplitude == a.cycles()[c].amplitude);
  }
  CHECK(b.cycles()[4].start_s == Approx(a.cycles()[4].start_s).epsilon(1e-12));
  premature.premature_beat_every = 1;
  CHECK_THAT(premature.Validate(), Catch::Matchers::Contains("--premature-beat-every"));
}

}  // namespace dg::tools::phantom
