#include "tools/phantom/heart_motion.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Geometry>

#include "sim/error.h"

namespace dg::tools::phantom {
namespace {

double Activation(double phase) {
  const double s = std::sin(std::numbers::pi * phase);
  return s * s;
}

double Sway(double phase) { return std::sin(2 * std::numbers::pi * phase) * Activation(phase); }

}  // namespace

HeartMotion::HeartMotion(const PhantomSpec& spec, double horizon_s)
    : height_m_(spec.height_m()),
      radial_(spec.radial_contraction),
      twist_(spec.twist_rad),
      longitudinal_(spec.longitudinal_shortening),
      sway_m_(spec.sway_m) {
  // A stream of its own, so that other random choices do not shift the cycles.
  std::mt19937_64 rng(spec.seed * 0x9E3779B97F4A7C15ULL + 1);
  std::normal_distribution<double> normal(0.0, 1.0);
  double start = 0;
  double carried_s = 0;  // a premature beat's shortfall, added to the pause after it
  for (int cycle = 0; start <= horizon_s; ++cycle) {
    double period = spec.period_s() * std::clamp(1 + spec.period_variation * normal(rng), 0.5, 1.5);
    const double amplitude = std::clamp(1 + spec.amplitude_variation * normal(rng), 0.5, 1.5);
    period += carried_s;
    carried_s = 0;
    const int every = spec.premature_beat_every;
    if (every > 0 && cycle % every == every - 1) {
      carried_s = (1 - PhantomSpec::kPrematurePeriodFactor) * period;
      period -= carried_s;
    }
    cycles_.push_back({start, period, amplitude});
    start += period;
  }
}

MotionState HeartMotion::StateAt(double t_s) const {
  const auto after = std::upper_bound(cycles_.begin(), cycles_.end(), t_s,
                                      [](double t, const Cycle& cycle) { return t < cycle.start_s; });
  DG_CHECK(after != cycles_.begin());  // t >= 0 and the first cycle starts at 0
  const Cycle& cycle = *std::prev(after);
  const double phase = std::clamp((t_s - cycle.start_s) / cycle.period_s, 0.0, 1.0);
  return {cycle.amplitude * Activation(phase), cycle.amplitude * Sway(phase)};
}

MotionState HeartMotion::NominalState(double phase) { return {Activation(phase), Sway(phase)}; }

Eigen::Vector3d HeartMotion::Deform(const Eigen::Vector3d& X, const MotionState& state) const {
  const double zeta = std::max(X.z(), 0.0) / height_m_;
  const double w = zeta * zeta;
  const double a = state.activation;
  const Eigen::Vector2d planar = Eigen::Rotation2Dd(twist_ * a * w) * ((1 - radial_ * a * w) * X.head<2>()) +
                                 state.sway * w * sway_m_;
  return {planar.x(), planar.y(), X.z() * (1 - longitudinal_ * a * zeta)};
}

Eigen::Vector3d HeartMotion::Undeform(const Eigen::Vector3d& x, const MotionState& state) const {
  const double a = state.activation;
  // z' = z - (l a / H) z^2 for z > 0: the root that is continuous at l a = 0.
  const double q = longitudinal_ * a / height_m_;
  const double z = x.z() <= 0 || q == 0 ? x.z() : 2 * x.z() / (1 + std::sqrt(1 - 4 * q * x.z()));
  const double zeta = std::max(z, 0.0) / height_m_;
  const double w = zeta * zeta;
  const Eigen::Vector2d planar =
      Eigen::Rotation2Dd(-twist_ * a * w) * (x.head<2>() - state.sway * w * sway_m_) / (1 - radial_ * a * w);
  return {planar.x(), planar.y(), z};
}

}  // namespace dg::tools::phantom
