#pragma once

#include <vector>

#include <Eigen/Core>

namespace dg::stages {

// One fiducial in one video frame, in each eye's original (distorted) pixels.
struct FiducialSighting {
  bool in_left = false, in_right = false;
  Eigen::Vector2d uv_left_px = Eigen::Vector2d::Zero(), uv_right_px = Eigen::Vector2d::Zero();
};

// The registration window: frame times t_s[j] (video time, seconds) and the
// sightings frames[j][i] of fiducial i, in the scan's fiducial order.
struct FiducialTracks {
  std::vector<double> t_s;
  std::vector<std::vector<FiducialSighting>> frames;
};

}  // namespace dg::stages
