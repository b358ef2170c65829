#include "tools/track/front_end.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <utility>

#include "io/calibration.h"
#include "io/scene.h"
#include "sim/error.h"

namespace dg::tools {
namespace {

bool IsImagePath(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* image : {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm"})
    if (ext == image) return true;
  return false;
}

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

FrontEnd::FrontEnd(const FrontEndInput& input) {
  std::string left = input.left, right = input.right, calibration_path = input.calibration;
  double fps = input.fps;
  if (!input.scene.empty()) {
    const io::Scene scene = io::ReadScene(input.scene);
    left = scene.video.left;
    right = scene.video.right;
    if (calibration_path.empty()) calibration_path = scene.calibration;
    if (fps == 0) fps = scene.video.fps;
  }
  if (left.empty() || right.empty())
    throw Error("no input given", "dynaguide track", "give a scene file, or --left and --right");
  if (calibration_path.empty())
    throw Error("no calibration given", "dynaguide track", "give --calib calib.yaml (made by dynaguide calibrate)");

  stages::CaptureStage::Options capture;
  capture.left_path = left;
  capture.right_path = right;
  if (IsImagePath(left)) {
    capture.layout = stages::CaptureStage::Layout::kImageSequences;
    capture.fps = fps > 0 ? fps : 1;
  }
  capture_ = std::make_unique<stages::CaptureStage>(capture);

  io::StereoCalibration calibration = io::ReadStereoCalibration(calibration_path);
  rectify_ = std::make_unique<stages::RectifyStage>(stages::RectifyStage::Options{}, calibration);
  if (rectify_->camera().size != capture_->size()) {
    throw Error("the video is " + std::to_string(size().width) + "x" + std::to_string(size().height) +
                    " but the calibration is for " + std::to_string(rectify_->camera().size.width) + "x" +
                    std::to_string(rectify_->camera().size.height),
                calibration_path, "use the calibration of the camera and resolution that recorded the video");
  }
  calibration.rectification = rectify_->rectification();

  tracker_ = std::make_unique<stages::FeatureTracker>(
      stages::OptionsForDepthRange(calibration, input.near_m, input.far_m), calibration);
}

FrontEnd::~FrontEnd() {
  try {
    decoding_.wait();
  } catch (...) {  // an error of a frame nobody asked for any more
  }
}

void FrontEnd::StartCapture() {
  decoding_started_ = true;
  decoding_.run([this] {
    decoded_ = capture_->Next();
    if (!decoded_) return;
    // Grey before rectification: the tracker needs grey, and remapping one channel is a third of the work.
    stages::ConvertToGrey(decoded_->left, decoded_->left);
    stages::ConvertToGrey(decoded_->right, decoded_->right);
  });
}

std::optional<stages::StereoFrame> FrontEnd::Captured() {
  if (!decoding_started_) StartCapture();
  decoding_.wait();
  decoding_started_ = false;
  return std::exchange(decoded_, std::nullopt);
}

void FrontEnd::Skip(std::int64_t count) {
  for (std::int64_t i = 0; i < count && Captured(); ++i) {
  }
}

std::optional<FrontEndFrame> FrontEnd::Next(FrontEndTimings* timings) {
  FrontEndTimings spent;
  auto start = std::chrono::steady_clock::now();
  std::optional<stages::StereoFrame> raw = Captured();
  if (!raw) return std::nullopt;
  StartCapture();  // the next frame, while this one is rectified and tracked
  spent.capture_ms = MsSince(start);

  start = std::chrono::steady_clock::now();
  const stages::RectifiedPair pair = rectify_->Process(*raw);
  spent.rectify_ms = MsSince(start);

  FrontEndFrame frame{pair.index, pair.t_s, tracker_->Process(pair.left, pair.right, &spent.track)};
  if (timings) *timings = spent;
  return frame;
}

}  // namespace dg::tools
