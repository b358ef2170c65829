#pragma once

#include <memory>

#include "io/calibration.h"
#include "io/scene.h"
#include "pipeline/overlay_stages.h"
#include "pipeline/simulation_stages.h"
#include "pipeline/stage_graph.h"

namespace dg::pipeline {

// What the scene does not say about the front end.
struct FrontEndSettings {
  // The depths searched by stereo matching, for the disparity range: an
  // endoscope sees tissue at a few centimetres.
  double near_m = 0.03, far_m = 0.30;
  // Tracked features wanted (the detector's target): detection runs when
  // fewer than 90% are alive, so a target the image cannot hold means
  // detecting in every frame.
  int target_features = 500;
};

// What the scene does not say about the overlays.
struct OverlaySettings {
  // Draw and compose the right eye too (packet.composite_right), for a
  // side-by-side stereo video; without it the run draws the left eye alone.
  bool right_eye = false;
  OverlayQuality quality;
};

struct SceneGraph {
  std::unique_ptr<StageGraph> graph;
  // The scene's calibration with the rectification the graph applies (the
  // tracks' rectified coordinates refer to it).
  io::StereoCalibration calibration;
  // The scene's own registration (registration.file), or null when the graph registers.
  std::shared_ptr<const io::Registration> given_registration;
  bool live_phase = false;  // the register stage estimates the heart's phase every frame (packet.phase)
  // What the simulation stages run on; null when the scene has no simulation.
  std::shared_ptr<const SimulationSetup> simulation;
  // The overlays the graph draws, in drawing order (empty without overlays).
  std::vector<std::string> overlay_names;
  // The graph's overlays stage (owned by the graph), for the quality it ended
  // at; null without overlays.
  const OverlaysAdapter* overlays_stage = nullptr;
};

// The graph a scene needs and nothing more: capture,
// rectification unless the recording is rectified already, and tracking;
// with a simulation, constraint mapping and the FEM step, preceded by
// registration unless the scene gives a registration file (a scene may also
// ask for registration alone); with a simulation and overlays, the overlays
// stage after the FEM step and the composite stage (each eye's, with
// overlays.right_eye).
// @throws dg::Error for unreadable inputs, a calibration of another image
// size than the video, a rectified recording whose calibration has no
// rectification (P1, P2), a depth range that OptionsForDepthRange refuses,
// registration without the scan's fiducials or their first-frame pixels, a
// given registration that places the tissue outside the depth range
// (CheckWorkingDistance), or a simulation the scene's mesh or motion cannot run.
SceneGraph BuildSceneGraph(const io::Scene& scene, const GraphOptions& options, const FrontEndSettings& settings = {},
                           const OverlaySettings& overlays = {});

}  // namespace dg::pipeline
