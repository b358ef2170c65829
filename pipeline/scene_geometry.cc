#include "pipeline/scene_geometry.h"

#include <cstdio>
#include <string>

#include <Eigen/Core>

#include "sim/error.h"
#include "stages/register/fiducial_motion.h"

namespace dg::pipeline {
namespace {

// Soft-tissue organs and phantoms span centimetres to a few decimetres.
constexpr double kLargestOrgan_m = 0.5, kSmallestOrgan_m = 1e-3;
// Fiducials are glued to the organ's surface: within a few millimetres of its box.
constexpr double kFiducialMargin_m = 0.01;

std::string Metres(double value_m) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g m", value_m);
  return text;
}

}  // namespace

void CheckSceneGeometry(const io::Scene& scene, const sim::TetMesh& mesh) {
  const Eigen::Vector3d low = mesh.X_m.rowwise().minCoeff(), high = mesh.X_m.rowwise().maxCoeff();
  const double extent_m = (high - low).maxCoeff();
  if (extent_m > kLargestOrgan_m) {
    throw Error("the mesh spans " + Metres(extent_m) + ", not an organ's size: its coordinates are probably in "
                    "millimetres",
                scene.mesh.file + " (through " + scene.path + ")", "state the mesh's unit in the scene: mesh: {units: mm}");
  }
  if (extent_m < kSmallestOrgan_m) {
    throw Error("the mesh spans " + Metres(extent_m) + ", not an organ's size: its unit is probably stated wrong",
                scene.mesh.file + " (through " + scene.path + ")", "state the mesh's unit in the scene (mesh: {units: m}, mm or cm)");
  }
  if (!scene.preoperative) return;
  const stages::FiducialMotion fiducials = stages::ReadFiducialMotion(scene.preoperative->motion);
  if (fiducials.num_phases() == 0) return;
  const Eigen::Matrix3Xd& first = fiducials.positions_S_m.front();
  for (Eigen::Index f = 0; f < first.cols(); ++f) {
    const Eigen::Vector3d outside =
        (low - first.col(f)).cwiseMax(first.col(f) - high).cwiseMax(Eigen::Vector3d::Zero());
    if (outside.norm() <= kFiducialMargin_m) continue;
    throw Error("the scan's fiducial " + std::to_string(f + 1) + " lies " + Metres(outside.norm()) +
                    " outside the mesh (which spans " + Metres(extent_m) +
                    "): the scan and the mesh are not in one frame or one unit",
                scene.preoperative->motion + " (through " + scene.path + ")",
                "give the mesh and scan.h5 of one preoperative CT, both in metres (mesh: {units: ...} for the mesh)");
  }
}

}  // namespace dg::pipeline
