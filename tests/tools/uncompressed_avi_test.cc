// The phantom's uncompressed AVI read back by FFmpeg through OpenCV, and by
// the capture stage: every byte as written, the frame count and rate as stated.
#include <cstdint>
#include <fstream>

#include <catch2/catch.hpp>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "sim/error.h"
#include "stages/capture.h"
#include "tests/support/temporary_folder.h"
#include "tools/phantom/uncompressed_avi.h"

namespace dg::tools::phantom {
namespace {

std::vector<cv::Mat> RandomFrames(int count, cv::Size size, std::uint64_t seed = 7) {
  cv::RNG rng(seed);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < count; ++i) {
    frames.emplace_back(size, CV_8UC3);
    rng.fill(frames.back(), cv::RNG::UNIFORM, 0, 256);
  }
  return frames;
}

// `frames` written to `path`; returns the path.
std::string Written(const std::string& path, const std::vector<cv::Mat>& frames, double fps) {
  UncompressedAviWriter writer(path, frames[0].size(), fps);
  for (const cv::Mat& frame : frames) writer.Write(frame);
  writer.Close();
  return path;
}

TEST_CASE("uncompressed AVI: FFmpeg reads back every byte, the count and the rate", "[unit]") {
  const testing::TemporaryFolder folder("dg_uncompressed_avi_test");
  // 161 px rows (483 bytes) need padding to 4 bytes; 29.97 fps is a fractional rate.
  for (const auto& [size, fps] : {std::pair{cv::Size(160, 120), 30.0}, std::pair{cv::Size(161, 75), 29.97}}) {
    const std::vector<cv::Mat> frames = RandomFrames(7, size);
    const std::string path = Written(folder.File("test.avi"), frames, fps);
    cv::VideoCapture capture(path, cv::CAP_FFMPEG);
    REQUIRE(capture.isOpened());
    CHECK(capture.get(cv::CAP_PROP_FRAME_COUNT) == 7);
    CHECK(capture.get(cv::CAP_PROP_FPS) == Approx(fps).epsilon(1e-4));
    cv::Mat read;
    for (const cv::Mat& frame : frames) {
      REQUIRE(capture.read(read));
      REQUIRE(read.size() == size);
      CHECK(cv::norm(read, frame, cv::NORM_INF) == 0);
    }
    CHECK_FALSE(capture.read(read));
  }
}

TEST_CASE("uncompressed AVI: the capture stage reads a stereo pair with container times", "[unit]") {
  const testing::TemporaryFolder folder("dg_uncompressed_stereo");
  const std::vector<cv::Mat> left = RandomFrames(4, {64, 48}), right = RandomFrames(4, {64, 48}, 8);
  stages::CaptureStage::Options options;
  options.left_path = Written(folder.File("left.avi"), left, 25);
  options.right_path = Written(folder.File("right.avi"), right, 25);
  stages::CaptureStage capture(options);
  REQUIRE(capture.frame_count() == 4);
  for (int i = 0; i < 4; ++i) {
    const std::optional<stages::StereoFrame> frame = capture.Next();
    REQUIRE(frame);
    CHECK(frame->t_s == Approx(i / 25.0).margin(1e-6));
    CHECK(cv::norm(frame->left, left[i], cv::NORM_INF) == 0);
    CHECK(cv::norm(frame->right, right[i], cv::NORM_INF) == 0);
  }
  CHECK_FALSE(capture.Next());
}

TEST_CASE("uncompressed AVI: a frame of another size is refused, naming the frame", "[unit]") {
  const testing::TemporaryFolder folder("dg_uncompressed_bad");
  const std::string path = folder.File("bad.avi");
  UncompressedAviWriter writer(path, {32, 24}, 30);
  writer.Write(cv::Mat(24, 32, CV_8UC3, cv::Scalar::all(9)));
  CHECK_THROWS_WITH(writer.Write(cv::Mat(24, 30, CV_8UC3)), Catch::Contains("frame 1"));
  CHECK_THROWS_AS(UncompressedAviWriter(path, {0, 24}, 30), Error);
}

}  // namespace
}  // namespace dg::tools::phantom
