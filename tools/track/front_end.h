#pragma once

#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "stages/capture.h"
#include "stages/rectify.h"
#include "stages/track/feature_tracker.h"

namespace dg::tools {

// What the vision front end reads: a scene file, or left and right inputs
// (videos, image sequences or a single image pair) with a calibration.
struct FrontEndInput {
  std::string scene;             // scene.yaml: video.left/right, video.fps and calibration
  std::string left, right;       // instead of a scene
  std::string calibration;       // overrides the scene's
  double fps = 0;                // for images: 0 takes 1 frame per second
  // The depths searched by stereo matching, for the disparity range: an endoscope sees tissue at a few centimetres.
  double near_m = 0.03, far_m = 0.30;
};

// Milliseconds per part of one frame.
struct FrontEndTimings {
  double capture_ms = 0;  // decoding and conversion to grey
  double rectify_ms = 0;
  stages::TrackTimings track;
  double total_ms() const {
    return capture_ms + rectify_ms + track.temporal_ms + track.detect_ms + track.stereo_ms + track.triangulate_ms;
  }
};

struct FrontEndFrame {
  std::int64_t index = 0;
  double t_s = 0;
  stages::TrackFrame tracks;
};

// Capture -> grey -> rectification -> feature tracking, one frame per call:
// the front end run sequentially (for `dynaguide track` and the benchmark).
// Stateful and not thread-safe; the stages inside use TBB within a frame.
class FrontEnd {
 public:
  // @throws dg::Error for a missing or unreadable input or calibration, or
  // inputs and calibration of different image sizes.
  explicit FrontEnd(const FrontEndInput& input);

  // Reads and discards the next `count` frames, without tracking them.
  void Skip(std::int64_t count);

  // The next frame's tracks, or std::nullopt after the last. `timings` is optional.
  std::optional<FrontEndFrame> Next(FrontEndTimings* timings = nullptr);

  int frame_count() const { return capture_->frame_count(); }
  cv::Size size() const { return capture_->size(); }

 private:
  std::unique_ptr<stages::CaptureStage> capture_;
  std::unique_ptr<stages::RectifyStage> rectify_;
  std::unique_ptr<stages::FeatureTracker> tracker_;
};

}  // namespace dg::tools
