#pragma once

#include <memory>

#include "io/calibration.h"
#include "io/scene.h"
#include "pipeline/stage_graph.h"

namespace dg::pipeline {

// What the scene does not say about the front end.
struct FrontEndSettings {
  // The depths searched by stereo matching, for the disparity range: an
  // endoscope sees tissue at a few centimetres.
  double near_m = 0.03, far_m = 0.30;
};

struct SceneGraph {
  std::unique_ptr<StageGraph> graph;
  // The scene's calibration with the rectification the graph applies (the
  // tracks' rectified coordinates refer to it).
  io::StereoCalibration calibration;
};

// The graph a scene needs and nothing more (DESIGN.md section 4): capture,
// rectification unless the recording is rectified already, and tracking.
// @throws dg::Error for unreadable inputs, a calibration of another image
// size than the video, a rectified recording whose calibration has no
// rectification (P1, P2), or a depth range that OptionsForDepthRange refuses.
SceneGraph BuildSceneGraph(const io::Scene& scene, const GraphOptions& options, const FrontEndSettings& settings = {});

}  // namespace dg::pipeline
