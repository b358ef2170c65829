#include "stages/track/triangulator.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>

#include "sim/error.h"
#include "stages/camera_model.h"

namespace dg::stages {
namespace {

Eigen::Vector3d RayOf(const Eigen::Matrix<double, 3, 4>& P, const Eigen::Vector2d& uv) {
  return {(uv.x() - P(0, 2)) / P(0, 0), (uv.y() - P(1, 2)) / P(1, 1), 1.0};
}

Eigen::Vector2d PixelOf(const Eigen::Matrix<double, 3, 4>& P, const Eigen::Vector3d& ray) {
  return {P(0, 0) * ray.x() / ray.z() + P(0, 2), P(1, 1) * ray.y() / ray.z() + P(1, 2)};
}

bool ToRectified(const io::CameraCalibration& camera, const Eigen::Matrix3d& R, const Eigen::Matrix<double, 3, 4>& P,
                 const Eigen::Vector2d& uv_px, Eigen::Vector2d* uv_R_px) {
  Eigen::Vector2d normalized;
  if (!UndistortPixel(camera, uv_px, &normalized)) return false;
  *uv_R_px = PixelOf(P, R * normalized.homogeneous());
  return true;
}

}  // namespace

Triangulator::Triangulator(const io::StereoCalibration& calibration)
    : left_(calibration.left), right_(calibration.right) {
  if (!calibration.rectification)
    throw Error("the stereo calibration has no rectification", "R1 R2 P1 P2 Q",
                "rectify the calibration (stereoRectify) before triangulating");
  rectification_ = *calibration.rectification;
  const auto& P1 = rectification_.P1;
  const auto& P2 = rectification_.P2;
  if (std::abs(P1(1, 2) - P2(1, 2)) > 1e-6 || std::abs(P2(1, 3)) > 1e-9 || std::abs(P2(0, 3)) < 1e-12)
    throw Error("the rectified cameras are not a horizontal pair", "P1 P2",
                "rectify with the cameras side by side (stereoRectify of a horizontal rig)");
}

Eigen::Vector3d Triangulator::Triangulate(const Eigen::Vector2d& uv_left_R_px, double disparity_px) const {
  const Eigen::Vector4d X = rectification_.Q * Eigen::Vector4d(uv_left_R_px.x(), uv_left_R_px.y(), disparity_px, 1.0);
  return rectification_.R1.transpose() * (X.head<3>() / X.w());
}

Eigen::Vector3d Triangulator::ToRectifiedDisparity(const Eigen::Vector3d& X_C_m, Eigen::Matrix3d* d_dX_C) const {
  const Eigen::Vector3d X_R = rectification_.R1 * X_C_m;
  const Eigen::Vector2d left = PixelOf(rectification_.P1, X_R);
  // The right rectified camera sees X_R shifted by its baseline: P2 = [K | K t], so
  // d = (f1 - f2) x / z + (cx1 - cx2) - P2_03 / z.
  const auto& P1 = rectification_.P1;
  const auto& P2 = rectification_.P2;
  const double u_right = (P2(0, 0) * X_R.x() + P2(0, 2) * X_R.z() + P2(0, 3)) / X_R.z();
  if (d_dX_C) {
    const double x = X_R.x(), y = X_R.y(), z = X_R.z(), df = P1(0, 0) - P2(0, 0);
    Eigen::Matrix3d d_dX_R;
    d_dX_R << P1(0, 0) / z, 0, -P1(0, 0) * x / (z * z),  //
        0, P1(1, 1) / z, -P1(1, 1) * y / (z * z),         //
        df / z, 0, (P2(0, 3) - df * x) / (z * z);
    *d_dX_C = d_dX_R * rectification_.R1;
  }
  return {left.x(), left.y(), left.x() - u_right};
}

Eigen::Vector2d Triangulator::LeftToDistorted(const Eigen::Vector2d& uv_R_px) const {
  return Project(left_, rectification_.R1.transpose() * RayOf(rectification_.P1, uv_R_px));
}

Eigen::Vector2d Triangulator::RightToDistorted(const Eigen::Vector2d& uv_R_px) const {
  return Project(right_, rectification_.R2.transpose() * RayOf(rectification_.P2, uv_R_px));
}

bool Triangulator::LeftToRectified(const Eigen::Vector2d& uv_px, Eigen::Vector2d* uv_R_px) const {
  return ToRectified(left_, rectification_.R1, rectification_.P1, uv_px, uv_R_px);
}

bool Triangulator::RightToRectified(const Eigen::Vector2d& uv_px, Eigen::Vector2d* uv_R_px) const {
  return ToRectified(right_, rectification_.R2, rectification_.P2, uv_px, uv_R_px);
}

double Triangulator::DisparityAtDepth(double z_m) const {
  // P2(0,3) = -f B (OpenCV's Tx f), and the principal points may differ by cx1 - cx2.
  const auto& P1 = rectification_.P1;
  const auto& P2 = rectification_.P2;
  return -P2(0, 3) / z_m + (P1(0, 2) - P2(0, 2));
}

std::pair<double, double> Triangulator::DisparityRange(double near_m, double far_m) const {
  if (!(near_m > 0 && near_m < far_m) || std::isnan(far_m)) {
    throw Error("the depth range " + std::to_string(near_m) + " to " + std::to_string(far_m) +
                    " m is empty or not in front of the camera",
                "--near/--far", "give 0 < near < far in metres, e.g. --near 0.03 --far 0.3");
  }
  const double nearest_px = DisparityAtDepth(near_m);
  if (!(nearest_px > 0)) {
    throw Error("depths of " + std::to_string(near_m) + " m and beyond have negative disparities (" +
                    std::to_string(nearest_px) + " px): the calibration puts the right camera on the left",
                "the stereo calibration's T",
                "swap the left and right videos, or calibrate again with the left camera's images first");
  }
  return {std::max(0.0, std::floor(DisparityAtDepth(far_m))), std::ceil(nearest_px)};
}

}  // namespace dg::stages
