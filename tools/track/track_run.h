#pragma once

#include <cstdint>
#include <string>

#include "tools/track/front_end.h"

namespace dg::tools {

struct TrackRunOptions {
  FrontEndInput input;
  std::string out_h5;    // required; its folder is created
  std::string out_csv;   // optional
  std::int64_t first_frame = 0, end_frame = -1;  // [first, end); end < 0: to the last frame
  bool progress = false;                          // on stderr
};

struct TrackRunSummary {
  int frames = 0;
  std::size_t rows = 0;    // tracked points summed over frames
  std::int64_t tracks = 0; // distinct track ids
  double ms_per_frame = 0; // the graph's wall time per frame
};

// `dynaguide track`: the run's front-end graph alone over a recording, tracks
// saved as a TrackTable as the frames come.
// @throws dg::Error for bad input (see FrontEndScene and BuildSceneGraph), an
//   empty frame range, or a frame that fails; pipeline::Interrupted for a stop
//   a signal asked for. Either way the table holds the frames before, marked incomplete.
TrackRunSummary RunTrack(const TrackRunOptions& options);

}  // namespace dg::tools
