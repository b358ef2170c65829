#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/frame_packet.h"
#include "pipeline/run_statistics.h"

namespace dg::tools {

// A run log read back: what `dynaguide report` summarises and plots.
struct SavedRun {
  std::string path;
  std::vector<std::string> stage_names;
  std::vector<pipeline::StageTiming> timings;
  pipeline::RunStatistics statistics;  // recomputed from the timings, as `dynaguide run` computed them
  std::string policy, error;
  int threads = 0;
  // A run with overlays (/composite): their names in drawing order and, per
  // composed frame, each overlay's layer age (frames between the frame and
  // the state its layer was drawn from; -1 composed without it). Empty
  // without overlays.
  std::vector<std::string> overlay_names;
  std::vector<std::int64_t> composite_frame;
  std::vector<std::int64_t> layer_age_frames;  // [composed frame][overlay]
};

// @throws dg::Error naming the file when it is not a run log (no /timings).
SavedRun ReadSavedRun(const std::string& path);

}  // namespace dg::tools
