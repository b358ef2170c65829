#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/annotated_video.h"
#include "pipeline/overlay_log.h"
#include "pipeline/run_statistics.h"
#include "pipeline/scene_graph.h"
#include "pipeline/stage_graph.h"

namespace dg::pipeline {

struct RunOptions {
  std::string scene;                // the scene file (io/scene.h); required
  std::string out_dir = "out/run";  // run.h5 and annotated.avi go here
  int threads = 0;                  // 0: all cores
  GraphOptions graph;     // policy, frames in flight, frame range
  FrontEndSettings front_end;
  OverlayQuality overlay_quality;  // how finely the overlays are drawn
  bool video = true;     // write the annotated video
  // The annotated video's and the snapshots' layout; side by side also draws
  // and composes the right eye's overlays (a left-only run does not).
  VideoLayout video_layout = VideoLayout::kLeft;
  // Label each frame of the annotated video with its layers' ages (frames
  // since the state each was drawn from).
  bool show_age = false;
  // Frames written as PNG (composite_<frame>.png: the overlaid frame, in video_layout).
  std::vector<std::int64_t> snapshots;
  bool progress = true;  // progress lines on stderr
  // The simulated mesh per frame as mesh_series.xmf + mesh_series.h5
  // (MeshSeriesSink). Unset: written when the frames the run reads
  // times the mesh's nodes are at most kMeshSeriesDefaultNodeFrames.
  std::optional<bool> mesh_series;
};

// The default's bound on frames x nodes: 1e6 node-frames is about 80 MB of
// series (10 doubles per node and frame), e.g. 30 s at 30 fps on a 1100-node
// mesh; the default phantom's run (105 frames, 1745 nodes) is 0.18e6.
inline constexpr std::int64_t kMeshSeriesDefaultNodeFrames = 1'000'000;

struct RunOutcome {
  RunStatistics statistics;
  std::string log_path, video_path;
  std::string registration_path;  // registration.yaml, when the run registered the scan itself
  std::string mesh_series_path;   // mesh_series.xmf, when the run wrote the mesh series
  std::int64_t video_frames_dropped = 0;
  std::int64_t simulated_frames = 0;  // frames the FEM stage advanced to (0 without a simulation)
  std::optional<OverlaySummary> overlays;  // a run with overlays: what they showed
};

// What a run writes into out_dir, as names and one-`*` patterns: a run
// removes what an earlier run left under these names before it writes.
std::vector<std::string> RunOutputNames();

// The graph a run would build, as text (`dynaguide run --print-graph`).
// @throws dg::Error as io::ReadScene, or when options.scene is empty.
std::string DescribeRunGraph(const RunOptions& options);

// `dynaguide run`: streams the scene's recording through its graph, writing
// the HDF5 run log, the annotated video, the mesh series (RunOptions::mesh_series)
// and (when the run registered the scan itself) registration.yaml into out_dir, which it holds for the run
// (io::OutputFolderClaim: a second process writing there is refused).
// @throws dg::Error for a bad scene or options before the run (no scene, a mesh series
// asked for in a scene without simulation), and, after the
// outputs are flushed and marked incomplete, when a stage failed (naming the
// stage and the frame).
// @throws Interrupted, after the same, when a signal stopped the run.
RunOutcome RunScene(const RunOptions& options);

}  // namespace dg::pipeline
