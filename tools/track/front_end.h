#pragma once

#include <string>

#include "io/calibration_source.h"
#include "io/scene.h"
#include "pipeline/scene_graph.h"

namespace dg::tools {

// What the vision front end reads: a scene file, or left and right inputs
// (videos, image sequences or a single image pair) with a calibration.
struct FrontEndInput {
  std::string scene;             // scene.yaml: its video (any layout) and calibration
  std::string left, right;       // instead of a scene: two videos, two image patterns or one image pair
  // Overrides the scene's: one file, or the files of a stereo pair
  // (docs/formats/calibration.md); T in metres unless calibration_units says.
  io::CalibrationSource calibration;
  std::string calibration_units;  // T's unit (m, cm, mm, um, or metres per unit), for --calib or the scene's
  double fps = 0;                // overrides the scene's; needed for image sequences, which carry no frame rate
  // The depths (along the left camera's axis) that stereo matching searches:
  // converted with the calibration to the disparity range, so a narrower
  // range is faster and rejects more false matches. 0 < near_m < far_m.
  double near_m = pipeline::FrontEndSettings{}.near_m, far_m = pipeline::FrontEndSettings{}.far_m;
  int target_features = pipeline::FrontEndSettings{}.target_features;  // tracked features wanted, as run's --features
};

// The input as a scene cut after tracking. pipeline::BuildSceneGraph makes of
// it the front end every run starts with (capture, rectification unless the
// recording is rectified, tracking), so `track` and `bench vision` run the
// product's own front end: the same capture, layouts, checks and messages.
// @throws dg::Error for no input or calibration, or image sequences without a frame rate.
io::Scene FrontEndScene(const FrontEndInput& input);

pipeline::FrontEndSettings FrontEndSettingsOf(const FrontEndInput& input);

}  // namespace dg::tools
