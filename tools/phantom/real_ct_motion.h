#pragma once

#include <string>

#include <Eigen/Core>

namespace dg::tools::phantom {

// The known motion a real CT is warped by (docs/commands/phantom.md, "A
// phantom from a real CT"): a smooth, invertible map of the scan frame S,
// X -> x = X + u(X, phi) at cycle fraction phi in [0, 1), zero at phi = 0.
//
// With rho = (X - centre) / window (dimensionless) and w = exp(-|rho|^2 / 2),
//   cardiac:     g(rho) = w (-rho_perp - shortening rho_par + twist (rho . n) (n x rho))
//                contraction towards the axis n through the centre, shortening
//                along it and a twist about it growing along it, as the
//                phantom's heart (heart_motion.h); activation sin^2(pi phi);
//   respiratory: g(rho) = w (-e_z + expansion rho_y e_y)
//                a translation towards the feet (S's z is superior in DICOM's
//                LPS patient frame) and an anterior-posterior expansion (y is
//                posterior); activation sin^4(pi phi), Lujan's breathing curve
//                with n = 2 (longer at end-exhale, phi = 0);
// and u(X, phi) = amplitude activation(phi) g(rho) / max|g|, so that the
// largest displacement over space and the cycle is the amplitude. The
// motion's scale is the window: its gradient is about amplitude / (0.6
// window). Immutable; thread-safe.
class RealCtMotion {
 public:
  enum class Kind { kCardiac, kRespiratory };

  struct Parameters {
    Kind kind = Kind::kCardiac;
    Eigen::Vector3d centre_S_m = Eigen::Vector3d::Zero();
    Eigen::Vector3d axis_S = Eigen::Vector3d::UnitZ();  // n, cardiac only; normalised on construction
    double window_m = 0.04;
    double amplitude_m = 0.004;
    double twist = 0.5;        // cardiac: twist relative to the contraction
    double shortening = 0.5;   // cardiac: shortening along n relative to the contraction
    double expansion = 0.3;    // respiratory: AP expansion relative to the translation

    std::string Validate() const;  // empty when valid
  };

  // The Jacobian of X -> X + u(X, phi) over all of space: its smallest
  // determinant, and the largest Frobenius norm of grad u (the fixed-point
  // inversion converges when it is below 1).
  struct JacobianBounds {
    double min_determinant = 1;
    double max_gradient_norm = 0;
  };

  // @throws dg::Error for invalid parameters.
  explicit RealCtMotion(const Parameters& parameters);

  const Parameters& parameters() const { return parameters_; }
  static const char* KindName(Kind kind);

  // 0 at phi = 0, 1 at phi = 1/2.
  double Activation(double cycle_fraction) const;
  // u(X, phi) in metres.
  Eigen::Vector3d Displacement(const Eigen::Vector3d& X_S_m, double cycle_fraction) const;
  // X with X + u(X, phi) = x, by fixed-point iteration X <- x - u(X) until a
  // step is below 1e-5 mm (so X is within 1e-4 mm of the exact inverse while
  // grad u's norm is below 0.9). @throws dg::Error when it does not converge.
  Eigen::Vector3d Undeform(const Eigen::Vector3d& x_S_m, double cycle_fraction) const;
  // Over a lattice of rho in [-4, 4]^3 at steps of 0.1 (grad g is below 1e-5
  // beyond), grad g by central differences: the field's scale is the window,
  // so the lattice resolves it at any size of CT.
  JacobianBounds Jacobian(double cycle_fraction) const;

 private:
  Eigen::Vector3d Shape(const Eigen::Vector3d& rho) const;  // g(rho)
  double ShapeMaximum() const;                              // max |g|

  Parameters parameters_;
  double shape_scale_ = 1;  // 1 / max |g|
};

}  // namespace dg::tools::phantom
