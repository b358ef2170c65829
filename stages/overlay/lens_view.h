#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "io/calibration.h"
#include "stages/render/pinhole_camera.h"

namespace dg::stages::overlay {

// How the overlays draw through a calibrated, distorting camera with the
// distortion-free rasterizer: each vertex x_C = (x, y, z) is moved to
// (x_d z, y_d z, z), (x_d, y_d) its distorted normalised coordinates (the
// OpenCV model of stages/camera_model.h), and the result is drawn by the
// pinhole camera with the calibration's K. So every vertex lands exactly on
// its distorted pixel and keeps its depth; only the interior of a triangle is
// interpolated linearly in the distorted image, an error of the order of the
// distortion's curvature across one triangle (hundredths of a pixel for
// millimetre triangles). This costs nothing per pixel, where rendering wide
// and resampling the image would.
//
// Beyond the image the polynomial model may fold back towards the centre;
// points farther out than 1.2 times the image's widest ray are moved by the
// radial factor of that limit instead, which keeps the map one-to-one.
// Immutable; safe to share between threads.
class LensView {
 public:
  // @throws dg::Error if the calibration has no image size or its distortion
  //   is not one-to-one over the image's field of view.
  LensView(const io::CameraCalibration& camera, const Eigen::Isometry3d& T_C_S);

  const io::CameraCalibration& camera() const { return camera_; }
  const Eigen::Isometry3d& T_C_S() const { return T_C_S_; }
  // The pinhole camera that draws the moved vertices: K and image size of the calibration.
  const render::PinholeCamera& pinhole() const { return pinhole_; }

  // Scan-frame points to the moved camera frame the pinhole draws, one per column.
  Eigen::Vector3d ToView(const Eigen::Vector3d& point_S) const;
  // Scalar float (for the rasterizer) or double; in parallel over points.
  template <typename Scalar>
  void ToView(const Eigen::Matrix3Xd& points_S, Eigen::Matrix<Scalar, 3, Eigen::Dynamic>* view) const;

  // CV_32FC1 per pixel: the length of its true (undistorted) ray per metre of
  // depth, sqrt(1 + x_u^2 + y_u^2). Computed on each call (inverts the lens per pixel).
  // @throws dg::Error if the lens cannot be inverted at a pixel.
  cv::Mat RayLengthPerDepth() const;

 private:
  io::CameraCalibration camera_;
  Eigen::Isometry3d T_C_S_;
  render::PinholeCamera pinhole_;
  double r2_limit_ = 0;  // squared normalised radius beyond which the radial factor is held
};

// The right eye's view of what the left camera sees at pose T_C_S: the right
// camera's calibration (intrinsics and distortion) at T_R_S = T_R_C T_C_S,
// T_R_C = [R | T] the stereo calibration's left-to-right transform.
// @throws dg::Error as LensView's constructor, for the right camera.
LensView RightLensView(const io::StereoCalibration& stereo, const Eigen::Isometry3d& T_C_S);

}  // namespace dg::stages::overlay
