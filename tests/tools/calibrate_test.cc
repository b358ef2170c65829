// Stereo calibration recovers the phantom's true cameras from its chessboard
// images (well enough that its rectification puts true point pairs on one
// row), and reaches the figures on OpenCV's real chessboard pairs.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/calibration.h"
#include "io/h5_file.h"
#include "stages/rectify.h"
#include "tests/support/temporary_folder.h"
#include "tools/calibrate/calibration_report.h"
#include "tools/calibrate/stereo_calibration.h"
#include "tools/calibrate/view_pairs.h"
#include "tools/phantom/phantom_generator.h"

namespace dg::tools::calibrate {
namespace {

namespace fs = std::filesystem;

const std::string kSamples = "/usr/share/doc/opencv-doc/examples/data/";

TEST_CASE("calibrate: the phantom's chessboards give its true cameras", "[tools][integration]") {
  const dg::testing::TemporaryFolder folder("dg_calibrate_test_default");
  const std::string& dir = folder.path();
  phantom::PhantomSpec spec = phantom::PresetSpec("default");
  spec.duration_s = 0.1;  // only the calibration images matter here
  phantom::GeneratePhantom(spec, dir, false);
  const io::StereoCalibration truth = io::ReadStereoCalibration(dir + "/calibration.yaml");

  StereoCalibrationOptions options;
  options.square_m = 0.004;
  const StereoCalibrationReport report = CalibrateStereo(PairsFromDirectory(dir + "/calibration"), options);
  INFO(DescribeReport(report));
  REQUIRE(report.rejected.empty());
  for (const auto& [found, expected] : {std::pair{&report.calibration.left, &truth.left},
                                        std::pair{&report.calibration.right, &truth.right}}) {
    CHECK(found->fx() == Approx(expected->fx()).epsilon(0.005));
    CHECK(found->fy() == Approx(expected->fy()).epsilon(0.005));
    CHECK(found->cx() == Approx(expected->cx()).margin(2.0));
    CHECK(found->cy() == Approx(expected->cy()).margin(2.0));
    // Regression bounds, about twice what is reached: focal lengths within
    // 0.038-0.049 % (left, right), principal points within 0.20 px (cy left;
    // the others 0.01-0.08 px).
    CHECK(found->fx() == Approx(expected->fx()).epsilon(0.001));
    CHECK(found->fy() == Approx(expected->fy()).epsilon(0.001));
    CHECK(found->cx() == Approx(expected->cx()).margin(0.4));
    CHECK(found->cy() == Approx(expected->cy()).margin(0.4));
  }
  CHECK(report.calibration.T_m.norm() == Approx(truth.T_m.norm()).epsilon(0.01));
  CHECK(report.calibration.T_m.norm() == Approx(truth.T_m.norm()).epsilon(0.0002));  // reached: 0.011 %

  const stages::RectifyStage stage({}, report.calibration);
  const io::H5Reader points(dir + "/truth.h5");
  const std::vector<double> uv_left = points.Read<double>("/surface_points/uv_left_px");
  const std::vector<double> uv_right = points.Read<double>("/surface_points/uv_right_px");
  const std::vector<uint8_t> visible_left = points.Read<uint8_t>("/surface_points/visible_left");
  const std::vector<uint8_t> visible_right = points.Read<uint8_t>("/surface_points/visible_right");
  std::vector<double> row_errors;
  for (size_t i = 0; i < visible_left.size(); ++i) {
    if (!visible_left[i] || !visible_right[i]) continue;
    const auto left = stage.RectifyPixel(stages::RectifyStage::Eye::kLeft, {uv_left[2 * i], uv_left[2 * i + 1]});
    const auto right = stage.RectifyPixel(stages::RectifyStage::Eye::kRight, {uv_right[2 * i], uv_right[2 * i + 1]});
    REQUIRE((left && right));
    row_errors.push_back(std::abs(left->y() - right->y()));
  }
  REQUIRE(row_errors.size() > 100);
  std::nth_element(row_errors.begin(), row_errors.begin() + row_errors.size() / 2, row_errors.end());
  CHECK(row_errors[row_errors.size() / 2] < 0.1);
}

TEST_CASE("calibrate: OpenCV's real chessboard pairs, with a rejected view named", "[tools][integration]") {
  const dg::testing::TemporaryFolder folder("dg_calibrate_test_samples");
  const fs::path dir = folder.path();
  std::vector<ViewPair> views = PairsFromPatterns(kSamples + "left??.jpg", kSamples + "right??.jpg");
  REQUIRE(views.size() == 13);  // left10/right10 are not shipped
  const std::string blank = (dir / "blank.png").string();
  REQUIRE(cv::imwrite(blank, cv::Mat(480, 640, CV_8UC1, cv::Scalar(128))));
  views.push_back({blank, views[0].right_path});

  StereoCalibrationOptions options;
  options.square_m = 0.025;
  const StereoCalibrationReport report = CalibrateStereo(views, options);
  INFO(DescribeReport(report));
  REQUIRE(report.used.size() == 13);
  REQUIRE(report.rejected.size() == 1);
  REQUIRE_THAT(report.rejected[0], Catch::Contains(blank) && Catch::Contains("board not found in left"));
  CHECK(report.rms_stereo_px <= 0.46);
  CHECK(report.epipolar_error_px <= 0.30);

  // Per view and per corner: the corners' errors, squared and averaged over
  // all views, give back OpenCV's overall RMS of each camera; each view's
  // RMS is its own corners'.
  REQUIRE(report.views.size() == 13);
  for (const auto& [overall, side] : {std::pair{report.rms_left_px, 0}, std::pair{report.rms_right_px, 1}}) {
    double sum2 = 0;
    size_t corners = 0;
    for (const StereoCalibrationReport::ViewErrors& view : report.views) {
      const std::vector<double>& errors = side == 0 ? view.corner_left_px : view.corner_right_px;
      REQUIRE(errors.size() == 54);
      double view_sum2 = 0;
      for (double e : errors) view_sum2 += e * e;
      CHECK(std::sqrt(view_sum2 / 54) == Approx(side == 0 ? view.rms_left_px : view.rms_right_px).epsilon(1e-4));
      sum2 += view_sum2, corners += errors.size();
    }
    CHECK(std::sqrt(sum2 / double(corners)) == Approx(overall).epsilon(1e-4));
  }
  // OpenCV's one-step calibration (intrinsics free) on the same corners finds
  // the same pair (0.06% apart; 5% would be warned of).
  INFO("baseline " << report.calibration.T_m.norm() * 1e3 << " mm, free " << report.free_intrinsics_baseline_m * 1e3);
  CHECK(report.calibration.T_m.norm() == Approx(report.free_intrinsics_baseline_m).epsilon(0.002));  // 0.06% here
  CHECK(report.warnings.empty());

  // The written files: the calibration reads back with its rectification, the JSON has the figures.
  const std::string yaml = (dir / "calibration.yaml").string(), json = (dir / "report.json").string();
  io::WriteStereoCalibration(yaml, report.calibration);
  WriteReportJson(json, report);
  const io::StereoCalibration read = io::ReadStereoCalibration(yaml);
  REQUIRE(read.rectification);
  REQUIRE((read.rectification->P2 - report.calibration.rectification->P2).norm() < 1e-9);
  std::stringstream text;
  text << std::ifstream(json).rdbuf();
  for (const char* key : {"\"rms_left_px\"", "\"rms_right_px\"", "\"rms_stereo_px\"", "\"epipolar_error_px\"",
                          "\"views_used\": 13", "\"baseline_free_intrinsics_m\"", "\"corner_errors_left_px\"",
                          "\"warnings\": []"}) {
    REQUIRE_THAT(text.str(), Catch::Contains(key));
  }
}

}  // namespace
}  // namespace dg::tools::calibrate
