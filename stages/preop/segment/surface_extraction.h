#pragma once

#include <string>

#include <Eigen/Core>

#include "io/surface_mesh.h"
#include "sim/error.h"
#include "stages/preop/segment/segmentation.h"

namespace dg::stages::preop {

// A closed triangulated surface from a voxel mask (the second step of the
// paper's section 2.4): VTK's flying edges at the mask's half level
// (optionally after a Gaussian blur of the mask), the largest connected
// region (single-voxel noise and cavities dropped), windowed sinc smoothing
// (Taubin's low-pass filter: it removes the staircase without shrinking the
// surface as Laplacian smoothing does), then decimation down to a triangle
// count fit for real-time simulation and drawing. The mask is padded with
// empty voxels on every side, so a mask that touches the grid's edge still
// gives a closed surface.
//
// The result must be what Gmsh can mesh: a closed, oriented 2-manifold of
// one component and genus 0 (CheckSurfaceTopology). Quadric edge collapse
// can pinch a thin wall into a non-manifold edge and a mask may hold a
// tunnel, so each result is checked, and a failed one is made again with
// topology-preserving decimation (vtkDecimatePro), then with the mask
// blurred by kExtraBlursVoxels more (a blur closes thin tunnels and cuts
// one-voxel bridges).
struct SurfaceOptions {
  // Standard deviation of a Gaussian blur of the mask before flying edges, in
  // voxels; 0: none. A light blur (1 voxel) rounds a label map's single-voxel
  // noise and thin bridges away.
  double image_smoothing_sigma_voxels = 0;
  int smoothing_iterations = 20;
  // Windowed sinc pass band in (0, 2]: lower smooths more. 0.1 removes the
  // one-voxel staircase and keeps features of a few voxels.
  double smoothing_pass_band = 0.1;
  // Decimation stops at this many triangles (kept as is when flying edges give
  // fewer).
  int target_triangles = 5000;
  // Whether the surface must bound one solid ball, as the mesher needs. An
  // overlay's surface (vessels, chambers) is drawn, not meshed: without this
  // the first surface made is kept whatever its topology.
  bool require_solid_ball = true;

  std::string Validate() const;  // empty when valid, else what is wrong
};

// The extra blurs, in voxels, added to image_smoothing_sigma_voxels for the
// later attempts when a surface fails CheckSurfaceTopology.
inline constexpr double kExtraBlursVoxels[] = {1.0, 2.0, 3.0, 4.0};

// What ExtractSurface throws when no attempt gives the boundary of one solid
// ball (a tunnel the blurs do not close, pieces): the mask, not the surface,
// must change.
class NotASolidBall : public Error {
 public:
  using Error::Error;
};

struct SurfaceReport {
  int extracted_triangles = 0;  // from flying edges, before decimation
  int triangles = 0;
  double enclosed_volume_m3 = 0;
  int attempts = 0;                     // surfaces made until one passed the topology check
  double image_smoothing_sigma_voxels = 0;  // the blur of the surface kept
  bool topology_preserving_decimation = false;  // vtkDecimatePro made the surface kept
};

// The topology of a triangle surface, as far as a mesher needs it.
struct SurfaceTopology {
  int vertices = 0;  // used by some triangle
  int edges = 0;
  int triangles = 0;
  int boundary_edges = 0;         // in one triangle only: a hole
  int non_manifold_edges = 0;     // in three triangles or more
  int misoriented_edges = 0;      // two triangles run along it the same way
  int non_manifold_vertices = 0;  // its triangles form several fans (two cones touching)
  int components = 0;
  int euler_characteristic = 0;   // vertices - edges + triangles: 2 for a sphere, 2 - 2 g with g tunnels
  Eigen::Vector3d first_fault_m = Eigen::Vector3d::Zero();  // a faulty edge's midpoint, or vertex, in S
  bool has_fault_location = false;

  // Closed, oriented, one component of genus 0: the boundary of a solid ball.
  bool IsClosedManifoldSphere() const;
  // What is wrong (or "closed manifold, genus 0"), with counts and the fault's position in mm.
  std::string Describe() const;
};

SurfaceTopology CheckSurfaceTopology(const io::SurfaceMesh& surface);

// The surface of `mask` in the scan frame S, metres: each point mapped from
// voxel indices through the mask's origin, spacing and direction (VTK 9.1's
// image data has no direction). Triangles are counter-clockwise seen from
// outside whatever the direction's handedness. No normals, no uvs. The
// surface passes CheckSurfaceTopology.
// @throws dg::Error for invalid options or an empty mask, and NotASolidBall
//   for a mask whose every attempt fails the topology check (saying what is
//   wrong, where, and what to change).
io::SurfaceMesh ExtractSurface(const VoxelMask& mask, const SurfaceOptions& options, SurfaceReport* report = nullptr);

// Six times the signed volume enclosed by a closed triangle surface (positive
// when its triangles are counter-clockwise seen from outside).
double SixEnclosedVolume(const io::SurfaceMesh& surface);

}  // namespace dg::stages::preop
