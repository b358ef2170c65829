#include "tools/phantom/heart_geometry.h"

#include <cmath>
#include <numbers>

namespace dg::tools::phantom {

HeartGeometry::HeartGeometry(const PhantomSpec& spec) {
  body_ = {Eigen::Vector3d(0, 0, spec.centre_height_m), spec.semi_axes_m};
  // Chambers scaled with the body: a larger one left of centre, a smaller one
  // right, both well inside the tissue so the wall is a few millimetres thick.
  const Eigen::Vector3d s = spec.semi_axes_m;
  const double h = spec.centre_height_m;
  chambers_ = {{Eigen::Vector3d(-0.25 * s.x(), 0.05 * s.y(), h + 0.05 * s.z()), Eigen::Vector3d(0.33, 0.35, 0.55).cwiseProduct(s)},
               {Eigen::Vector3d(0.33 * s.x(), -0.1 * s.y(), h - 0.05 * s.z()), Eigen::Vector3d(0.25, 0.28, 0.42).cwiseProduct(s)}};
  max_polar_rad_ = std::acos(-spec.centre_height_m / spec.semi_axes_m.z());
}

bool HeartGeometry::InTissue(const Eigen::Vector3d& X) const { return X.z() >= 0 && body_.Contains(X); }

int HeartGeometry::ChamberAt(const Eigen::Vector3d& X) const {
  for (size_t i = 0; i < chambers_.size(); ++i) {
    if (chambers_[i].Contains(X)) return static_cast<int>(i);
  }
  return -1;
}

bool HeartGeometry::InMount(const Eigen::Vector3d& x) {
  return x.z() < 0 && x.z() >= -kMountThickness_m && std::abs(x.x()) <= kMountHalfWidth_m &&
         std::abs(x.y()) <= kMountHalfWidth_m;
}

Eigen::Vector3d HeartGeometry::SurfacePoint(double u, double v) const {
  const double azimuth = 2 * std::numbers::pi * u, polar = v * max_polar_rad_;
  return body_.centre_m + body_.semi_axes_m.cwiseProduct(Eigen::Vector3d(
                              std::sin(polar) * std::cos(azimuth), std::sin(polar) * std::sin(azimuth), std::cos(polar)));
}

Eigen::Vector3d HeartGeometry::SurfaceNormal(double u, double v) const {
  // The gradient of the implicit ellipsoid equation.
  const Eigen::Vector3d p = SurfacePoint(u, v) - body_.centre_m;
  return p.cwiseQuotient(body_.semi_axes_m.cwiseProduct(body_.semi_axes_m)).normalized();
}

}  // namespace dg::tools::phantom
