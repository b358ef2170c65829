#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tools/phantom/phantom_spec.h"
#include "tools/phantom/stereo_rig.h"

namespace dg::tools::phantom {

// The calibration target the phantom's endoscope is calibrated with: a
// chessboard of 9 x 6 inner corners (OpenCV's convention) and 4 mm squares,
// printed with a white border of one square.
struct Chessboard {
  static constexpr int kInnerCols = 9, kInnerRows = 6;
  static constexpr double kSquare_m = 0.004;
  static constexpr int kTexelsPerSquare = 64;

  // Texture of the whole print (11 x 8 squares plus the border), CV_8UC3.
  static cv::Mat Texture();
  // Inner corners in the board frame B (z = 0, x along rows), metres.
  static Eigen::Matrix3Xd InnerCorners_B();
  // The print's outline in B: origin at its top-left corner.
  static Eigen::Vector2d PrintSize_m();
};

// Poses of the board in the left camera frame, varied in distance, tilt and
// position, each with the whole print inside both images (seeded).
std::vector<Eigen::Isometry3d> SampleBoardPoses(const PhantomSpec& spec, const StereoRig& rig, int count);

}  // namespace dg::tools::phantom
