#include "stages/camera_model.h"

#include <cmath>

#include <Eigen/LU>

namespace dg::stages {

bool UndistortPixel(const io::CameraCalibration& camera, const Eigen::Vector2d& uv, Eigen::Vector2d* normalized) {
  const Eigen::Vector2d target((uv.x() - camera.cx()) / camera.fx(), (uv.y() - camera.cy()) / camera.fy());
  auto distort = [&](const Eigen::Vector2d& p) {
    Eigen::Vector2d d;
    DistortNormalized(camera.distortion.data(), p.x(), p.y(), &d.x(), &d.y());
    return d;
  };
  // Newton's method with a central-difference Jacobian: quadratic convergence
  // where OpenCV's fixed-point iteration is linear.
  Eigen::Vector2d p = target;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const Eigen::Vector2d residual = distort(p) - target;
    if (residual.norm() < 1e-13) {
      *normalized = p;
      return true;
    }
    constexpr double h = 1e-7;
    Eigen::Matrix2d jacobian;
    for (int i = 0; i < 2; ++i) {
      Eigen::Vector2d step = Eigen::Vector2d::Zero();
      step[i] = h;
      jacobian.col(i) = (distort(p + step) - distort(p - step)) / (2 * h);
    }
    p -= jacobian.partialPivLu().solve(residual);
    if (!p.allFinite()) return false;
  }
  return false;
}

}  // namespace dg::stages
