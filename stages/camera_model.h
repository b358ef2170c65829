#pragma once

#include <Eigen/Core>

#include "io/calibration.h"

namespace dg::stages {

// OpenCV's camera model written once, as a template so that Ceres can
// differentiate through it (T = ceres::Jet) and the phantom can render with it:
//   x' = x/z, y' = y/z, r^2 = x'^2 + y'^2,
//   radial = (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6),
//   x'' = x' radial + 2 p1 x'y' + p2 (r^2 + 2 x'^2),
//   y'' = y' radial + p1 (r^2 + 2 y'^2) + 2 p2 x'y',
//   u = fx x'' + cx,  v = fy y'' + cy.
// intrinsics = (fx, fy, cx, cy); distortion = (k1 k2 p1 p2 k3 k4 k5 k6).
template <typename T>
void DistortNormalized(const T* distortion, const T& x, const T& y, T* x_distorted, T* y_distorted) {
  const T& k1 = distortion[0];
  const T& k2 = distortion[1];
  const T& p1 = distortion[2];
  const T& p2 = distortion[3];
  const T& k3 = distortion[4];
  const T& k4 = distortion[5];
  const T& k5 = distortion[6];
  const T& k6 = distortion[7];
  const T r2 = x * x + y * y;
  const T radial = (T(1) + r2 * (k1 + r2 * (k2 + r2 * k3))) / (T(1) + r2 * (k4 + r2 * (k5 + r2 * k6)));
  *x_distorted = x * radial + T(2) * p1 * x * y + p2 * (r2 + T(2) * x * x);
  *y_distorted = y * radial + p1 * (r2 + T(2) * y * y) + T(2) * p2 * x * y;
}

// Pixel of a point in the camera frame (z forward). @pre point_C[2] > 0.
template <typename T>
void ProjectPoint(const T* intrinsics, const T* distortion, const T* point_C, T* uv) {
  const T x = point_C[0] / point_C[2];
  const T y = point_C[1] / point_C[2];
  T xd, yd;
  DistortNormalized(distortion, x, y, &xd, &yd);
  uv[0] = intrinsics[0] * xd + intrinsics[2];
  uv[1] = intrinsics[1] * yd + intrinsics[3];
}

// The same for a calibrated camera, in double.
inline Eigen::Vector2d Project(const io::CameraCalibration& camera, const Eigen::Vector3d& point_C) {
  const double intrinsics[4] = {camera.fx(), camera.fy(), camera.cx(), camera.cy()};
  Eigen::Vector2d uv;
  ProjectPoint(intrinsics, camera.distortion.data(), point_C.data(), uv.data());
  return uv;
}

// Undistorted normalised coordinates (x/z, y/z) of a distorted pixel, by
// fixed-point iteration to 1e-12 (converges for the moderate distortion of
// endoscopes; returns false if it does not).
bool UndistortPixel(const io::CameraCalibration& camera, const Eigen::Vector2d& uv, Eigen::Vector2d* normalized);

}  // namespace dg::stages
