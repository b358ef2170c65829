#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "io/calibration.h"

namespace dg::stages::testing {

// A generated phantom scene rectified with OpenCV directly (stereoRectify with
// alpha 0, then remap), independent of the project's rectification stage.
struct RectifiedPhantom {
  io::StereoCalibration calibration;  // the true calibration, with its rectification
  std::vector<cv::Mat> left_R, right_R;  // grey, one per frame
};

// Fills calibration->rectification with OpenCV's stereoRectify (alpha 0,
// zero disparity at infinity).
void AddRectification(io::StereoCalibration* calibration);

// Generates the default phantom of `duration_s` into the folder `dir`.
void GeneratePhantomScene(double duration_s, const std::string& dir);

RectifiedPhantom LoadRectified(const std::string& scene_dir);

// Points of a truth group (/surface_points or /fiducials) over frames:
// values[frame][point].
struct TruthTracks {
  std::vector<std::vector<Eigen::Vector2d>> uv_left_px, uv_right_px;
  std::vector<std::vector<Eigen::Vector3d>> xyz_C_m;
  std::vector<std::vector<bool>> visible_left, visible_right;
};
TruthTracks ReadTruth(const std::string& scene_dir, const std::string& group);

}  // namespace dg::stages::testing
