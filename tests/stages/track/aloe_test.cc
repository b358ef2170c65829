// Sparse stereo matches on a real rectified pair (Middlebury's Aloe, as
// OpenCV's sample data ships it) checked against its ground-truth disparity.
#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>

#include "stages/track/feature_detector.h"
#include "stages/track/stereo_matcher.h"

namespace dg::stages {
namespace {

const std::string kData = "/usr/share/doc/opencv-doc/examples/data/";

struct Score {
  int matches = 0, within_1px = 0;
};

// aloeGT.png is the full-size Middlebury disparity of aloeL at scale 1
// (8-bit, 0 = unknown): same size as aloeL, values 43..211 (checked below).
Score MatchAloe(const FeatureDetector::Options& detector_options) {
  const cv::Mat left = cv::imread(kData + "aloeL.jpg", cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(kData + "aloeR.jpg", cv::IMREAD_GRAYSCALE);
  const cv::Mat truth = cv::imread(kData + "aloeGT.png", cv::IMREAD_GRAYSCALE);
  REQUIRE(!left.empty());
  REQUIRE(truth.size() == left.size());
  double lowest = 0, highest = 0;
  cv::minMaxLoc(truth, &lowest, &highest, nullptr, nullptr, truth > 0);
  REQUIRE(lowest >= 40);
  REQUIRE(highest <= 215);

  const std::vector<Feature> features = FeatureDetector(detector_options).Detect(left);
  std::vector<cv::Point2f> points;
  for (const Feature& f : features) points.push_back(f.uv_R_px);
  StereoMatcher::Options stereo_options;
  stereo_options.min_disparity_px = 30;
  stereo_options.max_disparity_px = 230;
  const std::vector<StereoMatch> matches = StereoMatcher(stereo_options).Match(left, right, points);
  Score score;
  for (size_t i = 0; i < matches.size(); ++i) {
    const uchar d = truth.at<uchar>(cvRound(points[i].y), cvRound(points[i].x));
    if (!matches[i].valid || d == 0) continue;
    ++score.matches;
    if (std::abs(matches[i].disparity_px - d) <= 1.0) ++score.within_1px;
  }
  WARN("features " << features.size() << ", matches with known truth " << score.matches << ", within 1 px "
                   << score.within_1px);
  return score;
}

TEST_CASE("stereo matcher: Aloe corners match within 1 px of the true disparity", "[stages][integration]") {
  FeatureDetector::Options options;
  options.mser = false;
  options.target_count = 1000;
  const Score score = MatchAloe(options);
  CHECK(score.matches >= 300);
  CHECK(score.within_1px >= 0.95 * score.matches);
}

TEST_CASE("stereo matcher: Aloe MSER centroids match within 1 px of the true disparity", "[stages][integration]") {
  FeatureDetector::Options options;
  options.corners = false;
  options.target_count = 1000;
  const Score score = MatchAloe(options);
  CHECK(score.matches >= 300);
  CHECK(score.within_1px >= 0.95 * score.matches);
}

}  // namespace
}  // namespace dg::stages
