#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dg::stages {

// Follows points from one image to the next by pyramidal Lucas-Kanade and
// keeps only those that track back to where they started (forward-backward
// check): a point that has drifted onto other texture, or been occluded,
// does not return. Stateless; Track() is const.
class TemporalTracker {
 public:
  struct Options {
    int window_px = 21;
    int pyramid_levels = 3;
    int max_iterations = 30;
    double epsilon_px = 0.01;
    double forward_backward_px = 0.5;  // largest round-trip error kept
    std::string Validate() const;      // empty when valid
  };

  // An image's pyramid, built once and used as "next" for one frame and "previous" for the following one.
  using Pyramid = std::vector<cv::Mat>;

  // @throws dg::Error naming the invalid option.
  explicit TemporalTracker(const Options& options);

  // @pre image is CV_8UC1.
  Pyramid BuildPyramid(const cv::Mat& image) const;

  // Positions of `points` (in `previous`) in `next`; `tracked[i]` is false for
  // points lost or failing the forward-backward check. `initial` (optional,
  // same size as points) is a guess of the new positions.
  void Track(const Pyramid& previous, const Pyramid& next, const std::vector<cv::Point2f>& points,
             std::vector<cv::Point2f>* moved, std::vector<bool>* tracked,
             const std::vector<cv::Point2f>* initial = nullptr) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace dg::stages
