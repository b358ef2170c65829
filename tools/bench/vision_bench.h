#pragma once

#include <string>
#include <vector>

namespace dg::tools {

struct VisionBenchOptions {
  std::vector<int> threads{1, 2};
  int frames = 0;            // frames timed per run; 0: all of the phantom's
  int repeats = 3;           // runs per codec and thread count; the run of median fps is reported
  double duration_s = 2.0;   // of the generated phantom video (30 fps)
  // The phantom's video codecs measured (both lossless): "raw" (uncompressed,
  // as a frame grabber delivers) and "huffyuv" (a compressed recording).
  std::vector<std::string> codecs{"raw", "huffyuv"};
};

// One line of the saved table: the interface users script against.
// Times are per stereo frame, in milliseconds; parts are medians over frames.
// The front end is the run's own graph cut after tracking (offline, two
// frames in flight). ms_median and ms_p95 are of a frame's work: its capture
// (decoding and conversion to grey), rectify and track stages summed. fps is
// the graph's throughput, frames over wall time: with frame j+1 captured
// while frame j is tracked, it exceeds 1000 / ms_median when the stages overlap.
// Over a short recording fps carries the start (the first frame's detection,
// the pipeline filling); 1000 / interval_ms_median is the steady rate, and
// what a loop taking one frame at a time would report as 1000 / ms_median.
struct VisionBenchRecord {
  std::string codec;  // of the video read
  int threads = 0;
  int width = 0, height = 0;
  int frames = 0;
  int features = 0;  // median tracked points per frame
  double ms_median = 0, ms_p95 = 0;
  double fps = 0;    // frames / wall time of the graph, in the run of median fps
  int repeats = 1;
  double fps_min = 0, fps_max = 0;  // over the repeats
  double interval_ms_median = 0;    // between successive frames leaving the tracker
  double capture_ms = 0, rectify_ms = 0, temporal_ms = 0, detect_ms = 0, stereo_ms = 0, triangulate_ms = 0;
  double detect_ms_max = 0;  // the worst frame's: detection runs in few frames, so its median hides it
};

// Capture + rectification + feature tracking on a default-preset phantom
// (generated into a temporary folder per codec and removed afterwards), per
// codec and thread count.
std::vector<VisionBenchRecord> RunVisionBench(const VisionBenchOptions& options, bool progress);

// Writes the records as a JSON list, each with the machine it ran on.
void WriteVisionBenchJson(const std::string& path, const std::vector<VisionBenchRecord>& records);

// A plain-text (Markdown) table of the records, for the terminal and the README.
std::string VisionBenchTable(const std::vector<VisionBenchRecord>& records);

}  // namespace dg::tools
