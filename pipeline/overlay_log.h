#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "io/h5_table.h"
#include "io/run_log.h"
#include "pipeline/frame_packet.h"

namespace dg::pipeline {

// What the overlays showed, per frame and overall.
struct OverlaySummary {
  std::int64_t composed_frames = 0;  // frames composed after the simulation started
  // Of those, the frames on which each overlay had a layer (the fewest over the overlays).
  std::int64_t frames_with_layers = 0;
  std::int64_t age_median_frames = -1, age_max_frames = -1;  // over every layer shown; -1 none shown
  std::int64_t draws = 0;  // per overlay (the fewest over the overlays)
  // Per overlay, in drawing order: its name and its draws' median time (ms, both eyes).
  std::vector<std::string> names;
  std::vector<double> draw_ms_median;

  // One line for the run's summary, with the overlay frame rate over wall_s.
  std::string Text(double wall_s) const;
};

// The overlays' record in the run log (a consumer of the run-log sink):
//   /composite        per composed frame: frame, layer_age_frames (one
//                     column per overlay, in drawing order: frames since the
//                     geometry of the layer that was laid over it; -1 none);
//                     attributes overlay_names and quality (how finely
//                     the overlays were drawn at the run's end);
//   /overlay_timings  per draw: frame, overlay (index), start_ns, end_ns on
//                     the run clock (both eyes' draws in a stereo run);
//                     attributes <name>_drawn per overlay.
class OverlayLog {
 public:
  OverlayLog(io::RunLog& log, std::vector<std::string> overlay_names);

  void Consume(const FramePacket& packet);
  // After the run: the draws' timings and counts, and the quality they were
  // drawn at. start_steady_ns: the run clock's zero.
  void Finish(std::int64_t start_steady_ns, const std::string& quality);

  const OverlaySummary& summary() const { return summary_; }

 private:
  struct Draw {
    std::int64_t frame;
    std::int32_t overlay;
    std::int64_t start_steady_ns, end_steady_ns;
  };

  io::RunLog& log_;
  std::vector<std::string> names_;
  io::H5Table& ages_;
  std::vector<Draw> draws_;
  std::vector<std::int64_t> shown_ages_;  // every layer's age on every frame, for the summary
  std::vector<std::int64_t> frames_with_layer_;  // per overlay
  std::vector<std::int64_t> drawn_;  // per overlay
  OverlaySummary summary_;
};

}  // namespace dg::pipeline
