#pragma once

#include <memory>
#include <string>

#include "io/calibration.h"
#include "pipeline/packet_stage.h"
#include "stages/capture.h"
#include "stages/rectify.h"
#include "stages/track/feature_tracker.h"

namespace dg::pipeline {

// The front end's stages (capture, rectify, track) as the graph sees them.
// Each adapter owns its stage and names the packet fields it reads and writes.

// capture: packet.raw (BGR as recorded) and packet.left_grey/right_grey; for a
// recording that is already rectified, packet.rectified too (the grey images).
class CaptureSource final : public PacketSource {
 public:
  CaptureSource(const stages::CaptureStage::Options& options, bool rectified_input);
  const std::string& name() const override { return name_; }
  bool Read(FramePacket& packet) override;
  bool Skip() override;
  double fps() const override { return capture_.fps(); }
  int frame_count() const override { return capture_.frame_count(); }
  cv::Size size() const { return capture_.size(); }

 private:
  std::string name_ = "capture";
  stages::CaptureStage capture_;
  stages::StereoFrame skipped_;  // where skipped frames are read, reused
  bool rectified_input_;
};

// rectify: packet.left_grey/right_grey -> packet.rectified. Stateless.
class RectifyAdapter final : public PacketStage {
 public:
  explicit RectifyAdapter(std::shared_ptr<const stages::RectifyStage> rectify) : rectify_(std::move(rectify)) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return false; }
  void Process(FramePacket& packet) override;

 private:
  std::string name_ = "rectify";
  std::shared_ptr<const stages::RectifyStage> rectify_;
};

// track: packet.rectified -> packet.tracks and packet.track_timings. Stateful: frames in order.
class TrackAdapter final : public PacketStage {
 public:
  TrackAdapter(const stages::FeatureTracker::Options& options, const io::StereoCalibration& calibration)
      : tracker_(options, calibration) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  void Process(FramePacket& packet) override;

 private:
  std::string name_ = "track";
  stages::FeatureTracker tracker_;
};

}  // namespace dg::pipeline
