#include "tools/phantom/heart_geometry.h"

#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

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

  // Vessel paths as straight lines in (u, v), from -> to; y < 0 (u near 0.75)
  // is the camera's side.
  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> paths = {
      {{0.00, 0.85}, {1.00, 0.85}},  // the ring of the atrioventricular groove
      {{0.28, 0.85}, {0.28, 0.08}},  // descending, far side
      {{0.78, 0.85}, {0.78, 0.12}},  // descending, camera side
      {{0.28, 0.35}, {0.45, 0.72}}, {{0.28, 0.50}, {0.10, 0.80}},
      {{0.78, 0.35}, {0.95, 0.70}}, {{0.78, 0.50}, {0.60, 0.80}}};
  constexpr int kPoints = 400;  // under 0.5 mm apart on the longest path
  std::vector<Eigen::Matrix3Xd> axes;
  for (const auto& [from, to] : paths) {
    Eigen::Matrix3Xd axis(3, kPoints);
    for (int p = 0; p < kPoints; ++p) {
      const Eigen::Vector2d uv = from + (to - from) * double(p) / (kPoints - 1);
      axis.col(p) = SurfacePoint(uv.x(), uv.y()) - kVesselDepth_m * SurfaceNormal(uv.x(), uv.y());
    }
    axes.push_back(axis);
  }
  vessels_ = TubeSet(axes, kVesselRadius_m);
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
