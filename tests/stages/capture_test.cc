// CaptureStage reads a real video as two files and as one side-by-side file,
// image sequences by printf pattern and glob, and rejects inputs that disagree.
#include <filesystem>
#include <fstream>

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "sim/error.h"
#include "stages/capture.h"
#include "tests/support/temporary_folder.h"

namespace dg::stages {
namespace {

namespace fs = std::filesystem;
using Layout = CaptureStage::Layout;

const std::string kMegamind = "/usr/share/doc/opencv-doc/examples/data/Megamind.avi";

std::vector<cv::Mat> ReadAll(const std::string& path, int max_frames = 1 << 30) {
  cv::VideoCapture capture(path);
  REQUIRE(capture.isOpened());
  std::vector<cv::Mat> frames;
  for (cv::Mat frame; static_cast<int>(frames.size()) < max_frames && capture.read(frame);) {
    frames.push_back(frame.clone());
  }
  return frames;
}

// An MJPG AVI (OpenCV's own encoder, no codec library needed) of the given frames.
void WriteVideo(const std::string& path, const std::vector<cv::Mat>& frames, double fps) {
  cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, frames[0].size());
  REQUIRE(writer.isOpened());
  for (const cv::Mat& frame : frames) writer.write(frame);
}

// Frames of a gradient that moves with the frame; `eye` 1 shifts it, as a
// second camera sees a scene (capture refuses two eyes that are the same).
std::vector<cv::Mat> Gradients(int count, cv::Size size, int eye = 0) {
  std::vector<cv::Mat> frames;
  for (int j = 0; j < count; ++j) {
    cv::Mat frame(size, CV_8UC3);
    frame.forEach<cv::Vec3b>(
        [j, eye](cv::Vec3b& px, const int* rc) { px = cv::Vec3b(rc[0] * 4 + j, rc[1] * 3 + 8 * eye, 128); });
    frames.push_back(frame);
  }
  return frames;
}

double MeanAbsDifference(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_L1) / a.total() / 3; }

std::string ErrorMessage(const CaptureStage::Options& options) {
  try {
    CaptureStage capture(options);
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

// The right eye is the same video mirrored, written as MJPG (OpenCV's own
// encoder): capture refuses two eyes that are the same video.
TEST_CASE("capture: a real video read as left and right files", "[stages][integration]") {
  const std::vector<cv::Mat> truth = ReadAll(kMegamind);
  std::vector<cv::Mat> mirrored(truth.size());
  for (size_t k = 0; k < truth.size(); ++k) cv::flip(truth[k], mirrored[k], 1);
  const testing::TemporaryFolder folder("dg_capture_test_two_files");
  const std::string right = folder.File("right.avi");
  cv::VideoCapture original(kMegamind);
  WriteVideo(right, mirrored, original.get(cv::CAP_PROP_FPS));
  CaptureStage capture({Layout::kTwoFiles, kMegamind, right, 0});
  REQUIRE(capture.frame_count() == static_cast<int>(truth.size()));
  REQUIRE(capture.size() == truth[0].size());
  REQUIRE(capture.truncation().empty());
  int count = 0;
  double last_t_s = -1;
  while (std::optional<StereoFrame> frame = capture.Next()) {
    REQUIRE(frame->index == count);
    REQUIRE(frame->t_s > last_t_s);
    REQUIRE(frame->t_s == Approx(count / capture.fps()).margin(1e-3));
    REQUIRE(cv::norm(frame->left, truth[count], cv::NORM_INF) == 0);
    REQUIRE(MeanAbsDifference(frame->right, mirrored[count]) < 4);  // JPEG's loss only
    last_t_s = frame->t_s;
    ++count;
  }
  REQUIRE(count == static_cast<int>(truth.size()));
}

TEST_CASE("capture: a side-by-side video is split into its halves", "[stages][integration]") {
  const std::vector<cv::Mat> frames = ReadAll(kMegamind, 20);
  std::vector<cv::Mat> side_by_side;
  for (const cv::Mat& frame : frames) {
    cv::Mat flipped, both;
    cv::flip(frame, flipped, 1);
    cv::hconcat(frame, flipped, both);
    side_by_side.push_back(both);
  }
  const testing::TemporaryFolder folder("dg_capture_test_sbs");
  const std::string path = folder.File("sbs.avi");
  WriteVideo(path, side_by_side, 24);
  CaptureStage capture({Layout::kSideBySide, path, "", 0});
  REQUIRE(capture.size() == frames[0].size());
  REQUIRE(capture.fps() == Approx(24));
  int count = 0;
  while (std::optional<StereoFrame> frame = capture.Next()) {
    cv::Mat flipped;
    cv::flip(frames[count], flipped, 1);
    REQUIRE(MeanAbsDifference(frame->left, frames[count]) < 4);  // JPEG's loss only
    REQUIRE(MeanAbsDifference(frame->right, flipped) < 4);
    REQUIRE(frame->t_s == Approx(count / 24.0).margin(1e-3));
    ++count;
  }
  REQUIRE(count == 20);
}

TEST_CASE("capture: image sequences by printf pattern and by glob", "[stages][integration]") {
  const testing::TemporaryFolder folder("dg_capture_test_sequence");
  const fs::path dir = folder.path();
  const std::vector<cv::Mat> left = Gradients(12, {64, 48}), right = Gradients(12, {64, 48}, 1);
  for (int j = 0; j < 12; ++j) {
    char name[64];
    std::snprintf(name, sizeof name, "left_%04d.png", j + 1);  // numbered from 1, as many cameras do
    REQUIRE(cv::imwrite((dir / name).string(), left[j]));
    std::snprintf(name, sizeof name, "right_%04d.png", j + 1);
    REQUIRE(cv::imwrite((dir / name).string(), right[j]));
  }
  for (const auto& [left_pattern, right_pattern] :
       {std::pair{"left_%04d.png", "right_%04d.png"}, std::pair{"left_*.png", "right_*.png"}}) {
    INFO(left_pattern);
    CaptureStage capture({Layout::kImageSequences, (dir / left_pattern).string(), (dir / right_pattern).string(), 25});
    REQUIRE(capture.frame_count() == 12);
    int count = 0;
    while (std::optional<StereoFrame> frame = capture.Next()) {
      REQUIRE(cv::norm(frame->left, left[count], cv::NORM_INF) == 0);
      REQUIRE(cv::norm(frame->right, right[count], cv::NORM_INF) == 0);
      REQUIRE(frame->t_s == Approx(count / 25.0));
      ++count;
    }
    REQUIRE(count == 12);
  }
  fs::remove(dir / "left_0005.png");
  const std::string gap = ErrorMessage({Layout::kImageSequences, (dir / "left_%04d.png").string(),
                                        (dir / "right_%04d.png").string(), 25});
  REQUIRE_THAT(gap, Catch::Contains("left_0005.png is missing"));
}

TEST_CASE("capture: inputs that disagree are rejected or truncated, saying so", "[stages][integration]") {
  const testing::TemporaryFolder folder("dg_capture_test_mismatch");
  const fs::path dir = folder.path();
  const std::string small = (dir / "small.avi").string(), large = (dir / "large.avi").string();
  const std::string short_video = (dir / "short.avi").string(), fast = (dir / "fast.avi").string();
  WriteVideo(small, Gradients(5, {64, 48}), 25);
  WriteVideo(large, Gradients(5, {80, 48}), 25);
  WriteVideo(short_video, Gradients(3, {64, 48}, 1), 25);
  WriteVideo(fast, Gradients(5, {64, 48}), 30);

  const std::string missing = (dir / "missing.avi").string();
  REQUIRE_THAT(ErrorMessage({Layout::kTwoFiles, missing, small, 0}),
               Catch::Contains("no such video file") && Catch::Contains(missing));

  const std::string size = ErrorMessage({Layout::kTwoFiles, small, large, 0});
  REQUIRE_THAT(size, Catch::Contains("frame size") && Catch::Contains(small + " is 64x48") &&
                         Catch::Contains(large + " is 80x48"));

  REQUIRE_THAT(ErrorMessage({Layout::kTwoFiles, small, fast, 0}),
               Catch::Contains("frame rate") && Catch::Contains(fast));

  CaptureStage capture({Layout::kTwoFiles, small, short_video, 0});
  REQUIRE_THAT(capture.truncation(), Catch::Contains(small + " has 5 frames") &&
                                         Catch::Contains(short_video + " has 3") &&
                                         Catch::Contains("first 3"));
  int count = 0;
  while (capture.Next()) ++count;
  REQUIRE(count == 3);

  const std::string not_video = (dir / "not_a_video.avi").string();
  std::ofstream(not_video) << "not a video";
  REQUIRE_THAT(ErrorMessage({Layout::kTwoFiles, not_video, small, 0}),
               Catch::Contains("cannot open the video") && Catch::Contains(not_video));
  REQUIRE_THAT(ErrorMessage({Layout::kImageSequences, small, large, 0}), Catch::Contains("frame rate"));

  // What a scene states about the recording must agree with the file.
  REQUIRE_THAT(ErrorMessage({Layout::kTwoFiles, small, small, 50}),
               Catch::Contains("stated frame rate, 50 fps, contradicts the video's own, 25 fps") &&
                   Catch::Contains("video.fps: 25"));
  REQUIRE_THAT(ErrorMessage({Layout::kTwoFiles, small, small, 25, 4}),
               Catch::Contains("holds 5 frames, not the 4 stated") && Catch::Contains(small));
  REQUIRE(CaptureStage({Layout::kTwoFiles, small, small, 25, 5}).frame_count() == 5);
}

}  // namespace
}  // namespace dg::stages
