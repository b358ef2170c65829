#include "pipeline/scene_geometry.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <Eigen/Core>

#include "io/metaimage.h"
#include "sim/error.h"
#include "stages/register/fiducial_motion.h"
#include "stages/track/triangulator.h"

namespace dg::pipeline {
namespace {

// Soft-tissue organs and phantoms span centimetres to a few decimetres.
constexpr double kLargestOrgan_m = 0.5, kSmallestOrgan_m = 1e-3;
// Fiducials are glued to the organ's surface: within a few millimetres of its box.
constexpr double kFiducialMargin_m = 0.01;
// An overlay mesh against the simulated mesh: a structure inside the organ
// spans more than a hundredth of it, the surface or a neighbour less than ten
// times; a unit slip is a factor of 1000 either way.
constexpr double kSmallestOverlayToMesh = 1e-2, kLargestOverlayToMesh = 10;
// The mesh is segmented from the CT: its box lies inside the CT's grid, and a
// CT spans at most a body's width more than the organ.
constexpr double kGridMargin_m = 0.01, kLargestGridToMesh = 50;

std::string Metres(double value_m) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g m", value_m);
  return text;
}

// A unit slip is a factor of 1000 (millimetres for metres); a range merely
// set too tight is off by less than this.
constexpr double kUnitSlip = 100;

// A depth range around the tissue's, for the fix: half its nearest depth to
// twice its farthest, in two significant digits.
std::string SuggestedRange(double nearest_m, double farthest_m) {
  char text[64];
  std::snprintf(text, sizeof text, "--near %.2g --far %.2g", 0.5 * nearest_m, 2 * farthest_m);
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

void CheckOverlayMeshSize(const io::Scene& scene, const std::string& file, const io::SurfaceMesh& overlay_mesh,
                          const sim::TetMesh& mesh) {
  const auto span_m = [](const Eigen::Matrix3Xd& points_m) {
    return points_m.cols() == 0 ? 0.0 : (points_m.rowwise().maxCoeff() - points_m.rowwise().minCoeff()).maxCoeff();
  };
  const double overlay_m = span_m(overlay_mesh.vertices_m), mesh_m = span_m(mesh.X_m);
  const double stated = scene.overlays ? scene.overlays->metres_per_unit : 1.0;
  const std::string sizes = "the overlay mesh spans " + Metres(overlay_m) + ", the simulated mesh " + Metres(mesh_m);
  const std::string where = file + " (through " + scene.path + ")";
  if (overlay_m > kLargestOverlayToMesh * mesh_m) {
    throw Error(sizes + ": the overlay mesh is probably in millimetres" +
                    (stated == 1.0 ? " (overlays: has no units, so metres are read)" : ""),
                where, "state the overlay meshes' unit in the scene: overlays: {units: mm}");
  }
  if (overlay_m < kSmallestOverlayToMesh * mesh_m) {
    throw Error(sizes + ": the overlay mesh's unit is probably stated wrong (a file in metres read as millimetres?)",
                where, "state the overlay meshes' unit in the scene: overlays: {units: m} (or mm, cm)");
  }
}

std::vector<double> DepthsInCamera(const Eigen::Matrix4d& T_C_S, const Eigen::Matrix3Xd& points_S_m) {
  const Eigen::RowVectorXd z = T_C_S.block<1, 3>(2, 0) * points_S_m;
  std::vector<double> depths_m(z.data(), z.data() + z.size());
  for (double& depth : depths_m) depth += T_C_S(2, 3);
  return depths_m;
}

void CheckWorkingDistance(const std::vector<double>& depths_m, const std::string& what,
                          const io::StereoCalibration& rectified, double near_m, double far_m, const std::string& where,
                          const std::string& unit_fix) {
  if (depths_m.empty()) return;
  const auto [lowest, highest] = std::minmax_element(depths_m.begin(), depths_m.end());
  const double nearest_m = *lowest, farthest_m = *highest;
  const std::string tissue = what + " lie at " + Metres(nearest_m) + " to " + Metres(farthest_m) + " from the camera";
  if (!(nearest_m > 0) || !std::isfinite(farthest_m)) {
    throw Error(what + " lie at depths " + Metres(nearest_m) + " to " + Metres(farthest_m) +
                    ": behind the camera, or not finite",
                where, unit_fix);
  }
  const std::string range = "the stereo matcher's depth range (--near " + Metres(near_m) + ", --far " +
                            Metres(far_m) + ")";
  if (nearest_m < near_m || farthest_m > far_m) {
    if (near_m > kUnitSlip * farthest_m) {
      throw Error(tissue + ", far nearer than " + range + ": --near and --far are probably in millimetres", where,
                  "give them in metres, e.g. " + SuggestedRange(nearest_m, farthest_m));
    }
    if (nearest_m > kUnitSlip * far_m) {
      throw Error(tissue + ", far beyond " + range + ": these depths are probably in millimetres", where, unit_fix);
    }
    throw Error(tissue + ", outside " + range + ": stereo matching would not find the tissue there", where,
                "widen the range around the tissue, e.g. " + SuggestedRange(nearest_m, farthest_m));
  }
  // The disparity f B / z: under a pixel, stereo measures no depth; wider
  // than the image, the two eyes do not both see the tissue.
  const stages::Triangulator geometry(rectified);
  const double width_px = rectified.left.width, widest_px = geometry.DisparityAtDepth(nearest_m),
               narrowest_px = geometry.DisparityAtDepth(farthest_m);
  char disparity[160];
  std::snprintf(disparity, sizeof disparity, "the calibration's baseline %.4g m gives a disparity of %.3g to %.3g px",
                rectified.T_m.norm(), narrowest_px, widest_px);
  if (widest_px >= width_px || narrowest_px < 1) {
    throw Error(tissue + ", where " + disparity + (narrowest_px < 1 ? ", under one pixel" : ", wider than the image") +
                    ": the baseline is implausible for that distance (a stereo endoscope's is a few millimetres, "
                    "at a few centimetres), so one of the two is probably in another unit",
                where, "check the calibration's T is in metres, and " + unit_fix);
  }
}

}  // namespace dg::pipeline
