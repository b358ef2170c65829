// The annotated video offline: every frame added is encoded, even through a
// queue of two, and the file holds them all; adding after Close() is refused.
#include "pipeline/annotated_video.h"

#include <catch2/catch.hpp>
#include <opencv2/videoio.hpp>

#include "tests/support/temporary_folder.h"

namespace dg::pipeline {
namespace {

TEST_CASE("annotated video: offline, every frame reaches the file", "[pipeline][unit]") {
  const testing::TemporaryFolder folder("dg_annotated");
  const std::string path = folder.File("annotated.avi");
  constexpr int kFrames = 25;
  {
    AnnotatedVideo video(path, 30, {64, 48}, VideoLayout::kLeft, Policy::kOffline, {}, 2);
    video.Start();
    FramePacket packet;
    for (int j = 0; j < kFrames; ++j) {
      packet.index = j;
      packet.raw.left = cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(4 * j));
      video.Add(packet);
    }
    video.Close();
    video.Close();  // idempotent
    REQUIRE(video.written() == kFrames);
    REQUIRE(video.dropped() == 0);
    REQUIRE_THROWS_WITH(video.Add(packet), Catch::Contains("closed while frames were still coming"));
  }
  cv::VideoCapture reader(path);
  REQUIRE(reader.isOpened());
  int frames = 0;
  for (cv::Mat frame; reader.read(frame);) ++frames;
  REQUIRE(frames == kFrames);
}

}  // namespace
}  // namespace dg::pipeline
