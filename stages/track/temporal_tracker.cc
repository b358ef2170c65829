#include "stages/track/temporal_tracker.h"

#include <opencv2/video/tracking.hpp>

#include "sim/error.h"

namespace dg::stages {

std::string TemporalTracker::Options::Validate() const {
  if (window_px < 5 || window_px % 2 == 0) return "window_px must be odd and at least 5";
  if (pyramid_levels < 0) return "pyramid_levels must not be negative";
  if (max_iterations <= 0) return "max_iterations must be positive";
  if (epsilon_px <= 0) return "epsilon_px must be positive";
  if (forward_backward_px <= 0) return "forward_backward_px must be positive";
  if (backward_pyramid_levels < 0 || backward_pyramid_levels > pyramid_levels)
    return "backward_pyramid_levels must lie in [0, pyramid_levels]";
  return {};
}

TemporalTracker::TemporalTracker(const Options& options) : options_(options) {
  if (const std::string error = options.Validate(); !error.empty())
    throw Error("invalid temporal tracker options: " + error, "TemporalTracker::Options", "correct the option");
}

void TemporalTracker::BuildPyramid(const cv::Mat& image, Pyramid* pyramid) const {
  DG_CHECK(image.type() == CV_8UC1);
  cv::buildOpticalFlowPyramid(image, *pyramid, cv::Size(options_.window_px, options_.window_px),
                              options_.pyramid_levels);
}

void TemporalTracker::Track(const Pyramid& previous, const Pyramid& next, const std::vector<cv::Point2f>& points,
                            std::vector<cv::Point2f>* moved, std::vector<bool>* tracked,
                            const std::vector<cv::Point2f>* initial) const {
  tracked->assign(points.size(), false);
  moved->clear();
  if (points.empty()) return;
  const cv::Size window(options_.window_px, options_.window_px);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options_.max_iterations,
                                  options_.epsilon_px);
  int flags = 0;
  if (initial != nullptr) {
    DG_CHECK(initial->size() == points.size());
    *moved = *initial;
    flags = cv::OPTFLOW_USE_INITIAL_FLOW;
  }
  std::vector<uchar> forward_ok, backward_ok;
  std::vector<float> errors;
  cv::calcOpticalFlowPyrLK(previous, next, points, *moved, forward_ok, errors, window, options_.pyramid_levels,
                           criteria, flags);
  // Back from where each point went, starting at its origin: a correct track returns there.
  std::vector<cv::Point2f> back = points;
  cv::calcOpticalFlowPyrLK(next, previous, *moved, back, backward_ok, errors, window,
                           options_.backward_pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  const double limit2 = options_.forward_backward_px * options_.forward_backward_px;
  const cv::Size size = next.front().size();
  for (size_t i = 0; i < points.size(); ++i) {
    const cv::Point2f d = back[i] - points[i];
    const cv::Point2f& m = (*moved)[i];
    (*tracked)[i] = forward_ok[i] && backward_ok[i] && d.dot(d) <= limit2 && m.x >= 0 && m.y >= 0 &&
                    m.x <= size.width - 1 && m.y <= size.height - 1;
  }
}

}  // namespace dg::stages
