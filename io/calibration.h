#pragma once

#include <array>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "io/calibration_source.h"

namespace dg::io {

// One camera of OpenCV's model: pinhole K and distortion coefficients in
// OpenCV's order (k1 k2 p1 p2 k3 k4 k5 k6; unused ones zero). Pixel (0,0) is
// the centre of the top-left pixel, as in OpenCV.
struct CameraCalibration {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  std::array<double, 8> distortion{};
  int num_distortion = 5;  // how many coefficients the file gives (4, 5, 8): written back the same way
  int width = 0, height = 0;

  double fx() const { return K(0, 0); }
  double fy() const { return K(1, 1); }
  double cx() const { return K(0, 2); }
  double cy() const { return K(1, 2); }
};

// A calibrated stereo pair as OpenCV's stereoCalibrate gives it: a point X_L in
// the left camera frame is R X_L + T in the right camera frame. T in metres.
// The rectification (R1 R2 P1 P2 Q, as stereoRectify gives it) is optional.
struct StereoCalibration {
  CameraCalibration left, right;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d T_m = Eigen::Vector3d::Zero();
  struct Rectification {
    Eigen::Matrix3d R1, R2;
    Eigen::Matrix<double, 3, 4> P1, P2;
    Eigen::Matrix4d Q;
  };
  std::optional<Rectification> rectification;

  // Essential and fundamental matrices implied by R, T and the intrinsics.
  Eigen::Matrix3d Essential() const;
  Eigen::Matrix3d Fundamental() const;
};

// Writes OpenCV FileStorage YAML with K1 D1 K2 D2 R T E F image_size (and
// R1 R2 P1 P2 Q when present), readable by cv::FileStorage and OpenCV's tools.
// @throws dg::Error when the file cannot be written.
void WriteStereoCalibration(const std::string& path, const StereoCalibration& calibration);

// A frame size in pixels, for a calibration whose files give none.
struct ImageSize {
  int width = 0, height = 0;
};

// Reads a stereo calibration from the files of `source` (one file in the
// layout above, with image_size optional; OpenCV's stereo_calib sample's
// intrinsics.yml and extrinsics.yml in either order; or the left and right
// camera's camera_info, followed by an extrinsics file when the two give no
// baseline; docs/formats/calibration.md). T (and the translations in P1, P2
// and Q) are scaled by source.metres_per_unit. E and F are recomputed from
// the other keys. Files without an image size take `video_size`, the size of
// the video the calibration serves; a file's own size is kept (callers
// compare it with the video's).
// @throws dg::Error naming the file and the missing or malformed key; for a
// file or a set of files of none of the accepted layouts, naming their key
// sets; for no image size and no video_size; for a baseline |T| outside a
// stereo endoscope's range, naming the unit T is probably in.
StereoCalibration ReadStereoCalibration(const CalibrationSource& source,
                                        const std::optional<ImageSize>& video_size = std::nullopt);

}  // namespace dg::io
