// `dynaguide calibrate` as a user runs it: the command line parsed by the
// command's own CLI definition, the calibration run, and the YAML and JSON it
// writes read back by OpenCV's FileStorage and as text, with the issue's
// figures on OpenCV's real chessboard pairs.
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <catch2/catch.hpp>
#include <opencv2/core.hpp>

#include "sim/error.h"
#include "tests/support/temporary_folder.h"
#include "tools/commands.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

const std::string kSamples = "/usr/share/doc/opencv-doc/examples/data/";

// Runs `dynaguide ARGS...` through the calibrate subcommand, as main() does.
void RunCommand(const std::vector<std::string>& args) {
  CLI::App app("dynaguide");
  app.require_subcommand(1);
  AddCalibrateCommand(app);
  std::vector<const char*> argv{"dynaguide"};
  for (const std::string& arg : args) argv.push_back(arg.c_str());
  app.parse(static_cast<int>(argv.size()), argv.data());
}

double JsonNumber(const std::string& json, const std::string& key) {
  std::smatch match;
  REQUIRE(std::regex_search(json, match, std::regex("\"" + key + R"(\": ([-+0-9.eE]+))")));
  return std::stod(match[1]);
}

TEST_CASE("calibrate command: OpenCV's chessboard pairs to YAML and JSON", "[tools][integration]") {
  const testing::TemporaryFolder folder("dg_calibrate_command_test");
  const std::string yaml = folder.File("calib.yaml"), json = folder.File("calib.json");
  RunCommand({"calibrate", "--left", kSamples + "left??.jpg", "--right", kSamples + "right??.jpg", "--board", "9x6",
              "--square", "0.025", "--out", yaml, "--json", json});

  cv::FileStorage storage(yaml, cv::FileStorage::READ);
  REQUIRE(storage.isOpened());
  cv::Mat K1, D1, K2, D2, R, T, E, F, R1, R2, P1, P2, Q;
  for (const auto& [name, matrix] : {std::pair{"K1", &K1}, {"D1", &D1}, {"K2", &K2}, {"D2", &D2}, {"R", &R},
                                     {"T", &T}, {"E", &E}, {"F", &F}, {"R1", &R1}, {"R2", &R2}, {"P1", &P1},
                                     {"P2", &P2}, {"Q", &Q}}) {
    storage[name] >> *matrix;
    INFO(name);
    REQUIRE(!matrix->empty());
  }
  std::vector<int> size;
  storage["image_size"] >> size;
  CHECK(size == std::vector<int>{640, 480});
  CHECK(D1.total() == 5);  // the default model k5
  // The samples are 640x480: principal points near the centre, square pixels.
  for (const cv::Mat& K : {K1, K2}) {
    CHECK(std::abs(K.at<double>(0, 2) - 320) < 40);
    CHECK(std::abs(K.at<double>(1, 2) - 240) < 40);
    CHECK(K.at<double>(1, 1) == Approx(K.at<double>(0, 0)).epsilon(0.02));
  }
  // The written matrices agree with each other: E = [T]x R, F = K2^-T E K1^-1 (up to scale).
  const cv::Mat Tx = (cv::Mat_<double>(3, 3) << 0, -T.at<double>(2), T.at<double>(1), T.at<double>(2), 0,
                      -T.at<double>(0), -T.at<double>(1), T.at<double>(0), 0);
  const cv::Mat E_expected = Tx * R;
  CHECK(cv::norm(E / cv::norm(E) - E_expected / cv::norm(E_expected)) < 1e-6);
  const cv::Mat F_expected = K2.inv().t() * E * K1.inv();
  CHECK(cv::norm(F / cv::norm(F) - F_expected / cv::norm(F_expected)) < 1e-6);
  // Rectified: P2's x offset is -f times the baseline (OpenCV's convention).
  CHECK(-P2.at<double>(0, 3) == Approx(P2.at<double>(0, 0) * cv::norm(T)).epsilon(1e-6));

  std::stringstream text;
  text << std::ifstream(json).rdbuf();
  CHECK(JsonNumber(text.str(), "views_used") == 13);  // left10/right10 are not shipped
  CHECK(JsonNumber(text.str(), "rms_stereo_px") <= 0.46);
  CHECK(JsonNumber(text.str(), "epipolar_error_px") <= 0.30);
  CHECK(JsonNumber(text.str(), "rms_left_px") > 0);
  CHECK(JsonNumber(text.str(), "baseline_m") == Approx(cv::norm(T)).epsilon(1e-6));
}

TEST_CASE("calibrate command: a malformed board and missing images are errors", "[tools][unit]") {
  const testing::TemporaryFolder folder("dg_calibrate_command_never");
  const std::string out = folder.File("never.yaml");
  CHECK_THROWS_WITH(RunCommand({"calibrate", "--left", kSamples + "left??.jpg", "--right", kSamples + "right??.jpg",
                                "--board", "9by6", "--square", "0.025", "--out", out}),
                    Catch::Contains("--board must be COLSxROWS"));
  CHECK_THROWS_AS(RunCommand({"calibrate", "--square", "0.025", "--out", out}), Error);
  CHECK_THROWS_AS(RunCommand({"calibrate", "--left", "a.png", "--right", "b.png", "--out", out}), CLI::ParseError);
  CHECK(!fs::exists(out));
}

}  // namespace
}  // namespace dg::tools
