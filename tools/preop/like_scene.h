#pragma once

#include <string>

namespace dg::tools::preop {

// What `dynaguide preop` made, for the scene it writes.
struct PreopSceneParts {
  int phases = 0;
  double period_s = 0;     // 0: the like scene's
  int internal_meshes = 0;  // assets/internal_K.obj
  bool texture = false;     // assets/surface.obj carries uvs for assets/annotation.*
  int fiducials = 0;        // in scan.h5; 0: the scene needs them before `dynaguide run`
};

// Writes out_dir/scene.yaml: the like scene's video, calibration, truth,
// material, registration and simulation settings (its files by absolute
// path), and everything preoperative from out_dir: mesh.msh (groups base and
// surface), scan.h5, ct/phase_NN.mhd and the overlay assets. The like scene's
// internal points (measurement points in the scan frame, not anatomy) are
// kept. The like scene is read and checked first.
// @throws dg::Error for a like scene that does not read, or a failed write.
void WriteSceneLike(const std::string& like_scene, const std::string& out_dir, const PreopSceneParts& parts);

}  // namespace dg::tools::preop
