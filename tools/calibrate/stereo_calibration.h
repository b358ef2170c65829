#pragma once

#include <string>
#include <vector>

#include "io/calibration.h"

namespace dg::tools::calibrate {

// Which of OpenCV's distortion coefficients are estimated.
enum class DistortionModel {
  kK4,  // k1 k2 p1 p2 (k3 fixed at zero): narrow lenses, few views
  kK5,  // k1 k2 p1 p2 k3: OpenCV's default
  kK8,  // k1..k6 p1 p2, the rational model: strong (endoscope) distortion
};

// Parses "k4", "k5" or "k8". @throws dg::Error naming the known models.
DistortionModel ParseDistortionModel(const std::string& name);

struct StereoCalibrationOptions {
  int board_cols = 9, board_rows = 6;  // inner corners of the chessboard
  double square_m = 0.025;             // side of one square
  DistortionModel model = DistortionModel::kK5;
  // stereoRectify's free scaling of the rectified images written to the file:
  // 0 keeps only valid pixels (no black border), 1 keeps every source pixel.
  double alpha = 0;

  // Empty when valid; otherwise which field is wrong and why.
  std::string Validate() const;
};

// One stereo view of the board: a left and a right image taken at once.
struct ViewPair {
  std::string left_path, right_path;
};

struct StereoCalibrationReport {
  io::StereoCalibration calibration;  // with its rectification
  double rms_left_px = 0, rms_right_px = 0, rms_stereo_px = 0;
  // Mean |v_left - v_right| of the board's corners mapped to rectified pixels:
  // zero for a perfect calibration, whatever the scene.
  double epipolar_error_px = 0;
  std::vector<ViewPair> used;
  std::vector<std::string> rejected;  // one line per view: its files and why

  // Reprojection errors of one used view (in `used`'s order).
  struct ViewErrors {
    double rms_left_px = 0, rms_right_px = 0;        // each camera's own calibration
    double stereo_left_px = 0, stereo_right_px = 0;  // the stereo step's, per camera
    // |reprojected - detected| of each inner corner, row by row, from each camera's own calibration.
    std::vector<double> corner_left_px, corner_right_px;
  };
  std::vector<ViewErrors> views;
  // The baseline stereoCalibrate gives with the intrinsics left free (OpenCV's
  // one-step calibration): far from the baseline with them fixed, the views
  // do not pin the pair down.
  double free_intrinsics_baseline_m = 0;
  std::vector<std::string> warnings;  // one line each, for the user
};

// Zhang's method in the order that calibrates best: the board's corners found
// and refined to sub-pixel in every view, each camera calibrated on its own,
// then the pair's R and T with those intrinsics fixed (freeing them in the
// stereo step lets the larger problem trade intrinsics for a lower joint
// residual that does not generalise), then the rectification.
// Views where the board is not found in both images are rejected and named.
// @throws dg::Error for invalid options, an unreadable image, images of
// different sizes, or fewer than 3 usable views.
StereoCalibrationReport CalibrateStereo(const std::vector<ViewPair>& views,
                                        const StereoCalibrationOptions& options);

}  // namespace dg::tools::calibrate
