#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "io/surface_mesh.h"
#include "tools/phantom/heart_geometry.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools::phantom {

// What is drawn and measured on the phantom's surface, in the reference
// configuration: a fine triangulation of the (u, v) grid, its texture (tissue,
// vessels and the fiducial markers), and the material points the ground truth
// follows. Fiducials and surface points are grid vertices, so they lie exactly
// on the rendered triangles.
struct SurfaceAssets {
  io::SurfaceMesh skin;                 // uvs in OBJ convention (v up); vertices_m in S
  Eigen::Matrix2Xd grid_uv;             // per vertex (u, v) of HeartGeometry (v down from the top pole)
  cv::Mat texture;                      // CV_8UC3 BGR, rows follow v down
  std::vector<int> fiducial_vertices;   // skin vertices carrying a marker and a bead
  std::vector<int> surface_point_vertices;  // the dense set of tracked material points
  Eigen::Matrix3Xd fiducials_S;         // reference positions of the fiducials
  Eigen::Matrix3Xd surface_points_S;
  Eigen::Matrix3Xd internal_points_S;   // internal features: chamber centres and poles
  std::vector<io::SurfaceMesh> chamber_meshes;  // internal structures, high resolution

  // Small, because a disc on a curved surface images with its centroid shifted
  // toward the side facing the camera by about r^2 tan(theta) / (4 R): 0.1 px here.
  static constexpr double kMarkerRadius_m = 0.8e-3;
  static constexpr double kBeadRadius_m = 2.0e-3;
};

// Deterministic for a spec (its seed): fiducials spread over the side facing
// the camera (azimuth camera_azimuth_u +- 0.12, polar v in [0.3, 0.75]).
SurfaceAssets MakeSurfaceAssets(const PhantomSpec& spec, const HeartGeometry& geometry, double camera_azimuth_u);

// The flat mount under the phantom as a textured square on z = 0.
struct MountAssets {
  io::SurfaceMesh plate;  // uvs in OBJ convention
  cv::Mat texture;
};
MountAssets MakeMountAssets(uint64_t seed);

}  // namespace dg::tools::phantom
