#pragma once

#include "io/scene.h"
#include "sim/tet_mesh.h"

namespace dg::pipeline {

// Checks, when a scene is loaded, that its geometry is mutually plausible in
// metres: the mesh is the size of an organ, it lies inside the CT's grid
// (which is not fifty times larger), and the scan's fiducials lie on it. A mesh in millimetres read as metres is a 1000 times larger organ; its
// run would tie no feature, take a critical time step of hundreds of
// milliseconds and report errors of a frozen surface, yet finish.
// @throws dg::Error naming the scene, the sizes found and the likely unit.
void CheckSceneGeometry(const io::Scene& scene, const sim::TetMesh& mesh);

}  // namespace dg::pipeline
