#include "tools/phantom/real_ct_motion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Dense>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "sim/error.h"

namespace dg::tools::phantom {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Fixed-point inversion: a step below this ends it (metres).
constexpr double kInversionStep_m = 1e-8;
constexpr int kMaxInversionIterations = 200;

// The Jacobian's lattice in rho: [-kLatticeExtent, kLatticeExtent]^3.
constexpr double kLatticeExtent = 4;
constexpr double kLatticeStep = 0.1;
constexpr double kDifferenceStep = 1e-5;

// max over p, q >= 0 of |g|^2 = exp(-(p^2 + q^2)) (p^2 (1 + twist^2 q^2) + shortening^2 q^2),
// the cardiac shape's squared length at distance p from the axis and q along
// it (its three terms are radial, axial and tangential: orthogonal). A coarse
// search, then a fine one around the best point.
double CardiacShapeMaximum(double twist, double shortening) {
  const auto squared = [&](double p, double q) {
    return std::exp(-(p * p + q * q)) * (p * p * (1 + twist * twist * q * q) + shortening * shortening * q * q);
  };
  double best = 0, best_p = 0, best_q = 0;
  for (double p = 0; p <= 4; p += 0.01) {
    for (double q = 0; q <= 4; q += 0.01) {
      if (const double s = squared(p, q); s > best) best = s, best_p = p, best_q = q;
    }
  }
  const double p0 = best_p, q0 = best_q;
  for (double p = std::max(0.0, p0 - 0.02); p <= p0 + 0.02; p += 1e-4) {
    for (double q = std::max(0.0, q0 - 0.02); q <= q0 + 0.02; q += 1e-4) best = std::max(best, squared(p, q));
  }
  return std::sqrt(best);
}

}  // namespace

std::string RealCtMotion::Parameters::Validate() const {
  if (!centre_S_m.allFinite()) return "the centre is not finite";
  if (!(axis_S.norm() > 0) || !axis_S.allFinite()) return "the axis is zero or not finite";
  if (!(window_m > 0) || !std::isfinite(window_m)) return "the window must be positive";
  if (!(amplitude_m > 0) || !std::isfinite(amplitude_m)) return "the amplitude must be positive";
  if (!(twist >= 0 && shortening >= 0 && expansion >= 0 && twist <= 1 && shortening <= 1 && expansion <= 1)) {
    return "twist, shortening and expansion must lie in [0, 1]";
  }
  return {};
}

RealCtMotion::RealCtMotion(const Parameters& parameters) : parameters_(parameters) {
  if (const std::string wrong = parameters.Validate(); !wrong.empty()) {
    throw Error("invalid motion: " + wrong, "RealCtMotion", "correct the motion's parameters");
  }
  parameters_.axis_S.normalize();
  shape_scale_ = 1 / ShapeMaximum();
}

const char* RealCtMotion::KindName(Kind kind) { return kind == Kind::kCardiac ? "cardiac" : "respiratory"; }

double RealCtMotion::ShapeMaximum() const {
  if (parameters_.kind == Kind::kCardiac) return CardiacShapeMaximum(parameters_.twist, parameters_.shortening);
  // |g|^2 = exp(-|rho|^2) (1 + expansion^2 rho_y^2) falls from rho = 0 for expansion < 1.
  return 1;
}

Eigen::Vector3d RealCtMotion::Shape(const Eigen::Vector3d& rho) const {
  const double w = std::exp(-0.5 * rho.squaredNorm());
  if (parameters_.kind == Kind::kRespiratory) {
    return w * Eigen::Vector3d(0, parameters_.expansion * rho.y(), -1);
  }
  const Eigen::Vector3d& n = parameters_.axis_S;
  const double along = rho.dot(n);
  const Eigen::Vector3d perpendicular = rho - along * n;
  return w * (-perpendicular - parameters_.shortening * along * n + parameters_.twist * along * n.cross(rho));
}

double RealCtMotion::Activation(double cycle_fraction) const {
  const double s = std::sin(kPi * cycle_fraction);
  return parameters_.kind == Kind::kCardiac ? s * s : s * s * s * s;
}

Eigen::Vector3d RealCtMotion::Displacement(const Eigen::Vector3d& X_S_m, double cycle_fraction) const {
  const double scale = parameters_.amplitude_m * Activation(cycle_fraction) * shape_scale_;
  if (scale == 0) return Eigen::Vector3d::Zero();
  return scale * Shape((X_S_m - parameters_.centre_S_m) / parameters_.window_m);
}

Eigen::Vector3d RealCtMotion::Undeform(const Eigen::Vector3d& x_S_m, double cycle_fraction) const {
  Eigen::Vector3d X = x_S_m - Displacement(x_S_m, cycle_fraction);
  for (int iteration = 0; iteration < kMaxInversionIterations; ++iteration) {
    const Eigen::Vector3d next = x_S_m - Displacement(X, cycle_fraction);
    const double step = (next - X).norm();
    X = next;
    if (step < kInversionStep_m) return X;
  }
  char where[128];
  std::snprintf(where, sizeof where, "x = (%.6g, %.6g, %.6g) mm, cycle fraction %.4g", 1e3 * x_S_m.x(),
                1e3 * x_S_m.y(), 1e3 * x_S_m.z(), cycle_fraction);
  throw Error("the motion's inverse did not converge", where,
              "lower --amplitude-mm (the motion's gradient must stay well below 1)");
}

RealCtMotion::JacobianBounds RealCtMotion::Jacobian(double cycle_fraction) const {
  // grad_X u = scale / window * grad_rho g.
  const double scale = parameters_.amplitude_m * Activation(cycle_fraction) * shape_scale_ / parameters_.window_m;
  const int points = static_cast<int>(std::lround(2 * kLatticeExtent / kLatticeStep)) + 1;
  const auto coordinate = [&](int index) { return -kLatticeExtent + kLatticeStep * index; };
  const auto combine = [](JacobianBounds a, const JacobianBounds& b) {
    a.min_determinant = std::min(a.min_determinant, b.min_determinant);
    a.max_gradient_norm = std::max(a.max_gradient_norm, b.max_gradient_norm);
    return a;
  };
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, points), JacobianBounds{},
      [&](const tbb::blocked_range<int>& planes, JacobianBounds bounds) {
        for (int a = planes.begin(); a != planes.end(); ++a) {
          for (int b = 0; b < points; ++b) {
            for (int c = 0; c < points; ++c) {
              const Eigen::Vector3d rho(coordinate(a), coordinate(b), coordinate(c));
              Eigen::Matrix3d gradient;
              for (int axis = 0; axis < 3; ++axis) {
                const Eigen::Vector3d h = kDifferenceStep * Eigen::Vector3d::Unit(axis);
                gradient.col(axis) = scale * (Shape(rho + h) - Shape(rho - h)) / (2 * kDifferenceStep);
              }
              bounds.min_determinant =
                  std::min(bounds.min_determinant, (Eigen::Matrix3d::Identity() + gradient).determinant());
              bounds.max_gradient_norm = std::max(bounds.max_gradient_norm, gradient.norm());
            }
          }
        }
        return bounds;
      },
      combine);
}

}  // namespace dg::tools::phantom
