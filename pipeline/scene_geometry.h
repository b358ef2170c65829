#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/calibration.h"
#include "io/scene.h"
#include "io/surface_mesh.h"
#include "sim/tet_mesh.h"

namespace dg::pipeline {

// Checks, when a scene is loaded, that its geometry is mutually plausible in
// metres: the mesh is the size of an organ, it lies inside the CT's grid
// (which is not fifty times larger), and the scan's fiducials lie on it. A mesh in millimetres read as metres is a 1000 times larger organ; its
// run would tie no feature, take a critical time step of hundreds of
// milliseconds and report errors of a frozen surface, yet finish.
// @throws dg::Error naming the scene, the sizes found and the likely unit.
void CheckSceneGeometry(const io::Scene& scene, const sim::TetMesh& mesh);

// Checks that an overlay mesh (`file`, read in the scene's overlays.units) is
// drawn at a plausible size on the simulated mesh: the span of its box lies
// between a hundredth (a vessel or a lesion inside the organ) and ten times
// (the surface, a neighbouring structure) the simulated mesh's. A mesh in
// millimetres read as metres is 1000 times larger, one in metres read as
// millimetres 1000 times smaller; either would be drawn off the screen or
// as a dot, with the run finishing.
// @throws dg::Error naming the file, both spans and the `units` fix.
void CheckOverlayMeshSize(const io::Scene& scene, const std::string& file, const io::SurfaceMesh& overlay_mesh,
                          const sim::TetMesh& mesh);

// The tissue's depth from the camera, once known, against what stereo
// matching searches and what the calibration can measure: a depth range in
// millimetres (--near 30) matches nothing, which would otherwise surface as
// a failure of the fiducials' tracking; a pose in millimetres puts the tissue
// 1000 times too far. depths_m: of points the camera sees (the scan's fiducials), in the
// left camera frame; what: those points and where their depth comes from;
// unit_fix: how to correct that source if its depths are in another unit.
// Checks that every depth lies in [near_m, far_m], and that the calibration's
// baseline gives them a disparity of at least a pixel and less than the image.
// @throws dg::Error at `where` naming the depths, the range or the baseline,
// the likely unit mistake and the fix (e.g. "--near 0.03 --far 0.2").
// The depths (z in the left camera frame C) of points in the scan frame S, through T_C_S.
std::vector<double> DepthsInCamera(const Eigen::Matrix4d& T_C_S, const Eigen::Matrix3Xd& points_S_m);

void CheckWorkingDistance(const std::vector<double>& depths_m, const std::string& what,
                          const io::StereoCalibration& rectified, double near_m, double far_m, const std::string& where,
                          const std::string& unit_fix);

}  // namespace dg::pipeline
