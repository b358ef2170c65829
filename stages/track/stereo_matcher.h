#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dg::stages {

// A left point's match on the same row of the rectified right image:
// u_right = u_left - disparity_px.
struct StereoMatch {
  bool valid = false;
  float disparity_px = 0;
  float score = 0;  // normalised cross-correlation of the windows at the match, in [-1, 1]
};

// Matches points of the rectified left image along their row in the rectified
// right image. Pyramidal LK alone fails at large disparities (it converges to
// the nearest similar structure), so the match is a search first: normalised
// cross-correlation at every integer disparity of the range, the best peak
// accepted only if it is clearly better than any other (repeated texture) and
// if searching back from it finds the start again (left-right check); then
// sub-pixel: a parabola through the peak and its neighbours, and Gauss-Newton
// on the zero-mean, unit-variance windows along x only, which removes the
// parabola's bias towards whole pixels.
// Stateless; Match() is const and may run on several frames at once; within one
// call the points are matched in parallel (TBB), each writing only its own result
// and each task reusing its own buffers (a point allocates nothing).
class StereoMatcher {
 public:
  struct Options {
    double min_disparity_px = 0, max_disparity_px = 64;
    int half_window_px = 5;            // windows of (2h+1)^2 pixels
    double min_score = 0.8;            // NCC below this: no match
    double uniqueness_margin = 0.03;   // the best NCC must beat the best NCC away from its peak by this
    double left_right_tolerance_px = 1.0;
    int refine_iterations = 10;
    double expected_window_px = 4;     // search half-width around an expected disparity (tracks known in the last frame)
    std::string Validate() const;  // empty when valid
  };

  // @throws dg::Error naming the invalid option.
  explicit StereoMatcher(const Options& options);

  // One match per point. Where `expected_disparity_px` (optional, one per
  // point) is not negative, only expected_window_px either side of it is
  // searched: a tracked point's disparity changes little between frames, and
  // the full range costs most of the tracking stage's time.
  // @pre left and right are CV_8UC1 of one size.
  std::vector<StereoMatch> Match(const cv::Mat& left, const cv::Mat& right, const std::vector<cv::Point2f>& uv_left_px,
                                 const std::vector<float>* expected_disparity_px = nullptr) const;

  const Options& options() const { return options_; }

 private:
  struct Peak {
    bool found = false;
    double disparity = 0, score = 0;
  };
  struct Scratch;           // one thread's buffers, defined in the .cc
  struct ScratchPerThread;  // tbb::enumerable_thread_specific<Scratch>
  // The best disparity in [d_min, d_max] from `from` at p into `to`, along
  // the row; direction -1 looks left of p (left to right image), +1 right of it.
  Peak SearchRow(const cv::Mat& from, const cv::Mat& to, const cv::Point2f& p, int direction, int d_min, int d_max,
                 Scratch* scratch) const;
  // Gauss-Newton along x from an initial disparity; false if it does not settle.
  bool Refine(const cv::Mat& left, const cv::Mat& right, const cv::Point2f& p, double* disparity,
              Scratch* scratch) const;

  Options options_;
  // Each thread's buffers, kept from call to call: they grow to the largest
  // window and range met, and then matching allocates nothing. Shared by
  // copies: a thread runs one match at a time (no waits inside one).
  std::shared_ptr<ScratchPerThread> scratch_;
};

}  // namespace dg::stages
