#pragma once

#include <string>

#include "io/surface_mesh.h"
#include "sim/tet_mesh.h"
#include "stages/preop/segment/segmentation.h"

namespace dg::stages::preop {

// The organ's closed surface to a tetrahedral mesh for the simulation (the
// paper's section 2.4), through Gmsh's SDK: the triangles become a discrete
// surface, which Gmsh splits into patches it can parametrise (classifySurfaces,
// createGeometry) and remeshes at a uniform size, so that the element count
// follows the target whatever the surface's own resolution; then 3D Delaunay
// and Gmsh's tetrahedral quality optimisation (Debian's Gmsh 4.8 has no
// Netgen optimiser compiled in).
//
// Every call is deterministic (one thread, fixed seed and algorithms, no user
// gmshrc) and serialised on a process-wide mutex, as in io/gmsh_mesher.cc;
// Gmsh prints nothing, and its failures become dg::Error.
struct TetrahedralisationOptions {
  int target_tets = 8000;
  // Surface patches bend by less than this between neighbouring triangles;
  // sharper edges (the rim where the organ meets the mount) become curves.
  double feature_angle_deg = 40;
  // A boundary node within this distance of the mount mask's voxels touches
  // the mount: it is fixed in the simulation. About a voxel: the mask's own
  // surface lies half a voxel off the true contact plane at worst.
  double base_distance_m = 1e-3;

  std::string Validate() const;  // empty when valid, else what is wrong
};

// How the mesh came out, for logs and the command's report.
struct TetrahedralisationReport {
  int nodes = 0;
  int tets = 0;
  int surface_nodes = 0;
  int base_nodes = 0;
  double element_size_m = 0;     // Gmsh's characteristic length on the pass kept
  int passes = 0;                // meshings run to approach the target count
  double volume_m3 = 0;          // sum of the element volumes
  double min_radius_ratio = 0;   // worst element, io::RadiusRatio
  double mean_radius_ratio = 0;
};

// The element count lands within kTetCountTolerance of the target (the size
// is estimated from volume / target, then corrected from the counts of up to
// kMaxMeshingPasses meshings).
inline constexpr double kTetCountTolerance = 0.15;
inline constexpr int kMaxMeshingPasses = 4;

// Meshes the solid bounded by `surface` (closed, counter-clockwise seen from
// outside, metres, as ExtractSurface gives it). Node sets: "base" (the nodes of
// the boundary triangles whose three nodes are within base_distance_m of the
// mount; empty when the mount mask is), "surface" (the nodes of the other
// boundary triangles: the free surface), "body" (all nodes); element set
// "body". The mesh is in metres, positively oriented, without unused nodes.
// @throws dg::Error for invalid options, a surface that is not closed (an
//   edge not shared by exactly two triangles), or naming the step when Gmsh fails.
sim::TetMesh Tetrahedralise(const io::SurfaceMesh& surface, const VoxelMask& mount,
                            const TetrahedralisationOptions& options, TetrahedralisationReport* report = nullptr);

}  // namespace dg::stages::preop
