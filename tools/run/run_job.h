#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/annotated_video.h"
#include "pipeline/run_statistics.h"
#include "pipeline/scene_graph.h"
#include "pipeline/stage_graph.h"

namespace dg::tools {

struct RunOptions {
  std::string scene;                // empty: the built-in default scene
  std::string out_dir = "out/run";  // run.h5 and annotated.avi go here
  int threads = 0;                  // 0: all cores
  pipeline::GraphOptions graph;     // policy, frames in flight, frame range
  pipeline::FrontEndSettings front_end;
  bool video = true;     // write the annotated video
  // The annotated video's and the snapshots' layout; side by side also draws
  // and composes the right eye's overlays (a left-only run does not).
  pipeline::VideoLayout video_layout = pipeline::VideoLayout::kLeft;
  // Frames written as PNG (composite_<frame>.png: the overlaid frame, in video_layout).
  std::vector<std::int64_t> snapshots;
  bool progress = true;  // progress lines on stderr
};

struct RunOutcome {
  pipeline::RunStatistics statistics;
  std::string log_path, video_path;
  std::string registration_path;  // registration.yaml, when the run registered the scan itself
  std::int64_t video_frames_dropped = 0;
  std::int64_t simulated_frames = 0;  // frames the FEM stage advanced to (0 without a simulation)
};

// What a run writes into out_dir, as names and one-`*` patterns: a run
// removes what an earlier run left under these names before it writes.
std::vector<std::string> RunOutputNames();

// The graph a run would build, as text (`dynaguide run --print-graph`).
std::string DescribeRunGraph(const RunOptions& options);

// `dynaguide run`: streams the scene's recording through its graph, writing
// the HDF5 run log, the annotated video and (when the run registered the
// scan itself) registration.yaml into out_dir, which it holds for the run
// (io::OutputFolderClaim: a second process writing there is refused).
// @throws dg::Error for a bad scene or options before the run, and, after the
// outputs are flushed and marked incomplete, when a stage failed (naming the
// stage and the frame).
// @throws pipeline::Interrupted, after the same, when a signal stopped the run.
RunOutcome RunScene(const RunOptions& options);

}  // namespace dg::tools
