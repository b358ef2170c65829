// The tracking parts on synthetic inputs with exact answers: a known
// sub-pixel shift, a known rectified rig, and rejected options.
#include <algorithm>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "stages/track/feature_detector.h"
#include "stages/track/stereo_matcher.h"
#include "stages/track/temporal_tracker.h"
#include "stages/track/triangulator.h"
#include "tests/stages/track/rectified_phantom.h"

namespace dg::stages {
namespace {

using Catch::Matchers::Contains;

// Smooth random texture: noise blurred to blobs a few pixels across.
cv::Mat Texture(cv::Size size) {
  cv::Mat noise(size, CV_32F);
  cv::randn(noise, 0, 1);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
  cv::Mat image;
  cv::normalize(noise, noise, 20, 235, cv::NORM_MINMAX);
  noise.convertTo(image, CV_8U);
  return image;
}

TEST_CASE("stereo matcher: recovers a known sub-pixel disparity", "[stages][unit]") {
  cv::theRNG().state = 7;
  const cv::Mat left = Texture(cv::Size(320, 120));
  const double disparity = 37.3;
  cv::Mat right;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -disparity, 0, 1, 0);
  cv::warpAffine(left, right, shift, left.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  FeatureDetector::Options detector_options;
  detector_options.mser = false;
  detector_options.target_count = 100;
  std::vector<cv::Point2f> points;
  for (const Feature& f : FeatureDetector(detector_options).Detect(left))
    if (f.uv_R_px.x > 60) points.push_back(f.uv_R_px);
  StereoMatcher::Options options;
  options.max_disparity_px = 60;
  const std::vector<StereoMatch> matches = StereoMatcher(options).Match(left, right, points);
  std::vector<double> error_px;
  for (const StereoMatch& m : matches)
    if (m.valid) error_px.push_back(std::abs(m.disparity_px - disparity));
  std::sort(error_px.begin(), error_px.end());
  REQUIRE(error_px.size() >= 0.9 * points.size());
  WARN("disparity error median " << error_px[error_px.size() / 2] << " px, max " << error_px.back() << " px");
  CHECK(error_px[error_px.size() / 2] <= 0.05);
  CHECK(error_px.back() <= 0.2);  // the synthetic shift itself is cubic-interpolated and rounded to 8 bits
}

TEST_CASE("triangulator: a point seen in both rectified images triangulates to itself", "[stages][unit]") {
  io::StereoCalibration calibration;
  calibration.left.K << 600, 0, 320, 0, 600, 240, 0, 0, 1;
  calibration.left.distortion = {-0.2, 0.05, 0.001, -0.0005, 0, 0, 0, 0};
  calibration.left.width = 640, calibration.left.height = 480;
  calibration.right = calibration.left;
  calibration.right.K(0, 2) = 325;
  calibration.R = Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.3, 1, 0.1).normalized()).toRotationMatrix();
  calibration.T_m = Eigen::Vector3d(-0.005, 0.0002, 0.0001);
  CHECK_THROWS_WITH(Triangulator(calibration), Contains("no rectification"));

  testing::AddRectification(&calibration);
  const io::StereoCalibration::Rectification& rectification = *calibration.rectification;
  const Triangulator triangulator(calibration);

  const Eigen::Vector3d xyz_C(0.004, -0.003, 0.06);
  const Eigen::Vector3d in_left_R = rectification.R1 * xyz_C;
  const Eigen::Vector2d uv_left_R = (rectification.P1.leftCols<3>() * in_left_R).hnormalized();
  // P1 and P2 both project points of the rectified left frame.
  const Eigen::Vector2d uv_right_R = (rectification.P2 * in_left_R.homogeneous()).hnormalized();
  CHECK_THAT(uv_left_R.y() - uv_right_R.y(), Catch::Matchers::WithinAbs(0, 1e-9));
  CHECK((triangulator.Triangulate(uv_left_R, uv_left_R.x() - uv_right_R.x()) - xyz_C).norm() < 1e-9);
  // And back to the rectified pixel and disparity, with derivatives that central differences confirm.
  Eigen::Matrix3d d_dX;
  const Eigen::Vector3d uvd = triangulator.ToRectifiedDisparity(xyz_C, &d_dX);
  CHECK((uvd - Eigen::Vector3d(uv_left_R.x(), uv_left_R.y(), uv_left_R.x() - uv_right_R.x())).norm() < 1e-9);
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d h = 1e-7 * Eigen::Vector3d::Unit(c);
    const Eigen::Vector3d numeric =
        (triangulator.ToRectifiedDisparity(xyz_C + h) - triangulator.ToRectifiedDisparity(xyz_C - h)) / 2e-7;
    CHECK((d_dX.col(c) - numeric).norm() < 1e-5 * numeric.norm() + 1e-3);
  }
  // Original pixels, as OpenCV projects the point, and back.
  std::vector<cv::Point2d> left_px, right_px;
  const std::vector<cv::Point3d> point{{xyz_C.x(), xyz_C.y(), xyz_C.z()}};
  cv::Mat K1, K2, R, T, rvec;
  cv::eigen2cv(calibration.left.K, K1);
  cv::eigen2cv(calibration.right.K, K2);
  cv::eigen2cv(calibration.R, R);
  cv::eigen2cv(calibration.T_m, T);
  cv::Rodrigues(R, rvec);
  const cv::Mat D(1, 8, CV_64F, calibration.left.distortion.data());
  cv::projectPoints(point, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K1, D, left_px);
  cv::projectPoints(point, rvec, T, K2, D, right_px);
  CHECK((triangulator.LeftToDistorted(uv_left_R) - Eigen::Vector2d(left_px[0].x, left_px[0].y)).norm() < 1e-6);
  CHECK((triangulator.RightToDistorted(uv_right_R) - Eigen::Vector2d(right_px[0].x, right_px[0].y)).norm() < 1e-6);
  Eigen::Vector2d back;
  REQUIRE(triangulator.LeftToRectified(Eigen::Vector2d(left_px[0].x, left_px[0].y), &back));
  CHECK((back - uv_left_R).norm() < 1e-6);
}

// The disparity range of a depth range, f B / z rounded outwards; a pair
// whose right camera sits on the left (T's sign flipped, or left and right
// swapped) has negative disparities, which no matcher's range holds: named
// as such, not as an invalid matcher option.
TEST_CASE("triangulator: the disparity range of a depth range, and a right camera on the left", "[stages][unit]") {
  io::StereoCalibration calibration;
  calibration.left.K << 600, 0, 320, 0, 600, 240, 0, 0, 1;
  calibration.left.width = 640, calibration.left.height = 480;
  calibration.right = calibration.left;
  calibration.T_m = Eigen::Vector3d(-0.005, 0, 0);
  testing::AddRectification(&calibration);
  const auto [min_px, max_px] = Triangulator(calibration).DisparityRange(0.03, 0.3);
  const double f_px = calibration.rectification->P1(0, 0);
  CHECK(min_px == std::floor(f_px * 0.005 / 0.3));
  CHECK(max_px == std::ceil(f_px * 0.005 / 0.03));
  CHECK_THROWS_WITH(Triangulator(calibration).DisparityRange(0.3, 0.03), Contains("empty"));

  calibration.T_m = Eigen::Vector3d(0.005, 0, 0);
  testing::AddRectification(&calibration);
  CHECK_THROWS_WITH(Triangulator(calibration).DisparityRange(0.03, 0.3),
                    Contains("negative disparities") && Contains("right camera on the left") && Contains("swap"));
}

TEST_CASE("track options: invalid values are rejected by name", "[stages][unit]") {
  FeatureDetector::Options detector;
  detector.corners = detector.mser = false;
  CHECK_THROWS_AS(FeatureDetector(detector), Error);
  CHECK_THROWS_WITH(FeatureDetector(detector), Contains("enable at least one detector"));
  StereoMatcher::Options stereo;
  stereo.max_disparity_px = stereo.min_disparity_px;
  CHECK_THROWS_WITH(StereoMatcher(stereo), Contains("min_disparity_px < max_disparity_px"));
  TemporalTracker::Options temporal;
  temporal.window_px = 20;
  CHECK_THROWS_WITH(TemporalTracker(temporal), Contains("window_px"));
}

}  // namespace
}  // namespace dg::stages
