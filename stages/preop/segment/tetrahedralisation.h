#pragma once

#include <string>

#include "io/surface_mesh.h"
#include "sim/error.h"
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
// Quality is guaranteed: the explicit solver's stable step shrinks with the
// worst element. Elements under min_radius_ratio with two or three faces on
// the boundary (flat slivers along the surface's sharp curves, whose nodes
// all lie on the surface where no optimiser may move them) are peeled off
// while the boundary stays a closed 2-manifold. If the worst element is still
// under the bound, the solid is meshed again as kRemeshings lists (more
// rounds of Gmsh's optimiser, swaps then node relocation; a size 5% off) in
// turn, and the best mesh is kept; if none reaches the bound Tetrahedralise refuses.
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
  // The worst element's radius ratio (io::RadiusRatio) must reach this.
  double min_radius_ratio = 0.15;
  // What the surface is, for messages ("the organ (label 5)").
  std::string surface_name = "the organ's surface";

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
  double min_radius_ratio = 0;   // worst element, io::RadiusRatio, of the mesh kept
  double mean_radius_ratio = 0;
  double min_radius_ratio_meshed = 0;  // worst element of the first mesh, before any extra optimisation
  int slivers_removed = 0;             // flat elements peeled off the boundary of the mesh kept
  int optimisation_rounds = 0;         // extra rounds of Gmsh's optimiser that made the mesh kept
  double target_scale = 1;             // the target count scaled by this for the mesh kept
};

// The remeshings tried in turn while the worst element is under
// min_radius_ratio: extra rounds of Gmsh's optimiser, and the target count
// scaled (a slightly different size moves every node, and with them the
// slivers that neither peeling nor the optimiser removes).
struct Remeshing {
  int optimisation_rounds;
  double target_scale;
};
inline constexpr Remeshing kRemeshings[] = {{2, 1.0}, {6, 1.0}, {2, 1.05}, {2, 0.95}};

// What Tetrahedralise throws when the surface is valid but Gmsh cannot mesh
// it (it cuts itself: "Wrong topology of boundary mesh") or no mesh reaches
// min_radius_ratio: both come from surface detail finer than the elements,
// which a smoother surface removes (docs/preop.md, "Tetrahedralisation.").
class UnmeshableSurface : public Error {
 public:
  using Error::Error;
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
// @throws dg::Error for invalid options, a surface that is not the boundary
//   of one solid ball (CheckSurfaceTopology: saying what is wrong and where),
//   and UnmeshableSurface naming the surface and the step when Gmsh fails, or
//   when no mesh reaches min_radius_ratio (the worst ratio, the elements under
//   the bound, where the worst lies).
sim::TetMesh Tetrahedralise(const io::SurfaceMesh& surface, const VoxelMask& mount,
                            const TetrahedralisationOptions& options, TetrahedralisationReport* report = nullptr);

}  // namespace dg::stages::preop
