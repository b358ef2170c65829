#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "pipeline/frame_packet.h"

namespace dg::pipeline {

struct StageStatistics {
  std::string name;
  std::int64_t frames = 0;
  double median_ms = 0, p95_ms = 0, mean_ms = 0;
};

// The figures `dynaguide run` prints at the end and `dynaguide report`
// recomputes from a saved log: the same code, so they cannot disagree.
struct RunStatistics {
  std::vector<StageStatistics> stages;
  std::int64_t frames = 0, dropped = 0;
  double wall_s = 0;
  double frames_per_s = 0;
  // Seconds of video covered (frames processed and dropped) per wall second:
  // at least 1 keeps up with the camera.
  double realtime_factor = 0;
  double latency_median_ms = 0, latency_p95_ms = 0;  // capture start to sink end, per frame
  bool complete = false;

  std::string Text() const;  // a table for a terminal
};

// From the /timings rows of a run. Stage 0 is the source and the last stage
// the sink (StageGraph::stage_names()); wall_s 0 takes the span of the rows.
RunStatistics Summarize(std::span<const StageTiming> timings, const std::vector<std::string>& stage_names,
                        std::int64_t dropped, double wall_s, double video_fps, bool complete);

}  // namespace dg::pipeline
