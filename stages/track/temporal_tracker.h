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
    // A 15 px window on 3 levels (0..2) follows motion of up to about 28 px
    // per frame, several times the phantom's largest; it costs half of a
    // 21 px window on 4 levels.
    int window_px = 15;
    int pyramid_levels = 2;
    int max_iterations = 30;
    double epsilon_px = 0.01;
    double forward_backward_px = 0.5;  // largest round-trip error kept
    // Levels of the backward pass, which starts where a correct track returns
    // (the point's origin), so it needs no coarse levels to find a large motion.
    int backward_pyramid_levels = 0;
    std::string Validate() const;  // empty when valid
  };

  // An image's pyramid, built once and used as "next" for one frame and "previous" for the following one.
  using Pyramid = std::vector<cv::Mat>;

  // @throws dg::Error naming the invalid option.
  explicit TemporalTracker(const Options& options);

  // Into `pyramid`, reusing its images when they have the sizes already (a
  // tracker alternating two pyramids allocates none per frame).
  // @pre image is CV_8UC1; no other cv::Mat shares pyramid's images.
  void BuildPyramid(const cv::Mat& image, Pyramid* pyramid) const;

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
