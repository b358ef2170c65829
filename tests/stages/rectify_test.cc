// RectifyStage on the tiny phantom with its true calibration: true point
// pairs land on one rectified row, agree with OpenCV's own point
// rectification, and give the true depth from their disparity.
#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/videoio.hpp>

#include "io/calibration.h"
#include "io/h5_file.h"
#include "sim/error.h"
#include "sim/statistics.h"
#include "stages/rectify.h"
#include "tests/support/temporary_folder.h"
#include "tools/phantom/phantom_generator.h"

namespace dg::stages {
namespace {

using Eye = RectifyStage::Eye;

TEST_CASE("rectify: true point pairs share a rectified row on the phantom", "[stages][integration]") {
  const testing::TemporaryFolder folder("dg_rectify_test_tiny");
  const std::string& dir = folder.path();
  tools::phantom::GeneratePhantom(tools::phantom::PresetSpec("tiny"), dir, false);
  const io::StereoCalibration calibration = io::ReadStereoCalibration(dir + "/calibration.yaml");
  const RectifyStage stage({}, calibration);
  const RectifiedCamera& camera = stage.camera();
  REQUIRE(camera.baseline_m == Approx(calibration.T_m.norm()).epsilon(1e-9));

  // OpenCV's rectification of the same calibration, as an independent check of RectifyPixel.
  cv::Mat K1, D1, K2, D2, R, T, R1, R2, P1, P2, Q;
  cv::FileStorage file(dir + "/calibration.yaml", cv::FileStorage::READ);
  file["K1"] >> K1, file["D1"] >> D1, file["K2"] >> K2, file["D2"] >> D2, file["R"] >> R, file["T"] >> T;
  cv::stereoRectify(K1, D1, K2, D2, camera.size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0);
  const cv::TermCriteria converged(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-14);

  const io::H5Reader truth(dir + "/truth.h5");
  io::H5Shape shape;
  const std::vector<double> xyz_C = truth.Read<double>("/surface_points/xyz_C_m", &shape);
  const std::vector<double> uv_left = truth.Read<double>("/surface_points/uv_left_px");
  const std::vector<double> uv_right = truth.Read<double>("/surface_points/uv_right_px");
  const std::vector<uint8_t> visible_left = truth.Read<uint8_t>("/surface_points/visible_left");
  const std::vector<uint8_t> visible_right = truth.Read<uint8_t>("/surface_points/visible_right");
  std::vector<double> row_errors, opencv_errors, depth_errors;
  for (size_t i = 0; i < shape[0] * shape[1]; ++i) {
    if (!visible_left[i] || !visible_right[i]) continue;
    const Eigen::Vector2d distorted_left(uv_left[2 * i], uv_left[2 * i + 1]);
    const Eigen::Vector2d distorted_right(uv_right[2 * i], uv_right[2 * i + 1]);
    const std::optional<Eigen::Vector2d> left = stage.RectifyPixel(Eye::kLeft, distorted_left);
    const std::optional<Eigen::Vector2d> right = stage.RectifyPixel(Eye::kRight, distorted_right);
    REQUIRE(left);
    REQUIRE(right);
    row_errors.push_back(std::abs(left->y() - right->y()));

    std::vector<cv::Point2d> opencv_left;
    cv::undistortPoints(std::vector<cv::Point2d>{{distorted_left.x(), distorted_left.y()}}, opencv_left, K1, D1, R1,
                        P1, converged);
    opencv_errors.push_back((*left - Eigen::Vector2d(opencv_left[0].x, opencv_left[0].y)).norm());

    const double z_R = (camera.R_R_C * Eigen::Vector3d(xyz_C[3 * i], xyz_C[3 * i + 1], xyz_C[3 * i + 2])).z();
    depth_errors.push_back(std::abs(camera.f_px * camera.baseline_m / (left->x() - right->x()) - z_R));
  }
  INFO(row_errors.size() << " visible pairs");
  REQUIRE(row_errors.size() > 100);
  CHECK(sim::Median(row_errors) < 0.1);
  CHECK(sim::Median(opencv_errors) < 1e-3);
  CHECK(sim::Median(depth_errors) < 1e-6);

  cv::VideoCapture video(dir + "/video/left.avi");
  StereoFrame frame{0, 0, cv::Mat(), cv::Mat()};
  REQUIRE(video.read(frame.left));
  frame.right = frame.left;
  const RectifiedPair pair = stage.Process(frame);
  REQUIRE(pair.left.size() == camera.size);
  REQUIRE(pair.right.size() == camera.size);
  REQUIRE(cv::mean(pair.left)[2] > 20);  // red tissue, not an empty remap

  frame.right = cv::Mat(10, 10, CV_8UC3);
  REQUIRE_THROWS_WITH(stage.Process(frame), Catch::Contains("10x10") && Catch::Contains("160x120"));
}

}  // namespace
}  // namespace dg::stages
