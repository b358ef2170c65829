#pragma once

#include <vector>

#include <Eigen/Core>

#include "tools/phantom/phantom_spec.h"
#include "tools/phantom/tube_set.h"

namespace dg::tools::phantom {

// An axis-aligned ellipsoid: centre and semi-axes, metres.
struct Ellipsoid {
  Eigen::Vector3d centre_m, semi_axes_m;
  bool Contains(const Eigen::Vector3d& X) const {
    return (X - centre_m).cwiseQuotient(semi_axes_m).squaredNorm() <= 1.0;
  }
};

// The phantom in its reference (end-diastolic) configuration, scan frame S:
// tissue is the ellipsoid of the spec above the mount plane z = 0; two
// ellipsoidal chambers inside stand in for internal anatomy; the mount is a
// plate under z = 0 that never moves. The curved surface is parameterised by
// (u, v) in [0,1]^2: u the azimuth about the long axis (u = 0 along +x,
// counter-clockwise seen from above), v the polar angle from the top pole
// (v = 0) down to the base rim (v = 1); these are also its texture coordinates.
// Coronary vessels in their epicardial fat run just under the surface (a ring
// near the base, two descending branches on opposite sides, four oblique ones)
// and give the CT edges in every direction along the surface, as a cardiac CT
// shows them.
class HeartGeometry {
 public:
  explicit HeartGeometry(const PhantomSpec& spec);

  bool InTissue(const Eigen::Vector3d& X_S) const;
  // -1 outside the chambers, else the chamber's index.
  int ChamberAt(const Eigen::Vector3d& X_S) const;
  bool InVessel(const Eigen::Vector3d& X_S) const { return vessels_.Contains(X_S); }
  static bool InMount(const Eigen::Vector3d& x_S);

  Eigen::Vector3d SurfacePoint(double u, double v) const;
  // Outward unit normal of the reference surface.
  Eigen::Vector3d SurfaceNormal(double u, double v) const;

  const Ellipsoid& body() const { return body_; }
  const std::vector<Ellipsoid>& chambers() const { return chambers_; }
  double max_polar_rad() const { return max_polar_rad_; }

  static constexpr double kMountThickness_m = 0.005;
  static constexpr double kMountHalfWidth_m = 0.045;
  static constexpr double kVesselRadius_m = 1.0e-3;
  static constexpr double kVesselDepth_m = 1.6e-3;  // of the vessel's axis under the surface

 private:
  Ellipsoid body_;
  std::vector<Ellipsoid> chambers_;
  double max_polar_rad_;  // polar angle of the base rim, where the ellipsoid meets z = 0
  TubeSet vessels_;
};

}  // namespace dg::tools::phantom
