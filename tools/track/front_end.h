#pragma once

#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>
#include <tbb/task_group.h>

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
  // The depths (along the left camera's axis) that stereo matching searches:
  // converted with the calibration to the disparity range, so a narrower
  // range is faster and rejects more false matches. An endoscope sees tissue
  // at a few centimetres. 0 < near_m < far_m; far_m may be infinite.
  double near_m = 0.03, far_m = 0.30;
};

// Milliseconds per part of one frame.
struct FrontEndTimings {
  // Waiting for the frame's decoding and conversion to grey, which ran while
  // the previous frame was tracked: the part of capture that tracking did not hide.
  double capture_ms = 0;
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

// Capture -> grey -> rectification -> feature tracking, one frame per call
// (for `dynaguide track` and the benchmark). As in the pipeline, where capture
// is a node of its own, the next frame is decoded (a TBB task) while this one
// is rectified and tracked. Stateful and not thread-safe; the stages inside
// use TBB within a frame.
class FrontEnd {
 public:
  // @throws dg::Error for a missing or unreadable input or calibration,
  // inputs and calibration of different image sizes, or a bad depth range.
  explicit FrontEnd(const FrontEndInput& input);
  ~FrontEnd();  // waits for a frame still being decoded

  // Reads and discards the next `count` frames, without tracking them.
  void Skip(std::int64_t count);

  // The next frame's tracks, or std::nullopt after the last. `timings` is optional.
  // @throws dg::Error from capture (e.g. a frame of another size).
  std::optional<FrontEndFrame> Next(FrontEndTimings* timings = nullptr);

  int frame_count() const { return capture_->frame_count(); }
  cv::Size size() const { return capture_->size(); }

 private:
  // The next frame, decoded and grey: waits for the one being decoded, if any.
  std::optional<stages::StereoFrame> Captured();
  void StartCapture();

  std::unique_ptr<stages::CaptureStage> capture_;
  std::unique_ptr<stages::RectifyStage> rectify_;
  std::unique_ptr<stages::FeatureTracker> tracker_;
  tbb::task_group decoding_;
  bool decoding_started_ = false;
  std::optional<stages::StereoFrame> decoded_;
};

}  // namespace dg::tools
