#pragma once

#include <string>

#include <Eigen/Core>

#include "sim/tet_mesh.h"

namespace dg::io {

// Meshing of simple solids through Gmsh's SDK, for tests, benchmarks and the
// built-in examples. Every call is deterministic: the same spec gives the same
// mesh bit for bit (one thread, fixed seed and algorithms, no user gmshrc).
// Gmsh runs in its module, loaded on the first call (io/gmsh_meshing.h); it
// is a process-wide singleton, so calls from several threads are serialised
// on a mutex. Gmsh prints nothing, and its failures become dg::Error.
// The returned mesh is in metres, has no unused nodes, is positively
// oriented (sim::OrientElements has run) and keeps Gmsh's node order, entity
// by entity, as Gmsh writes it to a file (the solver's model lays nodes out
// for its own memory access, whatever their order).

// An axis-aligned box with its min corner at the origin, so its bottom face is
// z = 0. Node sets "xmin", "xmax", "ymin", "ymax", "zmin", "zmax" (the nodes of
// each face) and "body" (all nodes); element set "body" (all elements).
struct BoxSpec {
  Eigen::Vector3d size_m{0.05, 0.05, 0.05};
  int target_tets = 20000;
  std::string Validate() const;  // empty when valid, else what is wrong
};

// An ellipsoid centred at the origin with its semi-axes along x, y, z. Node
// sets "surface" (the boundary nodes) and "body" (all nodes); element set "body".
struct EllipsoidSpec {
  Eigen::Vector3d semi_axes_m{0.03, 0.02, 0.02};
  int target_tets = 20000;
  std::string Validate() const;  // empty when valid, else what is wrong
};

// An ellipsoid with its centre at height centre_height_m above the plane z = 0,
// cut by that plane and standing on it: a solid organ on a flat mount. Node
// sets "surface" (the curved surface), "base" (the flat face on z = 0) and
// "body"; element set "body". @pre |centre_height_m| < semi_axes_m.z().
struct TruncatedEllipsoidSpec {
  Eigen::Vector3d semi_axes_m{0.022, 0.018, 0.03};
  double centre_height_m = 0.018;
  int target_tets = 8000;
  std::string Validate() const;  // empty when valid, else what is wrong
  double Volume_m3() const;      // analytic volume of the cut ellipsoid
};

// How a mesh came out, for logs and command summaries.
struct MeshReport {
  double element_size_m = 0;     // Gmsh's characteristic length on the pass kept
  int passes = 0;                // meshing passes run to approach the target count
  double volume_m3 = 0;          // sum of the element volumes
  double min_radius_ratio = 0;   // worst element quality, see RadiusRatio()
  double mean_radius_ratio = 0;
  double wall_ms = 0;            // meshing time, all passes included
};

// The element count lands within kTetCountTolerance of target_tets (the
// characteristic length is estimated from volume / target, then corrected from
// the counts of up to kMaxPasses meshings); a log warning says when a target is
// too coarse for the shape to reach.
inline constexpr double kTetCountTolerance = 0.15;
inline constexpr int kMaxPasses = 4;

// @throws dg::Error for an invalid spec, or naming the spec when Gmsh fails.
sim::TetMesh MeshBox(const BoxSpec& spec, MeshReport* report = nullptr);
sim::TetMesh MeshEllipsoid(const EllipsoidSpec& spec, MeshReport* report = nullptr);
sim::TetMesh MeshTruncatedEllipsoid(const TruncatedEllipsoidSpec& spec, MeshReport* report = nullptr);

// Writes a Gmsh ASCII mesh, format 2.2 (version = 22) or 4.1 (version = 41),
// that Gmsh and ParaView open: node i is written with tag i + 1 and element e
// with tag e + 1, in mesh order. Each element set becomes a physical volume;
// each node set becomes a physical surface of the boundary triangles whose
// three nodes it holds, except a node set named like an element set (whose
// nodes it is). Reading the file back gives the same sets, and the coordinates
// to Gmsh's 16 significant digits.
// @throws dg::Error for another version, a node set that is not a patch of the
//   boundary (a .msh file names nodes only through elements), or a failed write.
void WriteMsh(const sim::TetMesh& mesh, const std::string& path, int version);

// Element quality 3 r_in / r_circ: 1 for a regular tetrahedron, 0 for a flat
// one. The explicit solver's stable step shrinks with the smallest altitude, so
// a mesher's worst element matters more than its average.
double RadiusRatio(const sim::TetMesh& mesh, int element);

}  // namespace dg::io
