#include "pipeline/scene_geometry.h"

#include <cstdio>
#include <string>

#include <Eigen/Core>

#include "io/metaimage.h"
#include "sim/error.h"
#include "stages/register/fiducial_motion.h"

namespace dg::pipeline {
namespace {

// Soft-tissue organs and phantoms span centimetres to a few decimetres.
constexpr double kLargestOrgan_m = 0.5, kSmallestOrgan_m = 1e-3;
// Fiducials are glued to the organ's surface: within a few millimetres of its box.
constexpr double kFiducialMargin_m = 0.01;
// The mesh is segmented from the CT: its box lies inside the CT's grid, and a
// CT spans at most a body's width more than the organ.
constexpr double kGridMargin_m = 0.01, kLargestGridToMesh = 50;

std::string Metres(double value_m) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g m", value_m);
  return text;
}

// The CT the overlays sample (the first phase's grid): the mesh made from it
// lies inside it, both in metres (MetaImage states millimetres).
void CheckCtGrid(const io::Scene& scene, const Eigen::Vector3d& mesh_low, const Eigen::Vector3d& mesh_high) {
  const std::string& path = scene.preoperative->ct_volumes.front();
  const io::VolumeU8 grid = io::ReadMetaImageGrid(path);
  const Eigen::Vector3d grid_low = grid.origin_m - 0.5 * grid.spacing_m;
  const Eigen::Vector3d grid_high = grid_low + grid.size.cast<double>().cwiseProduct(grid.spacing_m);
  const double grid_extent_m = (grid_high - grid_low).maxCoeff(), mesh_extent_m = (mesh_high - mesh_low).maxCoeff();
  const std::string where = path + " (through " + scene.path + ")";
  if (grid_extent_m < mesh_extent_m - kGridMargin_m || grid_extent_m > kLargestGridToMesh * mesh_extent_m) {
    throw Error("the CT's grid spans " + Metres(grid_extent_m) + " and the mesh " + Metres(mesh_extent_m) +
                    ": one of them is in another unit (a CT's ElementSpacing is in millimetres, about 0.3-2 "
                    "for a CT)",
                where, "write the CT with its spacing in millimetres, or state the mesh's unit (mesh: {units: ...})");
  }
  const Eigen::Vector3d outside =
      (grid_low - mesh_low).cwiseMax(mesh_high - grid_high).cwiseMax(Eigen::Vector3d::Zero());
  if (outside.norm() > kGridMargin_m) {
    throw Error("the mesh reaches " + Metres(outside.norm()) + " outside the CT's grid: the mesh and the CT are "
                    "not in one frame",
                where, "give the mesh segmented from this CT, in the CT's coordinates (its Offset, in millimetres)");
  }
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
  if (!scene.preoperative->ct_volumes.empty()) CheckCtGrid(scene, low, high);
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
