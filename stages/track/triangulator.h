#pragma once

#include <utility>

#include <Eigen/Core>

#include "io/calibration.h"

namespace dg::stages {

// The geometry of a rectified stereo pair: 3D points from rectified matches,
// and conversions between rectified (R) and original, distorted pixels.
// Immutable after construction; every method is const and thread-safe.
class Triangulator {
 public:
  // @throws dg::Error if the calibration has no rectification (R1 R2 P1 P2 Q)
  // or the rectified cameras are not a horizontal pair.
  explicit Triangulator(const io::StereoCalibration& calibration);

  // The point in the left camera frame C, metres, of a left rectified pixel and
  // its disparity (u_left - u_right): [X Y Z W]^T = Q [u v d 1]^T in R, then
  // X_C = R1^T X_R. @pre disparity_px > 0 (a point in front of both cameras).
  Eigen::Vector3d Triangulate(const Eigen::Vector2d& uv_left_R_px, double disparity_px) const;
  // The inverse: the left rectified pixel and the disparity of a point in C,
  // as (u, v, d), and optionally their derivatives by X_C (rows u, v, d).
  // @pre the point lies in front of the cameras.
  Eigen::Vector3d ToRectifiedDisparity(const Eigen::Vector3d& X_C_m, Eigen::Matrix3d* d_dX_C = nullptr) const;

  // Original (distorted) pixel of a rectified pixel, through the ray it sees.
  Eigen::Vector2d LeftToDistorted(const Eigen::Vector2d& uv_R_px) const;
  Eigen::Vector2d RightToDistorted(const Eigen::Vector2d& uv_R_px) const;

  // Rectified pixel of an original (distorted) pixel; false if undistortion does not converge.
  bool LeftToRectified(const Eigen::Vector2d& uv_px, Eigen::Vector2d* uv_R_px) const;
  bool RightToRectified(const Eigen::Vector2d& uv_px, Eigen::Vector2d* uv_R_px) const;

  // Disparity (px) of a point at depth z_m: f B / z, for choosing a search range.
  double DisparityAtDepth(double z_m) const;
  // The disparities (px) of depths far_m and near_m, rounded outwards (the
  // smallest at least 0): a matcher's search range.
  // @throws dg::Error for an empty depth range, or a pair whose disparities
  //         are negative: its right camera sits on the left (left and right
  //         swapped in the calibration or the video).
  std::pair<double, double> DisparityRange(double near_m, double far_m) const;

 private:
  io::CameraCalibration left_, right_;
  io::StereoCalibration::Rectification rectification_;
};

}  // namespace dg::stages
