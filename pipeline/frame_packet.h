#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "stages/constraints/constraint_mapper.h"
#include "stages/overlay/overlay_layer.h"
#include "stages/rectify.h"
#include "stages/register/phase_estimate.h"
#include "stages/stereo_frame.h"
#include "stages/track/feature_tracker.h"

namespace dg::stages {
struct RegistrationResult;
}

namespace dg::io {
struct Registration;
}
namespace dg::stages {
struct FemFrameOutput;
}

namespace dg::pipeline {

// When one stage worked on one frame: a row of the run log's /timings.
// Times are nanoseconds since the run started (steady clock); thread is TBB's
// index of the worker in the run's arena.
struct StageTiming {
  std::int64_t frame = 0;
  std::int32_t stage = 0;  // index into the graph's stage names
  std::int32_t thread = 0;
  std::int64_t start_ns = 0, end_ns = 0;
};

// One frame in flight: the value every stage reads its input from and writes
// its output into. A run owns a fixed pool of packets,
// and a packet is a token of the graph's in-flight limit: the source fills a
// free one, the sink hands it back. Images are reused from frame to frame, so
// once every buffer has its size the steady state allocates no image memory.
struct FramePacket {
  static constexpr int kMaxStages = 16;

  std::int64_t sequence = 0;  // 0, 1, 2, ... in the order the source filled packets (gap-free)
  std::int64_t index = 0;     // the video frame (gaps where frames were dropped)
  double t_s = 0;             // the frame's time in the recording
  std::int64_t captured_ns = 0;  // when the source started on it (run clock; in real time, the frame's arrival), for latency
  int dropped_before = 0;        // frames the realtime policy dropped just before this one

  stages::StereoFrame raw;          // as captured, BGR
  cv::Mat left_grey, right_grey;    // the tracker's input before rectification
  stages::RectifiedPair rectified;  // grey, rectified (or the grey input when it comes rectified)
  stages::TrackFrame tracks;
  stages::TrackTimings track_timings;  // where the tracker spent its time on this frame
  // The scan's registration to the video: from the frame the registration
  // stage solved it on (or from the first frame, when the scene gives it);
  // null before. Shared, never written after it is set.
  std::shared_ptr<const io::Registration> registration;
  // The solve behind `registration` when the run registered (its fiducial
  // assignment and search, for the log); null when the scene gave it.
  std::shared_ptr<const stages::RegistrationResult> registration_solve;
  // The heart's phase at this frame as the video shows it (docs/phase.md):
  // valid from the registration on when the register stage estimates it live.
  stages::PhaseEstimate phase;
  stages::NodeTargets targets;  // constraint mapping's, for the FEM stage
  // The FEM stage's node positions and record; null before the simulation
  // starts (at the first registered frame). Shared with the sinks that keep
  // it after the packet is reused.
  std::shared_ptr<const stages::FemFrameOutput> simulation;
  // Per overlay, in drawing order: the layer drawn from this frame's own
  // simulation through the left (and, in a stereo run, the right) eye; empty
  // layers before the simulation starts. The pixels belong to the overlay's
  // pool, which reuses them once the packet lets go (ResetFor).
  std::vector<stages::overlay::OverlayLayer> layers, layers_right;
  // Per overlay: when its draw (both eyes) started and ended, steady clock.
  std::vector<std::int64_t> draw_start_steady_ns, draw_end_steady_ns;
  cv::Mat composite;  // the video frame with the overlays' layers (BGR); empty without overlays
  cv::Mat composite_right;  // the same over the right frame, drawn through the right eye; only in a stereo run
  std::vector<std::int64_t> layer_age_frames;  // per overlay: frames since its layer's geometry; -1 none

  std::array<StageTiming, kMaxStages> timings;
  int timing_count = 0;

  void ResetFor(std::int64_t next_sequence) {
    sequence = next_sequence;
    dropped_before = 0;
    timing_count = 0;
    registration.reset();
    registration_solve.reset();
    phase = {};
    simulation.reset();
    // Hands the layers' pixels back to their pools; the vectors keep their size.
    for (auto& layer : layers) layer = {};
    for (auto& layer : layers_right) layer = {};
  }
};

}  // namespace dg::pipeline
