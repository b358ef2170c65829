#pragma once

#include <vector>

#include <Eigen/Core>

#include "tools/phantom/phantom_spec.h"

namespace dg::tools::phantom {

// How far through its beat the heart is: contraction (0 at rest, about 1 at
// peak systole, times the cycle's amplitude) and lateral sway.
struct MotionState {
  double activation = 0;
  double sway = 0;
};

// The phantom's motion: an analytic, smooth, invertible map of the scan frame
// (mount on z = 0, long axis z) onto itself, which is the ground truth of
// every test. With zeta = z / H (H the phantom's height) and w = zeta^2:
//   z' = z (1 - l a zeta)                          longitudinal shortening
//   (x', y') = Rot(t a w) (1 - r a w) (x, y) + s w sway_m   contraction, twist, sway
// for activation a and sway s; zero at the mount (z <= 0). Its Jacobian is
// (1 - r a w)^2 (1 - 2 l a zeta) > 0, and it inverts in closed form.
// A beat has activation sin^2(pi phi) and sway sin(2 pi phi) sin^2(pi phi):
// both start and end at zero with zero slope, so cycles of different period and
// amplitude join smoothly. Each cycle's period and amplitude are drawn from the
// seed, so that no cyclic model of the nominal beat (the 4D CT) fits exactly;
// with premature_beat_every = N, every N-th cycle is cut short and the next
// lengthened by the same time (PhantomSpec::kPrematurePeriodFactor).
class HeartMotion {
 public:
  // Draws the cycles covering [0, horizon_s].
  HeartMotion(const PhantomSpec& spec, double horizon_s);

  // The state at phantom time t (cycle variation included). @pre 0 <= t <= horizon.
  MotionState StateAt(double t_s) const;
  // The nominal beat at phase in [0, 1) (what the 4D CT records).
  static MotionState NominalState(double phase);

  Eigen::Vector3d Deform(const Eigen::Vector3d& X_S, const MotionState& state) const;
  // X with Deform(X, state) = x.
  Eigen::Vector3d Undeform(const Eigen::Vector3d& x_S, const MotionState& state) const;

  struct Cycle {
    double start_s, period_s, amplitude;
  };
  const std::vector<Cycle>& cycles() const { return cycles_; }

 private:
  double height_m_, radial_, twist_, longitudinal_;
  Eigen::Vector2d sway_m_;
  std::vector<Cycle> cycles_;
};

}  // namespace dg::tools::phantom
