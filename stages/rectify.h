#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "io/calibration.h"
#include "stages/stereo_frame.h"

namespace dg::stages {

// The pinhole pair after rectification (frame R): both eyes share f, cy and
// the image rows; a point X_R projects to P_left [X_R; 1] and P_right [X_R; 1],
// with P_right = P_left + [0 0 0 -f baseline]. Disparity d = u_left - u_right
// gives depth z_R = f baseline / d (cx is the same in both: zero disparity at infinity).
struct RectifiedCamera {
  Eigen::Matrix3d R_R_C;  // the left camera frame C to R (stereoRectify's R1)
  Eigen::Matrix<double, 3, 4> P_left, P_right;
  double f_px = 0, cx_px = 0, cy_px = 0;
  double baseline_m = 0;
  cv::Size size;
};

struct RectifiedPair {
  std::int64_t index = 0;
  double t_s = 0;
  cv::Mat left, right;  // rectified images of the camera's size and the frame's type (BGR or grey)
};

// OpenCV's stereoRectify of a calibrated pair: zero disparity at infinity;
// alpha 0 keeps only valid pixels, 1 keeps every source pixel.
// @throws dg::Error if the two cameras' image sizes differ or are empty.
io::StereoCalibration::Rectification ComputeRectification(const io::StereoCalibration& calibration, double alpha);

// Rectifies raw stereo pairs. The maps are computed once at construction;
// Process() is const and allocates only its output, so several frames may be
// rectified at once; within one call both eyes are remapped in parallel.
class RectifyStage {
 public:
  enum class Eye { kLeft, kRight };

  struct Options {
    // stereoRectify's free scaling: 0 (the default) zooms in until every
    // rectified pixel has a source pixel, so that no black border gives the
    // tracker false corners; 1 keeps every source pixel in view (black
    // borders). The rectification stored in the calibration file, if any, is
    // not used: the maps and camera() always follow this alpha.
    double alpha = 0;
    int interpolation = cv::INTER_LINEAR;

    // Empty when valid; otherwise which field is wrong and why.
    std::string Validate() const;
  };

  // @throws dg::Error for invalid options or a calibration whose cameras
  // differ in image size.
  RectifyStage(const Options& options, const io::StereoCalibration& calibration);

  // @throws dg::Error when the frame's size is not the calibration's (naming both).
  RectifiedPair Process(const StereoFrame& frame) const;
  // The same into `into`'s images, which are reused when they have the size
  // already (a pipeline's pooled buffers: no allocation per frame).
  void Process(const StereoFrame& frame, RectifiedPair* into) const;

  const RectifiedCamera& camera() const { return camera_; }
  // The rectification these maps apply (R1 R2 P1 P2 Q), for the triangulator:
  // it must be this one, not one stored in the calibration file with another alpha.
  const io::StereoCalibration::Rectification& rectification() const { return rectification_; }

  // Where a pixel of the raw (distorted) image lands in the rectified one:
  // undistortion to 1e-12, the rectifying rotation, then P. std::nullopt when
  // the undistortion does not converge (far outside the calibrated field).
  std::optional<Eigen::Vector2d> RectifyPixel(Eye eye, const Eigen::Vector2d& uv_distorted) const;

 private:
  Options options_;
  io::StereoCalibration calibration_;
  Eigen::Matrix3d R_right_;  // the right camera's frame to R
  RectifiedCamera camera_;
  io::StereoCalibration::Rectification rectification_;
  cv::Mat map1_left_, map2_left_, map1_right_, map2_right_;
};

}  // namespace dg::stages
