#pragma once

#include <string>
#include <vector>

#include "stages/overlay/overlay_error.h"

namespace dg::tools {

struct OverlaySnapshotOptions {
  std::string scene;    // a phantom's scene.yaml
  std::string out_dir;  // created
  int frame = -1;       // -1: the frame of peak contraction
  int supersample = 2;
  double slice_spacing_m = 0.5e-3;
};

struct OverlaySnapshotSummary {
  int frame = 0;
  std::vector<std::string> files;
  stages::overlay::ErrorSummary surface_px, surface_mm, internal_mm;
  std::string embedding;  // the surface overlay's embedding, described
  std::string Describe() const;
};

// On a phantom scene, moves the mesh's nodes by the phantom's true motion at
// one frame and writes one PNG per overlay mode (embedded meshes, volume and
// surface texture, each alpha-blended and with Inverse Realism where it
// applies, their composite, the saliency map and the plain frame) for a
// person to look at, and measures that frame's overlay errors.
// @throws dg::Error for a scene that is not a phantom's or an unwritable folder.
OverlaySnapshotSummary WriteOverlaySnapshots(const OverlaySnapshotOptions& options);

}  // namespace dg::tools
