// Motion JPEG in AVI, read back by the two readers users have: OpenCV's own
// AVI reader and FFmpeg's (which VLC and most players use). The frames are
// crops of a real photograph (Middlebury's Aloe, from OpenCV's sample data),
// each moved a few pixels, so that no two are alike.
#include "pipeline/mjpeg_avi_writer.h"

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "tests/support/temporary_folder.h"

namespace dg::pipeline {
namespace {

const std::string kAloe = "/usr/share/doc/opencv-doc/examples/data/aloeL.jpg";
constexpr int kFrames = 13;
constexpr int kQuality = 90;
const cv::Size kSize(320, 241);  // an odd height: JPEG's blocks do not tile it

std::vector<cv::Mat> AloeFrames() {
  const cv::Mat aloe = cv::imread(kAloe, cv::IMREAD_COLOR);
  REQUIRE(!aloe.empty());
  std::vector<cv::Mat> frames;
  for (int j = 0; j < kFrames; ++j) frames.push_back(aloe(cv::Rect({300 + 7 * j, 400 + 3 * j}, kSize)).clone());
  return frames;
}

void WriteAll(const std::string& path, double fps, const std::vector<cv::Mat>& frames) {
  MjpegAviWriter writer(path, fps, kSize, kQuality);
  for (const cv::Mat& frame : frames) writer.Write(frame);
  REQUIRE(writer.frames() == kFrames);
  writer.Close();
  writer.Close();  // idempotent
}

TEST_CASE("MJPEG AVI: OpenCV and FFmpeg read every frame back, at the rate written", "[pipeline][unit]") {
  const testing::TemporaryFolder folder("dg_mjpeg_avi");
  const std::string path = folder.File("aloe.avi");
  const std::vector<cv::Mat> frames = AloeFrames();
  WriteAll(path, 30000.0 / 1001.0, frames);

  for (const int backend : {cv::CAP_OPENCV_MJPEG, cv::CAP_FFMPEG}) {
    INFO("backend " << backend);
    cv::VideoCapture reader(path, backend);
    REQUIRE(reader.isOpened());
    CHECK(reader.get(cv::CAP_PROP_FRAME_COUNT) == kFrames);
    CHECK(reader.get(cv::CAP_PROP_FPS) == Approx(30000.0 / 1001.0).epsilon(1e-6));
    int read = 0;
    for (cv::Mat frame; reader.read(frame); ++read) {
      REQUIRE(read < kFrames);
      REQUIRE(frame.size() == kSize);
      // JPEG at quality 90 keeps these crops at 37-40 dB (34 dB is twice the
      // worst one's squared error); the frame written before scores under 19 dB.
      CHECK(cv::PSNR(frame, frames[read]) > 34.0);
      if (read > 0) CHECK(cv::PSNR(frame, frames[read - 1]) < 25.0);
      // OpenCV decodes with the same libjpeg that encoded: the frame is the
      // one a JPEG file of it holds, to the bit.
      if (backend == cv::CAP_OPENCV_MJPEG) {
        std::vector<unsigned char> jpeg;
        cv::imencode(".jpg", frames[read], jpeg, {cv::IMWRITE_JPEG_QUALITY, kQuality});
        CHECK(cv::norm(frame, cv::imdecode(jpeg, cv::IMREAD_COLOR), cv::NORM_INF) == 0);
      }
    }
    CHECK(read == kFrames);
  }
}

TEST_CASE("MJPEG AVI: a whole frame rate is stored exactly", "[pipeline][unit]") {
  const testing::TemporaryFolder folder("dg_mjpeg_avi_rate");
  const std::string path = folder.File("aloe.avi");
  WriteAll(path, 25, AloeFrames());
  cv::VideoCapture reader(path, cv::CAP_FFMPEG);
  REQUIRE(reader.isOpened());
  CHECK(reader.get(cv::CAP_PROP_FPS) == 25.0);
  CHECK(reader.get(cv::CAP_PROP_FRAME_COUNT) == kFrames);
}

TEST_CASE("MJPEG AVI: what cannot be written is refused with the reason", "[pipeline][unit]") {
  const testing::TemporaryFolder folder("dg_mjpeg_avi_errors");
  REQUIRE_THROWS_WITH(MjpegAviWriter(folder.File("missing/aloe.avi"), 30, kSize, kQuality),
                      Catch::Contains("cannot create the video file") && Catch::Contains("missing/aloe.avi"));
  REQUIRE_THROWS_WITH(MjpegAviWriter(folder.File("aloe.avi"), 0, kSize, kQuality),
                      Catch::Contains("positive frame size and rate"));
  MjpegAviWriter writer(folder.File("aloe.avi"), 30, kSize, kQuality);
  REQUIRE_THROWS_WITH(writer.Write(cv::Mat(kSize, CV_8UC1, cv::Scalar(0))),
                      Catch::Contains("give every frame the video's size and type"));
  REQUIRE_THROWS_WITH(writer.Write(cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(0))),
                      Catch::Contains("a frame of 320x240"));
  writer.Close();
  REQUIRE_THROWS_WITH(writer.Write(AloeFrames()[0]), Catch::Contains("closed while frames were still coming"));
}

}  // namespace
}  // namespace dg::pipeline
