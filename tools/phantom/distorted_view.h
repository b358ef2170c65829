#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "io/calibration.h"
#include "stages/render/rasterizer.h"

namespace dg::tools::phantom {

// Renders what a calibrated camera sees through its lens: the scene is drawn
// by a pinhole camera wide enough to cover every distorted pixel, then each
// output pixel samples it where its (exactly undistorted) ray lands. So a
// point's pixel in the output is the OpenCV model's projection of it, which is
// what the ground truth says.
class DistortedView {
 public:
  // @throws dg::Error if the distortion cannot be inverted over the image.
  DistortedView(const io::CameraCalibration& camera, int supersample);

  stages::render::Rasterizer& rasterizer() { return rasterizer_; }

  // The distorted image, CV_32FC3 BGR: the supersampled render low-pass
  // filtered to the output's pixel size, then resampled.
  cv::Mat Resolve() const;

  // For each point (camera frame, one per column): 1 if it projects into the
  // image and is the nearest surface drawn along its ray within tolerance_m
  // (hidden points have something at least that much in front), else 0.
  std::vector<uint8_t> Visible(const Eigen::Matrix3Xd& points_C, double tolerance_m) const;

 private:
  io::CameraCalibration camera_;
  cv::Mat rays_;  // undistorted normalised coordinates of each output pixel; set-up only
  stages::render::Rasterizer rasterizer_;
  cv::Mat map_x_, map_y_;  // output pixel -> supersampled render pixel
};

}  // namespace dg::tools::phantom
